"""`foresight pipeline run|mine-seeds` and `foresight demo`.

``pipeline run -f CONFIG`` submits a ``pipeline`` job (the seed runbook as child jobs) to the server and
follows it; ``--local`` runs every stage in-process instead. ``demo`` starts a server and a worker on the
embedded SQLite default (as ``foresight up``), submits ``configs/pipelines/quickstart.yaml`` through the
HTTP API, follows it, prints the report's URL and file and the gate verdict, and stops the server.
Exit codes: 0 gates passed, 2 a required gate failed (the summary is written), 1 error or failed stage.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import socket
import subprocess
import sys
import time
from collections import defaultdict
from pathlib import Path
from typing import TYPE_CHECKING, Any

from foresight.core.errors import ConfigError, CoreError
from foresight.core.runtime.refs import BUILTIN_BUNDLE, BUILTIN_CONFIG_ROOT

if TYPE_CHECKING:
    from foresight.core.reports.pipeline_summary import PipelineResult
    from foresight.schemas import JobPublic

QUICKSTART = BUILTIN_CONFIG_ROOT / "pipelines" / "quickstart.yaml"
FINISHED = {"succeeded", "failed", "cancelled"}
MATRIX = BUILTIN_CONFIG_ROOT / "scenarios" / "classic_interactions.yaml"


def register(sub: argparse._SubParsersAction) -> None:
    from foresight.cli.client import add_connection_args

    pipe = sub.add_parser(
        "pipeline", help="the runbook as one job: collect, train, evaluate, campaign, gates, promote"
    )
    actions = pipe.add_subparsers(dest="action", required=True)
    run = actions.add_parser("run", help="run a pipeline config (on the server by default)")
    run.add_argument(
        "-f", "--file", required=True, help="pipeline YAML (e.g. configs/pipelines/quickstart.yaml)"
    )
    run.add_argument("--local", action="store_true", help="run every stage in-process, no server")
    run.add_argument(
        "--out",
        help="--local: work folder (default: a new folder under <data dir>/runs; reruns with --out resume)",
    )
    run.add_argument(
        "--workers", type=int, help="processes per episode stage (overrides the config's workers)"
    )
    run.add_argument("--no-wait", action="store_true", help="submit and print the job id")
    run.add_argument("--key", help="idempotency key of the submission")
    run.add_argument(
        "--json",
        action="store_true",
        help="print the finished job as JSON, result included (--local: the same shape)",
    )
    add_connection_args(run)
    run.set_defaults(func=cmd_run)

    mine = actions.add_parser("mine-seeds", help="mine a seed manifest: seeds where a baseline planner fails")
    mine.add_argument("--matrix", default=str(MATRIX), help="scenario matrix YAML")
    mine.add_argument(
        "--seeds",
        help="candidate seeds LO:HI (half open) or a comma list (default: each "
        "scenario's own seeds, i.e. the evaluation seeds)",
    )
    mine.add_argument("--baseline", default="orca", help="baseline planner (orca, social_force, goal)")
    mine.add_argument("--per-scenario", type=int, default=2, help="failing seeds kept per scenario")
    mine.add_argument(
        "--exclude", action="append", default=[], help="manifest whose pairs are never picked (repeatable)"
    )
    mine.add_argument("--scenarios", help="comma-separated scenario names (default: all)")
    mine.add_argument("--description", default="", help="manifest description")
    mine.add_argument("-o", "--output", required=True, help="manifest YAML to write")
    mine.set_defaults(func=cmd_mine)

    demo = sub.add_parser(
        "demo",
        help="start a server + worker, run the quickstart pipeline through the API, "
        "print the report and the gate verdict",
    )
    demo.add_argument("-f", "--file", default=str(QUICKSTART), help="pipeline YAML (default: quickstart)")
    demo.add_argument("--port", type=int, help="server port (default: a free one)")
    demo.add_argument("--concurrency", type=int, default=1, help="worker job slots")
    demo.add_argument("--keep-running", action="store_true", help="leave the server running at the end")
    demo.add_argument("--json", action="store_true", help="print the finished pipeline job as JSON")
    demo.set_defaults(func=cmd_demo)


# ------------------------------------------------------------------------------------------ helpers


def read_pipeline(path: str | Path, workers: int | None = None) -> dict[str, Any]:
    """The pipeline YAML as a spec (validated here, so a bad file fails before anything starts)."""
    from foresight.core.jobs.pipeline.config import load_pipeline_config
    from foresight.paths import user_file

    config = load_pipeline_config(user_file(str(path), "--file"))
    if workers is not None:
        config = config.model_copy(update={"workers": max(1, workers)})
    # the keys as written: a section's defaults dumped as if set would read back as a section's own matrix, which
    # the wiring check refuses wherever the pipeline's matrix is not the default one
    return config.model_dump(mode="json", exclude_unset=True)


def verdict_text(result: PipelineResult) -> str:
    head = (
        "GATES PASSED" if result.passed else "GATES FAILED (" + (", ".join(result.failed_gates) or "?") + ")"
    )
    inc = result.incumbent
    return "\n".join(
        [f"{head}: exit code {result.exit_code}"]
        + ([f"incumbent: {inc.id} ({inc.why}, sha256 {inc.sha256[:12]})"] if inc else ["incumbent: none"])
        + [f"  FAIL {f}" for f in result.failing_checks]
        + ([result.promotion.replace("`", "")] if result.promotion else [])
    )


def _stage_lines(result: PipelineResult) -> list[str]:
    return [
        f"  {st.name:<18} {st.status:<12} {'-' if st.wall_s is None else f'{st.wall_s:.0f} s':>6}  {st.headline}"
        for st in result.stages
    ]


# ------------------------------------------------------------------------------------------ local


def run_local(
    config_path: str, out: str | None, workers: int | None, quiet: bool
) -> tuple[PipelineResult, Path]:
    from foresight.core.jobs.pipeline.config import PipelineConfig
    from foresight.core.jobs.pipeline.local import LocalChildren
    from foresight.core.jobs.pipeline.runbook import run_pipeline
    from foresight.local import ModelArgs, local_context, local_workdir

    config = PipelineConfig.model_validate(read_pipeline(config_path, workers))
    if config.bundle != BUILTIN_BUNDLE:
        raise ConfigError("--local runs use the builtin bundle (configs/)", source=config_path, item="bundle")
    workdir = local_workdir(out, f"pipeline-{config.name}")
    ctx = local_context(workdir, {BUILTIN_BUNDLE: BUILTIN_CONFIG_ROOT}, quiet=quiet)
    ctx.workers = config.workers or 1
    if not quiet:
        ctx.log = lambda message: print(f"\n{message}", file=sys.stderr)
    models = ModelArgs()
    children = LocalChildren(ctx, resolve_model=models.resolve, describe_model=models.describe)
    result = run_pipeline(
        config, ctx, children, run_id=workdir.name.split("-")[-1] or "local", registry=children
    )
    return result, workdir


def cmd_run(args: argparse.Namespace) -> int:
    if args.local:
        from foresight.cli import stage

        spec = {**read_pipeline(args.file, args.workers), "kind": "pipeline"}
        (result, workdir), started = stage.run_local(
            args, spec, lambda: run_local(args.file, args.out, args.workers, quiet=args.json)
        )
        if args.json:
            stage.emit_local(args, spec, result, str, started=started, workdir=workdir)
        else:
            print("\n".join(_stage_lines(result)))
            print(f"report: {workdir / 'report.html'}")
            print(verdict_text(result))
        return result.exit_code
    from foresight.cli.client import Client, ServerUnreachable

    client = Client.from_args(args)
    spec = read_pipeline(args.file, args.workers)
    try:
        return submit_and_follow(client, spec, as_json=args.json, wait=not args.no_wait, key=args.key)
    except ServerUnreachable as exc:
        raise CoreError(f"{exc}; start one with `foresight up`, or run in-process with --local") from None


# ------------------------------------------------------------------------------------------ server


def submit_and_follow(
    client: Any,
    spec: dict[str, Any],
    *,
    as_json: bool,
    wait: bool = True,
    key: str | None = None,
    store_root: Path | None = None,
) -> int:
    body: dict[str, Any] = {"spec": {**spec, "kind": "pipeline"}}
    if key:
        body["idempotency_key"] = key
    from foresight.cli.client import dump
    from foresight.schemas import JobPublic

    job = client.fetch(JobPublic, "/v1/jobs", method="POST", json=body)
    if not wait:
        print(dump(job) if as_json else job.id)
        return 0
    if not as_json:
        print(f"pipeline job {job.id} submitted", file=sys.stderr)
    job = follow_pipeline(client, job.id, quiet=as_json)
    return report_outcome(client, job, as_json=as_json, store_root=store_root)


def follow_pipeline(client: Any, job_id: str, *, quiet: bool) -> JobPublic:
    """Poll the pipeline job until it ends: one line per child stage as it starts and ends, and a bar."""
    from foresight.local import progress_bar
    from foresight.schemas import JobsPublic

    seen: dict[str, str] = defaultdict(str)  #: child job id -> the status last printed
    with progress_bar(quiet=quiet) as bar:
        task = bar.add_task("pipeline", total=1.0, message="")
        while True:
            job = client.job(job_id)
            bar.update(task, completed=job.progress, message=f"{job.status} {job.message[:70]}")
            if not quiet and job.children:
                page = client.fetch(JobsPublic, "/v1/jobs", params={"parent_id": job_id, "limit": 50})
                for child in sorted(page.data, key=lambda c: c.created_at):
                    if child.status not in ("queued", seen[child.id]):
                        seen[child.id] = child.status
                        stage = (child.idempotency_key or child.kind).rsplit(":", 1)[-1]
                        bar.console.print(
                            f"  {stage:<18} {child.kind:<13} job {child.id[:12]}  {child.status}"
                        )
            if job.status in FINISHED:
                return job
            time.sleep(1.0)


def report_outcome(client: Any, public: JobPublic, *, as_json: bool, store_root: Path | None = None) -> int:
    from foresight.cli.client import plain

    job = plain(public)  # the finished job as the server sent it (what --json prints of it)
    url = f"{client.base_url}/ui/jobs/{public.id}/files/report.html"
    path = (store_root / "jobs" / public.id / "report.html") if store_root else None
    from foresight.core.reports.pipeline_summary import PipelineResult

    result = PipelineResult.model_validate(job["result"]) if job["status"] == "succeeded" else None
    if as_json:  # the job, as every stage command's --json prints it (--local: the same shape)
        print(json.dumps(job, indent=2))
    else:
        if result is not None:
            print("\n".join(_stage_lines(result)))
        print(f"report: {url}")
        if path:
            print(f"report file: {path}")
        if result is not None:
            print(verdict_text(result))
        else:
            err = public.error
            print(
                f"pipeline {public.status}: {err.type if err else ''}: {err.message if err else ''}"
                f"\n(retry with `foresight jobs retry {public.id}`: finished stages are not run again)"
            )
    return 1 if result is None else result.exit_code


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _wait_healthy(url: str, proc: subprocess.Popen, timeout: float = 60.0) -> None:
    from foresight.cli.client import ApiError, Client, ServerUnreachable
    from foresight.schemas import Health

    client = Client(url, None, timeout=2.0)
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise CoreError(f"the server exited with code {proc.returncode} before it was ready")
        try:
            client.fetch(Health, "/healthz")
            return
        except (ApiError, ServerUnreachable):
            pass
        time.sleep(0.3)
    raise CoreError(f"the server at {url} did not become ready within {timeout:.0f} s")


def cmd_demo(args: argparse.Namespace) -> int:
    from foresight.cli.client import Client
    from foresight.store.settings import Settings

    spec = read_pipeline(args.file)  # fail on a bad config before starting anything
    settings = Settings()
    port = args.port or _free_port()
    url = f"http://127.0.0.1:{port}"
    env = {**os.environ, "FORESIGHT_API_URL": url}
    print(
        f"starting the Foresight server and a worker on {url} (database {settings.resolved_database_url}, "
        f"store {settings.store_root})",
        file=sys.stderr,
    )
    settings.data_dir.mkdir(parents=True, exist_ok=True)
    log_path = (settings.data_dir / "demo-server.log").resolve()
    print(f"server log: {log_path}", file=sys.stderr)
    with log_path.open("a") as log:
        proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "foresight.cli.main",
                "up",
                "--port",
                str(port),
                "--concurrency",
                str(max(1, args.concurrency)),
            ],
            env=env,
            start_new_session=True,
            stdout=log,
            stderr=subprocess.STDOUT,
        )
    code = 1
    try:
        _wait_healthy(url, proc)
        client = Client(url, Settings().client_token())
        print(f"dashboard: {url}/ui", file=sys.stderr)
        code = submit_and_follow(client, spec, as_json=args.json, store_root=settings.store_root)
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        code = 130
    finally:
        if args.keep_running and proc.poll() is None:
            print(
                f"server still running on {url} (pid {proc.pid}); stop it with: kill {proc.pid}",
                file=sys.stderr,
            )
        else:
            _stop(proc)
    return code


def _stop(proc: subprocess.Popen) -> None:
    if proc.poll() is not None:
        return
    proc.send_signal(signal.SIGTERM)
    try:
        proc.wait(timeout=30)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait(timeout=10)


# ------------------------------------------------------------------------------------------ seeds


def cmd_mine(args: argparse.Namespace) -> int:
    from foresight.core.jobs.pipeline.seeds import (
        mine_failures,
        parse_seed_range,
        read_manifest_pairs,
        write_manifest,
    )

    seeds = parse_seed_range(args.seeds) if args.seeds else None
    exclude: set[tuple[str, int]] = set()
    for path in args.exclude:
        exclude |= read_manifest_pairs(path)
    scenarios = [s.strip() for s in args.scenarios.split(",") if s.strip()] if args.scenarios else None

    from foresight.local import progress_bar

    with progress_bar(quiet=False) as bar:
        task = bar.add_task("mine-seeds", total=1.0, message="")
        found = mine_failures(
            args.matrix,
            seeds=seeds,
            baseline=args.baseline,
            per_scenario=args.per_scenario,
            scenarios=scenarios,
            exclude=exclude,
            progress=lambda fraction, message: bar.update(task, completed=fraction, message=message[:60]),
        )
    command = " ".join(["foresight pipeline mine-seeds", *_argv_for(args)])
    header = (
        f"Mined by: {command}\nSeeds where the {args.baseline} baseline does not reach the goal, the first "
        f"{args.per_scenario} per scenario in seed order\n(candidate seeds: "
        f"{args.seeds or 'each scenario own seeds = the evaluation seeds'}"
        + (f"; excluding {', '.join(args.exclude)}" if args.exclude else "")
        + ")."
    )
    path = write_manifest(args.output, found, args.description or f"{args.baseline} failures", header)
    print(f"{sum(len(v) for v in found.values())} seeds in {len(found)} scenarios -> {path}")
    return 0


def _argv_for(args: argparse.Namespace) -> list[str]:
    out = []
    if args.matrix != str(MATRIX):
        out += ["--matrix", args.matrix]
    if args.seeds:
        out += ["--seeds", args.seeds]
    out += ["--baseline", args.baseline, "--per-scenario", str(args.per_scenario)]
    for e in args.exclude:
        out += ["--exclude", _rel(e)]
    if args.scenarios:
        out += ["--scenarios", args.scenarios]
    if args.description:
        out += ["--description", repr(args.description)]
    return [*out, "-o", _rel(args.output)]


def _rel(path: str) -> str:
    try:
        return Path(path).resolve().relative_to(BUILTIN_CONFIG_ROOT.parent).as_posix()
    except ValueError:
        return path
