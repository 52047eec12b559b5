"""MLflow export against a real ``mlflow server`` (SQLite backend, its own folder and port, stopped afterwards):
a smoke training and a smoke evaluation, run with ``--local`` by the CLI and as jobs by a worker, are read back
with MlflowClient (run, job-id tag, parameters, per-epoch curves, metrics, artifacts)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest
import torch

from foresight.store import job_reads, queue
from foresight.store.registry import sync_bundles
from foresight.store.session import make_engine, upgrade
from foresight.store.settings import Settings

from .service import REPO, free_port

SMOKE_TRAIN = ["--config", str(REPO / "configs" / "training" / "smoke.yaml"), "--epochs", "2"]
MATRIX = REPO / "configs" / "scenarios" / "classic_interactions.yaml"
SMOKE_EVAL = {
    "scenarios": ["crossing_low"],
    "seeds_per_scenario": 1,
    "max_steps": 40,
    "planner": {"name": "goal"},
}
COLLECT = {"scenarios": ["crossing_low", "crossing_medium"], "seeds_per_scenario": 2, "max_steps": 100}


def _mlflow_command() -> list[str]:
    try:
        import mlflow  # noqa: F401
    except ImportError:
        if os.environ.get("CI") == "true":
            pytest.fail("mlflow is not installed (extra foresight[mlflow], part of dev)")
        pytest.skip("mlflow is not installed (pip install 'foresight[mlflow]')")
    return [sys.executable, "-m", "mlflow", "server"]


def _cli(capsys: pytest.CaptureFixture, *args: str) -> tuple[str, str]:
    """(stdout, stderr) of ``foresight ARGS`` run in this process (the CLI's code path, without its start-up)."""
    from foresight.cli.main import main

    code = main(list(args))
    out, err = capsys.readouterr()
    assert code in (0, 2), (
        f"foresight {' '.join(args)} -> {code}\n{out}\n{err}"
    )  # 2: a failed gate is a result
    return out, err


@pytest.fixture(scope="module")
def tracking(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[str, Path]]:
    """(tracking URI, a --local smoke dataset): the dataset is collected while the server starts (~20 s here)."""
    tmp = tmp_path_factory.mktemp("mlflow")
    port = free_port()
    env = {
        **os.environ,
        "MLFLOW_SERVER_ENABLE_JOB_EXECUTION": "false",
    }  # no job runner process: a faster start
    with (tmp / "server.log").open("w") as log:
        server = subprocess.Popen(
            [
                *_mlflow_command(),
                "--backend-store-uri",
                f"sqlite:///{tmp / 'mlflow.db'}",
                "--artifacts-destination",
                str(tmp / "artifacts"),
                "--host",
                "127.0.0.1",
                "--port",
                str(port),
                "--workers",
                "1",
            ],
            cwd=tmp,
            env=env,
            stdout=log,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
    try:
        from foresight.core.runtime.context import StageContext
        from foresight.core.runtime.refs import BUILTIN_CONFIG_ROOT
        from foresight.core.training.collect import CollectConfig, run_collect

        run_collect(
            CollectConfig(**COLLECT),
            StageContext(workdir=tmp / "data", resolve_bundle=lambda _: BUILTIN_CONFIG_ROOT),
        )
        url = f"http://127.0.0.1:{port}"
        deadline = time.monotonic() + 90
        while True:
            assert server.poll() is None, (tmp / "server.log").read_text()[-3000:]
            try:
                if httpx.get(f"{url}/health", timeout=2).status_code == 200:
                    break
            except httpx.HTTPError:
                pass
            assert time.monotonic() < deadline, (
                "mlflow server did not start\n" + (tmp / "server.log").read_text()
            )
            time.sleep(0.3)
        yield url, tmp / "data" / "dataset.npz"
    finally:
        os.killpg(server.pid, signal.SIGTERM)
        try:
            server.wait(timeout=15)
        except subprocess.TimeoutExpired:
            os.killpg(server.pid, signal.SIGKILL)
            server.wait()


def _runs(url: str) -> list:
    from mlflow.tracking import MlflowClient

    client = MlflowClient(tracking_uri=url)
    experiment = client.get_experiment_by_name("foresight")
    assert experiment is not None
    return client.search_runs([experiment.experiment_id], max_results=100)


def _artifacts(url: str, run_id: str, folder: str | None = None) -> set[str]:
    from mlflow.tracking import MlflowClient

    return {a.path for a in MlflowClient(tracking_uri=url).list_artifacts(run_id, folder)}


def _check_training(url: str, run) -> None:  # noqa: ANN001
    from mlflow.tracking import MlflowClient

    params, metrics = run.data.params, run.data.metrics
    assert params["config.epochs"] == "2" and params["seed"] == "0" and params["dt"] == "0.2"
    assert (
        len(params["data_hash"]) == 64 and len(params["checkpoint_sha256"]) == 64 and params["code_version"]
    )
    assert params["config.device"] == "auto" and params["device"] == (
        "cuda" if torch.cuda.is_available() else "cpu"
    )
    assert {"best.val_ade", "best.cv_val_ade", "gates_passed", "train_loss"} <= set(metrics)
    curve = MlflowClient(tracking_uri=url).get_metric_history(run.info.run_id, "val_ade")
    assert sorted(m.step for m in curve) == [1, 2]  # one point per epoch
    artifacts = _artifacts(url, run.info.run_id)
    assert {"report.html", "training_summary.json", "result.json", "checkpoint"} <= artifacts, artifacts
    assert _artifacts(url, run.info.run_id, "checkpoint") == {"checkpoint/model.pt"}


def _check_evaluation(run) -> None:  # noqa: ANN001
    params, metrics = run.data.params, run.data.metrics
    assert (
        params["planner_name"] == "goal"
        and params["model_id"] == "none"
        and params["seeds"] == "1 per scenario"
    )
    assert params["dt"] == "0.1" and len(params["config_hash"]) == 64 and params["planner.speed"] == "1.0"
    assert metrics["episodes"] == 1 and {"success_rate", "collision_rate", "timeout_rate"} <= set(metrics)
    assert run.data.tags["foresight.verdict"] in ("passed", "failed_gate")


def test_local_runs_are_exported(
    tracking: tuple[str, Path], tmp_path: Path, capsys: pytest.CaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    url, dataset = tracking
    monkeypatch.setenv("FORESIGHT_MLFLOW_TRACKING_URI", url)
    _, train_err = _cli(
        capsys, "train", "--local", "--dataset", str(dataset), *SMOKE_TRAIN, "--out", str(tmp_path / "t")
    )
    out, eval_err = _cli(
        capsys,
        "evaluate",
        "--local",
        "--matrix",
        str(MATRIX),
        "--scenarios",
        "crossing_low",
        "--seeds-per-scenario",
        "1",
        "--max-steps",
        "40",
        "--planner",
        "goal",
        "--out",
        str(tmp_path / "e"),
        "--json",
    )
    assert json.loads(out)["result"]["episodes"] == 1  # --json stays JSON: MLflow prints nothing to stdout
    assert "MLflow: run" in train_err and "MLflow: run" in eval_err
    runs = {r.data.tags.get("foresight.workdir"): r for r in _runs(url)}
    trained, evaluated = runs[str((tmp_path / "t").resolve())], runs[str((tmp_path / "e").resolve())]
    assert trained.info.status == evaluated.info.status == "FINISHED"
    assert trained.data.tags["foresight.mode"] == "local" and "foresight.job_id" not in trained.data.tags
    _check_training(url, trained)
    _check_evaluation(evaluated)
    assert {"report.html", "evaluation.json", "result.json"} <= _artifacts(url, evaluated.info.run_id)


def _finish(engine, spec: dict, timeout: float = 90.0) -> dict:  # noqa: ANN001
    job_id = queue.submit(engine, kind=spec["kind"], spec=spec)[0]["id"]
    deadline = time.time() + timeout
    while time.time() < deadline:
        job = job_reads.get_job(engine, job_id)
        if job["status"] in ("succeeded", "failed"):
            assert job["status"] == "succeeded", (job["error_type"], job["error_message"])
            return job
        time.sleep(0.05)
    raise AssertionError(f"job {job_id} still {job['status']}")


def test_worker_jobs_are_exported_with_their_job_id(tracking: tuple[str, Path], tmp_path: Path) -> None:
    import threading

    from foresight.worker.runner import JobWorker

    url, _ = tracking
    settings = Settings(
        data_dir=tmp_path,
        api_token="t",
        heartbeat_s=0.2,
        poll_s=0.05,
        shutdown_grace_s=0.3,
        model_registry=tmp_path / "none.yaml",
        mlflow_tracking_uri=url,
    )
    upgrade(settings.resolved_database_url)
    engine = make_engine(settings.resolved_database_url)
    sync_bundles(engine, settings)  # what the API does at start-up: configs/ is bundle builtin
    worker = JobWorker(settings, engine)
    thread = threading.Thread(target=worker.run, daemon=True)
    thread.start()
    try:
        data = _finish(engine, {"kind": "collect", **COLLECT})
        train = _finish(
            engine,
            {
                "kind": "train",
                "dataset": data["id"],
                "epochs": 2,
                "batch_size": 256,
                "hidden": 16,
                "blocks": 1,
            },
        )
        evaluate = _finish(engine, {"kind": "evaluate", **SMOKE_EVAL})
        logs = {
            job: [e["message"] for e in job_reads.events_after(engine, job, 0)]
            for job in (train["id"], evaluate["id"])
        }
    finally:
        worker.stop()
        worker.stop()
        thread.join(timeout=10)
        engine.dispose()
    runs = {r.data.tags.get("foresight.job_id"): r for r in _runs(url)}
    assert data["id"] not in runs  # collection is not exported
    for job in (train, evaluate):
        run = runs[job["id"]]
        assert run.info.status == "FINISHED" and run.data.tags["foresight.mode"] == "service"
        assert run.info.run_name == f"{job['kind']} {job['id'][:12]}"
        assert any(f"MLflow: run {run.info.run_id}" in m for m in logs[job["id"]]), logs[job["id"]]
    _check_training(url, runs[train["id"]])
    _check_evaluation(runs[evaluate["id"]])
