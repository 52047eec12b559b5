"""Paused workers: does a worker stopped past its lease ever overwrite a job another worker finished?

A real ``foresight serve`` and two ``foresight worker`` processes share a temporary SQLite file (or a fresh
PostgreSQL database created on ``--database-url``'s server and dropped afterwards) and one store, with the short
lease the integration tests use (1.5 s, heartbeats every 0.3 s). Both workers first run a short training and an
evaluation (their imports done). Each run then submits one job, alternately a training and an evaluation, and when
the worker holding it has reached a progress point (10 %, 30 %, 50 %, 70 % in turn) stops that worker and its child
processes (SIGSTOP) until the other worker has claimed the job after its lease ran out, run it again and finished
it; then resumes the first and waits until it has noticed its lost lease and removed its attempt folder. It then
compares the finished job's folder with the snapshot taken when the job succeeded, and every recorded artifact's
sha256 with its file.

Prints one JSON object: ``runs``; ``overwritten`` (files of the finished job changed or added after it
succeeded), ``sha_mismatch`` (recorded artifacts whose file no longer has the recorded sha256), ``lost`` (recorded
artifacts whose file is gone), ``duplicate_records`` (more than one evaluation record for a job),
``attempt_folders_left`` (a resumed attempt that did not clean up within 30 s), ``not_rerun`` (runs where the job
did not end succeeded on its second attempt: the pause did not happen as planned, so the run tests nothing);
``resumed_wrote`` (runs where the resumed worker was seen writing on into its attempt folder: the case fencing is
for); per kind the same, the artifacts checked, and the seconds per run. Each run's own line goes to stderr.

    python bench/paused_workers.py [--runs 20] [--database-url postgresql://postgres@127.0.0.1:5432/test]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import sys
import tempfile
import time
import uuid
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # tests.integration.service: the processes

from sqlalchemy import func, select  # noqa: E402

from foresight.store import folders, job_reads, queue  # noqa: E402
from foresight.store.models import Evaluation, JobEvent  # noqa: E402
from foresight.store.session import make_engine  # noqa: E402
from tests.integration.service import Service, wait_job  # noqa: E402

COLLECT = {
    "kind": "collect",
    "scenarios": ["crossing_low"],
    "seeds_per_scenario": 2,
    "max_steps": 80,
    "check_quality": False,
}
EVALUATE = {
    "kind": "evaluate",
    "scenarios": ["crossing_low"],
    "seeds_per_scenario": 4,
    "max_steps": 200,
    "planner": {"name": "goal"},
}
PAUSE_AT = (0.1, 0.3, 0.5, 0.7)
COUNTS = ("overwritten", "sha_mismatch", "lost", "duplicate_records", "attempt_folders_left", "not_rerun")


def train_spec(dataset: str, epochs: int) -> dict:
    return {
        "kind": "train",
        "dataset": dataset,
        "epochs": epochs,
        "hidden": 8,
        "blocks": 0,
        "edge_dim": 0,
        "allow_degenerate": True,
    }


def process_tree(pid: int) -> list[int]:
    """``pid`` and its descendants (Linux /proc), parents first."""
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        out.append(p)
        for task in Path(f"/proc/{p}/task").glob("*"):
            try:
                todo += [int(c) for c in (task / "children").read_text().split()]
            except OSError:
                continue
    return out


def signal_tree(pids: list[int], sig: int) -> None:
    for p in pids:
        try:
            os.kill(p, sig)
        except ProcessLookupError:
            continue


def snapshot(root: Path, job_id: str) -> dict[str, tuple[int, int, str] | None]:
    """Every file of the job's folder but its attempt folders (never entered: one may be being removed):
    (size, mtime_ns, sha256), None for a file gone between listing and reading."""
    base = root / "jobs" / job_id
    out: dict[str, tuple[int, int, str] | None] = {}
    for folder, dirs, files in os.walk(base):
        if Path(folder) == base and folders.ATTEMPTS in dirs:
            dirs.remove(folders.ATTEMPTS)
        for name in files:
            path = Path(folder) / name
            try:
                st = path.stat()
                out[str(path.relative_to(base))] = (st.st_size, st.st_mtime_ns, folders.sha256_file(path))
            except FileNotFoundError:
                out[str(path.relative_to(base))] = None
    return dict(sorted(out.items()))


def one_run(service: Service, engine, spec: dict, at: float) -> dict:  # noqa: ANN001
    """One paused-worker run of ``spec``: the counts of what went wrong (see the module docstring)."""
    root = service.tmp / "data" / "store"
    t0 = time.monotonic()
    with service.client() as client:
        job_id = client.post("/v1/jobs", json={"spec": spec}).json()["id"]
        deadline = time.time() + 180
        while (row := job_reads.get_job(engine, job_id))["progress"] < at or row["status"] != "running":
            if row["status"] not in ("queued", "running") or time.time() > deadline:
                return {"not_rerun": 1, "job": job_id, "why": f"{row['status']} before the pause point"}
            time.sleep(0.02)
        owner = int(row["lease_owner"].rsplit("-", 2)[1])
        stopped = process_tree(owner)
        signal_tree(stopped, signal.SIGSTOP)
        try:
            done = wait_job(client, job_id, timeout=300)
            files = snapshot(root, job_id)
        finally:
            signal_tree(stopped, signal.SIGCONT)
    out = {c: 0 for c in COUNTS} | {"job": job_id, "paused_pid": owner}
    if done["status"] != "succeeded" or done["attempts"] != 2:
        out["not_rerun"] = 1
        out["why"] = f"{done['status']} after {done['attempts']} attempts: {done.get('error')}"
        with engine.connect() as conn:
            events = conn.execute(
                select(JobEvent.message).where(JobEvent.job_id == job_id).order_by(JobEvent.id)
            ).scalars()
            out["events"] = [m[:300] for m in events][-15:]
        out["logs"] = str(service.tmp)
    attempts = root / "jobs" / job_id / folders.ATTEMPTS
    resumed = time.monotonic()
    seen = False
    while time.monotonic() - resumed < 2.0 or attempts.exists() and time.monotonic() - resumed < 30:
        seen |= attempts.exists()  # the resumed worker wrote on into its attempt folder
        time.sleep(0.02)
    out["resumed_wrote"] = int(seen)
    time.sleep(0.5)
    out["attempt_folders_left"] = int(attempts.exists())
    after = snapshot(root, job_id)
    out["overwritten"] = sum(after.get(name) != value for name, value in files.items()) + len(
        set(after) - set(files)
    )
    with engine.connect() as conn:
        arts = conn.execute(select(queue.artifacts).where(queue.artifacts.c.job_id == job_id)).all()
        evals = conn.execute(
            select(func.count()).select_from(Evaluation).where(Evaluation.job_id == job_id)
        ).scalar()
    for art in arts:
        path = root / art.path
        if not path.exists():
            out["lost"] += 1
        elif folders.sha256_file(path) != art.sha256:
            out["sha_mismatch"] += 1
    out["artifacts"] = len(arts)
    out["duplicate_records"] = int(evals > 1)
    out["seconds"] = round(time.monotonic() - t0, 1)
    return out


def warm_up(service: Service, dataset: str) -> None:
    """Two short trainings and two evaluations at once, so that each worker has imported what its runs need: a
    cold worker's first import of torch can hold its heartbeat thread past the short lease, which would make a run
    lose its lease before the planned pause (a run that then tests nothing)."""
    with service.client() as client:
        specs = [train_spec(dataset, 1), train_spec(dataset, 1), EVALUATE, EVALUATE]
        ids = [client.post("/v1/jobs", json={"spec": spec}).json()["id"] for spec in specs]
        for job_id in ids:
            wait_job(client, job_id, timeout=300)


def fresh_postgres(url: str) -> tuple[str, str]:
    """(SQLAlchemy URL of a new database on ``url``'s server, its name)."""
    import psycopg

    name = f"foresight_paused_{uuid.uuid4().hex[:10]}"
    with psycopg.connect(url.replace("+psycopg", ""), autocommit=True) as conn:
        conn.execute(f'CREATE DATABASE "{name}"')
    server = (
        url.replace("+psycopg", "").rsplit("/", 1)[0].replace("postgresql://", "postgresql+psycopg://", 1)
    )
    return f"{server}/{name}", name


def drop_postgres(url: str, name: str) -> None:
    import psycopg

    with psycopg.connect(url.replace("+psycopg", ""), autocommit=True) as conn:
        conn.execute(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)')


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "--runs", type=int, default=20, help="paused-worker runs, alternately training and evaluation"
    )
    ap.add_argument("--epochs", type=int, default=30, help="training epochs of a training run")
    ap.add_argument(
        "--database-url", help="a PostgreSQL server's URL (a fresh database is made there); else SQLite"
    )
    ap.add_argument("--json", action="store_true", help="(the output is always one JSON object)")
    args = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="foresight-paused-"))
    db_url, db_name = fresh_postgres(args.database_url) if args.database_url else (None, None)
    service = Service(tmp, db_url)
    engine = make_engine(db_url or f"sqlite:///{tmp / 'data' / 'foresight.db'}")
    runs: list[dict] = []
    t0 = time.monotonic()
    try:
        service.migrate()
        service.serve()
        service.worker(), service.worker()
        with service.client() as client:
            data = wait_job(client, client.post("/v1/jobs", json={"spec": COLLECT}).json()["id"], timeout=300)
        if data["status"] != "succeeded":
            raise SystemExit(f"the training data's collect job {data['status']}: {service.logs()}")
        warm_up(service, data["id"])
        for i in range(args.runs):
            kind = ("train", "evaluate")[i % 2]
            spec = train_spec(data["id"], args.epochs) if kind == "train" else EVALUATE
            at = PAUSE_AT[(i // 2) % len(PAUSE_AT)]
            run = one_run(service, engine, spec, at) | {"kind": kind, "pause_at": at}
            runs.append(run)
            print(json.dumps(run), file=sys.stderr, flush=True)
    finally:
        engine.dispose()
        service.stop()
        if db_name:
            drop_postgres(args.database_url, db_name)
    out: dict = {"database": "postgresql" if db_name else "sqlite", "runs": len(runs)}
    out |= {c: sum(r.get(c, 0) for r in runs) for c in COUNTS}
    out["per_kind"] = {
        kind: {"runs": sum(r["kind"] == kind for r in runs)}
        | {c: sum(r.get(c, 0) for r in runs if r["kind"] == kind) for c in COUNTS}
        for kind in ("train", "evaluate")
    }
    out["resumed_wrote"] = sum(r.get("resumed_wrote", 0) for r in runs)
    out["artifacts_checked"] = sum(r.get("artifacts", 0) for r in runs)
    seconds = sorted(r["seconds"] for r in runs if "seconds" in r)
    out["seconds_per_run"] = {"median": seconds[len(seconds) // 2], "max": seconds[-1]} if seconds else None
    out["wall_s"] = round(time.monotonic() - t0, 1)
    out["failed_runs"] = [r for r in runs if any(r.get(c) for c in COUNTS)]
    if not out["failed_runs"]:
        shutil.rmtree(tmp, ignore_errors=True)  # else kept: the runs' "logs" name it
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
