"""Fencing: a worker paused (SIGSTOP) past its lease during training or evaluation, while another worker runs the
job again and finishes it, then resumed, never changes the finished job's files: every recorded sha256 still
matches its file, and the paused attempt's own files are gone once it notices its lost lease."""

from __future__ import annotations

import signal
import time
from pathlib import Path

import pytest
from sqlalchemy import select

from foresight.store import folders, job_reads, queue
from foresight.store.session import make_engine

from .service import Service, wait_job

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


def _train(dataset: str) -> dict:
    return {
        "kind": "train",
        "dataset": dataset,
        "epochs": 30,
        "hidden": 8,
        "blocks": 0,
        "edge_dim": 0,
        "allow_degenerate": True,
    }


def _paused_past_lease(service: Service, engine, spec: dict, at: float) -> None:  # noqa: ANN001
    """Run ``spec`` on a worker, stop that worker at progress ``at``, let a second worker finish the job, resume
    the first and give it time to write on; then check the job's files against their records."""
    client = service.client()
    paused = service.worker()
    job_id = client.post("/v1/jobs", json={"spec": spec}).json()["id"]
    deadline = time.time() + 120
    while (row := job_reads.get_job(engine, job_id))["progress"] < at or row["status"] != "running":
        assert row["status"] in ("queued", "running") and time.time() < deadline, (row, service.logs())
        time.sleep(0.02)
    paused.send_signal(signal.SIGSTOP)
    other = service.worker()
    try:
        done = wait_job(client, job_id, timeout=180)
        assert done["status"] == "succeeded" and done["attempts"] == 2, (done, service.logs())
    finally:
        paused.send_signal(signal.SIGCONT)
    time.sleep(2.0)  # the resumed worker writes on until its next heartbeat says the lease is lost
    with engine.connect() as conn:
        arts = conn.execute(select(queue.artifacts).where(queue.artifacts.c.job_id == job_id)).all()
    root = service.tmp / "data" / "store"
    assert arts
    for art in arts:
        assert folders.sha256_file(root / art.path) == art.sha256, f"{art.path} was overwritten"
    assert not (
        root / "jobs" / job_id / folders.ATTEMPTS
    ).exists()  # the paused attempt cleaned up after itself
    for proc in (paused, other):
        proc.send_signal(signal.SIGTERM)
        proc.wait(timeout=30)
    client.close()


@pytest.mark.parametrize("stage", ["train", "evaluate"])
def test_a_worker_paused_past_its_lease_never_overwrites_the_results(service: Service, stage: str) -> None:
    service.migrate()
    service.serve()
    engine = make_engine(f"sqlite:///{service.tmp / 'data' / 'foresight.db'}")
    if stage == "train":
        with service.client() as client:
            first = service.worker()
            data = wait_job(client, client.post("/v1/jobs", json={"spec": COLLECT}).json()["id"], timeout=120)
            assert data["status"] == "succeeded", data
            first.send_signal(signal.SIGTERM)
            first.wait(timeout=30)
        _paused_past_lease(service, engine, _train(data["id"]), at=0.1)
    else:
        _paused_past_lease(service, engine, EVALUATE, at=0.2)
    engine.dispose()


def test_attempt_folders_resume_and_publish(tmp_path: Path) -> None:
    """An attempt starts from a copy of the previous one's files; publishing moves them into the job's folder."""
    root = tmp_path / "store"
    first = folders.start_attempt(root, "job1")
    (first / "checkpoints").mkdir()
    (first / "checkpoints" / "last.pt").write_text("epoch 3")
    (first / "checkpoints" / ".last.pt.x.tmp").write_text("half")
    second = folders.start_attempt(root, "job1")
    assert second != first and (second / "checkpoints" / "last.pt").read_text() == "epoch 3"
    assert not (second / "checkpoints" / ".last.pt.x.tmp").exists()
    (second / "checkpoints" / "last.pt").write_text("epoch 9")
    arts = folders.scan(root, "jobs/job1", source=second)
    assert [a["path"] for a in arts] == ["jobs/job1/checkpoints/last.pt"]
    folders.publish(root, "job1", second)
    folders.drop_attempts(root, "job1")
    (first / "checkpoints").mkdir(parents=True, exist_ok=True)  # a paused attempt writing on into its folder
    (first / "checkpoints" / "last.pt").write_text("epoch 4")
    assert (root / "jobs" / "job1" / "checkpoints" / "last.pt").read_text() == "epoch 9"
    assert folders.scan(root, "jobs/job1") == [dict(arts[0], path="jobs/job1/checkpoints/last.pt")]


def test_a_paused_evaluation_worker_never_overwrites_the_results_on_postgresql(
    tmp_path: Path, pg_url: str
) -> None:
    service = Service(tmp_path, database_url=pg_url)
    engine = make_engine(pg_url)
    try:
        service.migrate()
        service.serve()
        _paused_past_lease(service, engine, EVALUATE, at=0.2)
    finally:
        service.stop()
        engine.dispose()
