"""The Ray executor on a real local Ray instance (one per module, 2 CPUs): collect on Ray equals collect in-process
(the same dataset bytes), at most a window of tasks is ever in flight, a planner that raises is a recorded episode
outcome (no retry loop, no failed job), every result names its executor and CPUs, training as a Ray task falls back
to a CPU on a cluster without GPUs (device: cuda there is an error naming ``device``) and writes the checkpoint a
local run writes, and an address nobody answers at is one readable line naming it (CLI exit != 0; a service job
fails with it). Heavier cluster behaviour (two nodes, a node killed, cancellation) is
tests/integration/test_ray_cluster.py."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from foresight.core.errors import ConfigError
from foresight.core.evaluation.config import EvaluationConfig
from foresight.core.evaluation.runner import run_evaluation
from foresight.core.jobs.results import execution_of
from foresight.core.runtime.refs import BUILTIN_CONFIG_ROOT
from foresight.core.training.collect import CollectConfig, run_collect

from .service import Service, free_port, wait_job

pytestmark = pytest.mark.slow
REPO = Path(__file__).resolve().parents[2]
COLLECT = {
    "scenarios": ["crossing_low", "head_on_corridor_high"],
    "seeds_per_scenario": 2,
    "max_steps": 120,
    "policy": "goal_noisy",
}


@pytest.fixture(scope="module")
def ray_instance() -> Iterator[None]:
    """A local Ray instance of this test process (stopped at the end); its workers import this repository's tests
    (the in-process planner below)."""
    import ray

    saved = os.environ.get("RAY_AUTH_MODE")
    os.environ["RAY_AUTH_MODE"] = "disabled"
    ray.shutdown()
    ray.init(
        address="local",
        num_cpus=2,
        include_dashboard=False,
        log_to_driver=False,
        logging_level="ERROR",
        runtime_env={"env_vars": {"PYTHONPATH": str(REPO)}},
    )
    try:
        yield
    finally:
        ray.shutdown()
        if saved is None:
            os.environ.pop("RAY_AUTH_MODE", None)
        else:
            os.environ["RAY_AUTH_MODE"] = saved


def _ctx(folder: Path):  # noqa: ANN202
    from foresight.local import local_context

    return local_context(folder, {"builtin": BUILTIN_CONFIG_ROOT}, quiet=True)


def test_collect_on_ray_writes_the_dataset_collect_writes_in_process(
    ray_instance: None, tmp_path: Path
) -> None:
    local = run_collect(CollectConfig(**COLLECT), _ctx(tmp_path / "local"))
    on_ray = run_collect(CollectConfig(**COLLECT, executor="ray"), _ctx(tmp_path / "ray"))
    assert on_ray.sha256 == local.sha256  # the very same file: samples, splits, metadata
    assert (tmp_path / "ray" / on_ray.dataset).read_bytes() == (
        tmp_path / "local" / local.dataset
    ).read_bytes()
    assert on_ray.outcomes == local.outcomes and sum(local.outcomes.values()) == 4
    assert local.execution is not None and local.execution.executor == "local"
    ran = execution_of("collect", on_ray.model_dump(mode="json"))
    assert ran is not None and ran.executor == "ray" and ran.cpus == 2 and ran.address == "local"


def test_never_more_than_the_window_in_flight(ray_instance: None) -> None:
    import ray

    from foresight.core.evaluation import ray_executor
    from foresight.core.runtime.context import StageContext

    pulled: list[int] = []

    def items() -> Iterator[int]:
        for i in range(12):
            pulled.append(i)
            yield i

    def square(x: int) -> int:  # defined here: pickled by value, so Ray workers need not import this module
        return x * x

    ahead = []
    results = []
    task = ray.remote(num_cpus=1)(square)
    for value in ray_executor.run_tasks(task, (), items(), StageContext(workdir=Path(".")), window=3):
        results.append(value)
        ahead.append(len(pulled) - len(results))  # submitted but not yet handed back
    assert sorted(results) == [i * i for i in range(12)]
    assert max(ahead) <= 3 - 1 and len(pulled) == 12  # the one just handed back was one of the 3


def test_a_raising_planner_on_ray_is_a_recorded_episode_outcome(ray_instance: None, tmp_path: Path) -> None:
    from foresight.core.planners.registry import register

    register("tests.unit.planners.user_planner:broken_factory")  # Ray workers import it by name
    config = EvaluationConfig(
        scenarios=["crossing_low"],
        seeds_per_scenario=2,
        max_steps=50,
        executor="ray",
        planner={"name": "tests.unit.planners.user_planner:broken_factory"},
    )
    result = run_evaluation(config, _ctx(tmp_path))
    assert (
        result.episodes == 2 and result.taxonomy.get("planner_error") == 2
    )  # recorded, not retried, not failed
    assert (
        len(list((tmp_path / "traces").glob("*.json.gz"))) == 2
    )  # every episode's trace in the job's folder
    assert result.execution is not None and result.execution.executor == "ray" and result.execution.cpus == 2


def test_an_unreachable_ray_address_is_one_line_naming_it(tmp_path: Path) -> None:
    address = f"127.0.0.1:{free_port()}"  # nothing listens there
    env = {**os.environ, "FORESIGHT_RAY_ADDRESS": address, "RAY_AUTH_MODE": "disabled"}
    matrix = BUILTIN_CONFIG_ROOT / "scenarios" / "classic_interactions.yaml"
    out = subprocess.run(
        [
            str(Path(sys.executable).with_name("foresight")),
            "evaluate",
            "--local",
            "--executor",
            "ray",
            "--matrix",
            str(matrix),
            "--scenarios",
            "crossing_low",
            "--seeds-per-scenario",
            "1",
            "--max-steps",
            "20",
            "--planner",
            "goal",
            "--out",
            str(tmp_path),
        ],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert out.returncode != 0
    lines = [line for line in out.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and address in lines[0] and "unreachable" in lines[0], out.stderr

    # a service job with that address fails, its error that same one line
    service = Service(tmp_path / "service", ray_address=address)
    try:
        service.migrate()
        service.serve()
        service.worker()
        with service.client() as client:
            spec = {
                "kind": "evaluate",
                "scenarios": ["crossing_low"],
                "seeds_per_scenario": 1,
                "max_steps": 20,
                "planner": {"name": "goal"},
                "executor": "ray",
            }
            job = wait_job(client, client.post("/v1/jobs", json={"spec": spec}).json()["id"], timeout=120)
    finally:
        service.stop()
    assert job["status"] == "failed", job
    message = job["error"]["message"]
    assert address in message and "unreachable" in message and "\n" not in message, job["error"]


def test_training_as_a_ray_task_falls_back_to_a_cpu_and_writes_the_local_checkpoint(
    ray_instance: None, tmp_path: Path
) -> None:
    import torch

    from foresight.core.jobs.kinds import KINDS
    from foresight.core.predict.nn.checkpoint import load_predictor, read_checkpoint
    from foresight.core.training.config import TrainConfig

    data = run_collect(CollectConfig(**COLLECT, val_fraction=0.25), _ctx(tmp_path / "data"))
    dataset = str(tmp_path / "data" / data.dataset)
    fast = {
        "dataset": dataset,
        "epochs": 2,
        "batch_size": 64,
        "hidden": 16,
        "blocks": 1,
        "threads": 1,
        "allow_degenerate": True,
    }
    train = KINDS["train"].run
    local = train(TrainConfig(**fast), _ctx(tmp_path / "local"))
    on_ray = train(TrainConfig(**fast, executor="ray"), _ctx(tmp_path / "ray"))
    assert on_ray.execution is not None and on_ray.execution.executor == "ray"
    assert on_ray.execution.gpus == 0 and on_ray.execution.cpus == 1  # no GPU here: one CPU
    assert local.device == on_ray.device == on_ray.execution.device == "cpu"  # device: auto on a CPU
    assert on_ray.execution.describe().endswith(", trained on cpu")
    assert (
        Path(on_ray.checkpoint) == tmp_path / "ray" / "model.pt"
        and Path(on_ray.summary).parent == tmp_path / "ray"
    )
    assert (on_ray.best_epoch, on_ray.val_ade, on_ray.val_fde) == (
        local.best_epoch,
        local.val_ade,
        local.val_fde,
    )
    a, b = read_checkpoint(local.checkpoint), read_checkpoint(on_ray.checkpoint)
    assert a["model"].keys() == b["model"].keys()
    assert all(torch.equal(a["model"][k], b["model"][k]) for k in a["model"])  # same weights, same format
    load_predictor(on_ray.checkpoint)  # and it loads as any checkpoint does
    with pytest.raises(ConfigError, match="device: cuda, but the Ray cluster .* has no GPU") as err:
        train(TrainConfig(**fast, executor="ray", device="cuda"), _ctx(tmp_path / "cuda"))
    assert err.value.item == "device"
