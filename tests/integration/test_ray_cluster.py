"""Episodes on a real two-node Ray cluster (``ray start --head`` and ``ray start --address``, 1 CPU each, separate
processes): an evaluation and a campaign submitted over HTTP with ``executor: ray`` run on both nodes and their
records equal the local executor's; a node SIGKILLed mid-run loses no episode and duplicates none; a cancelled job leaves no task
holding a CPU. The cluster is stopped at the end."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest

from foresight.core.evaluation.config import EvaluationConfig
from foresight.core.evaluation.runner import read_records, run_evaluation
from foresight.core.runtime.refs import BUILTIN_CONFIG_ROOT
from tests.results import without

from .service import Service, free_port, wait_job

pytestmark = pytest.mark.slow
RAY = str(Path(sys.executable).with_name("ray"))
EVALUATE = {
    "kind": "evaluate",
    "scenarios": ["crossing_low", "head_on_corridor_high"],
    "seeds_per_scenario": 3,
    "max_steps": 150,
    "planner": {"name": "predictive", "model": "cv"},
}
CAMPAIGN = {
    "kind": "campaign",
    "scenarios": ["crossing_low"],
    "seeds_per_scenario": 1,
    "max_steps": 100,
    "seed_manifest": "seeds/classic_eval_hard_smoke.yaml",
    "planner": {"name": "predictive", "model": "cv"},
    "variants": [{"name": "base"}, {"name": "slow", "config": {"max_speed_ratio": 0.8}}],
}
#: execution facts, not outcomes: wall-clock values, the node, the code version
NOISE = {"timing", "code_version"}


class Cluster:
    def __init__(self, tmp: Path):
        self.port = free_port()
        self.address = f"127.0.0.1:{self.port}"
        # GCS health checks every 0.5 s, a node dead after 4 failed ones: a killed node is noticed in ~2 s instead of
        # ~15 s (3 s x 5, Ray's default); a check fails only on a refused connection or no answer in 10 s
        self.env = {
            **os.environ,
            "RAY_USAGE_STATS_ENABLED": "0",
            "RAY_health_check_period_ms": "500",
            "RAY_health_check_failure_threshold": "4",
        }
        self.tmp = tmp
        self.head: subprocess.Popen | None = None
        self.node: subprocess.Popen | None = None

    def _spawn(self, *args: str) -> subprocess.Popen:
        """``ray start ... --block`` in a session of its own: killing its process group stops exactly that node
        (never ``ray stop``, which stops every Ray process of the user on the machine)."""
        return subprocess.Popen(
            [RAY, "start", *args, "--num-cpus", "1", "--block"],
            env=self.env,
            start_new_session=True,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )

    def start(self) -> None:
        self.head = self._spawn(
            "--head", "--port", str(self.port), "--include-dashboard", "false", "--disable-usage-stats"
        )
        self.wait_cpus(1)
        self.start_node()

    def start_node(self) -> None:
        self.node = self._spawn("--address", self.address)
        self.wait_cpus(2)

    def nodes_alive(self) -> int:
        out = subprocess.run(
            [sys.executable, "-c", _ALIVE, self.address],
            env=self.env,
            capture_output=True,
            text=True,
            timeout=60,
        )
        found = re.search(r"^alive (\d+)$", out.stdout, re.M)  # Ray may print its own notices to stdout too
        return int(found.group(1)) if found else 0

    def wait_cpus(self, n: int, timeout: float = 90) -> None:
        deadline = time.time() + timeout
        while time.time() < deadline:
            if self.nodes_alive() >= n:
                return
            time.sleep(1)
        raise AssertionError(f"the Ray cluster did not reach {n} nodes")

    def kill_node(self) -> None:
        assert self.node is not None
        os.killpg(self.node.pid, signal.SIGKILL)
        self.node.wait(timeout=30)

    def stop(self) -> None:
        for proc in (self.node, self.head):
            if proc is not None and proc.poll() is None:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait(timeout=30)


_ALIVE = (
    "import ray, sys; ray.init(address=sys.argv[1], logging_level='ERROR', log_to_driver=False); "
    "print('alive', sum(1 for n in ray.nodes() if n['Alive']))"
)


@pytest.fixture(scope="module")
def cluster(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Cluster]:
    # no token authentication on this private test cluster: the head, its node, the service's worker (which
    # inherits this process's environment) and this test process all agree
    saved = os.environ.get("RAY_AUTH_MODE")
    os.environ["RAY_AUTH_MODE"] = "disabled"
    c = Cluster(tmp_path_factory.mktemp("ray"))
    try:
        c.start()
        yield c
    finally:
        c.stop()
        if saved is None:
            del os.environ["RAY_AUTH_MODE"]
        else:
            os.environ["RAY_AUTH_MODE"] = saved


def _local_records(tmp: Path) -> list[dict]:
    from foresight.local import local_context

    ctx = local_context(tmp / "local", {"builtin": BUILTIN_CONFIG_ROOT}, quiet=True)
    run_evaluation(EvaluationConfig(**{k: v for k, v in EVALUATE.items() if k != "kind"}), ctx)
    return [without(r.model_dump(mode="json"), NOISE) for r in read_records(ctx.workdir / "episodes.jsonl")]


def _run_over_http(
    cluster: Cluster, tmp_path: Path, spec: dict, read: Callable[[httpx.Client, dict], Any]
) -> tuple[dict, Any]:
    """Submit ``spec`` with the Ray executor to a real server + worker on ``cluster``; the succeeded job and what
    ``read(client, job)`` fetched from the server before it stopped."""
    service = Service(tmp_path, ray_address=cluster.address)
    try:
        service.migrate()
        service.serve()
        service.worker()
        with service.client() as client:
            resp = client.post("/v1/jobs", json={"spec": {**spec, "executor": "ray"}})
            assert resp.status_code == 201, resp.text
            job = wait_job(client, resp.json()["id"], timeout=240)
            assert job["status"] == "succeeded", (job["error"], service.logs())
            return job, read(client, job)
    finally:
        service.stop()


def _episodes(client: httpx.Client, job_id: str, name: str) -> list[dict]:
    return [json.loads(line) for line in client.get(f"/v1/jobs/{job_id}/artifacts/{name}").text.splitlines()]


def test_evaluation_over_http_runs_on_both_nodes_and_equals_local(cluster: Cluster, tmp_path: Path) -> None:
    _, records = _run_over_http(
        cluster, tmp_path, EVALUATE, lambda c, job: _episodes(c, job["id"], "episodes.jsonl")
    )
    assert len({r["timing"]["node"] for r in records}) == 2  # both nodes ran episodes
    assert [without(r, NOISE) for r in records] == _local_records(tmp_path)


def test_campaign_over_http_runs_on_both_nodes_and_equals_local(cluster: Cluster, tmp_path: Path) -> None:
    from foresight.core.evaluation.campaign import run_campaign
    from foresight.core.evaluation.config import CampaignConfig
    from foresight.core.render.episode_trace import read_compact, trace_name
    from foresight.local import local_context

    def read(c: httpx.Client, job: dict) -> tuple[dict, dict]:
        """Each cell's records, and each cell's first global-suite episode with its trace as the service serves it
        (a Ray node wrote it into the cell's own run folder)."""
        ranked = job["result"]["ranked"]
        records = {cell["key"]: _episodes(c, job["id"], cell["episodes_file"]) for cell in ranked}
        traces = {}
        for rank, cell in enumerate(ranked, start=1):
            listed = c.get(f"/v1/campaigns/{job['id']}/cells/{rank}/episodes").json()
            assert listed and all(e["trace"] for e in listed), listed
            traces[cell["key"]] = (listed[0], c.get(listed[0]["trace"]).json())
        return records, traces

    job, (cells, traces) = _run_over_http(cluster, tmp_path, CAMPAIGN, read)
    assert job["result"]["execution"]["executor"] == "ray" and job["result"]["execution"]["cpus"] == 2
    assert (
        len({r["timing"]["node"] for records in cells.values() for r in records}) == 2
    )  # both nodes ran episodes
    ctx = local_context(tmp_path / "local", {"builtin": BUILTIN_CONFIG_ROOT}, quiet=True)
    local = run_campaign(CampaignConfig(**{k: v for k, v in CAMPAIGN.items() if k != "kind"}), ctx)
    assert set(cells) == {c.key for c in local.ranked}
    for c in local.ranked:
        expected = [
            without(r.model_dump(mode="json"), NOISE) for r in read_records(ctx.workdir / c.episodes_file)
        ]
        assert [without(r, NOISE) for r in cells[c.key]] == expected, c.key
        episode, trace = traces[c.key]
        local_trace = read_compact(ctx.workdir / c.run_dir / trace_name(episode["scenario"], episode["seed"]))
        assert trace["robot"] == local_trace["robot"] and trace["outcome"] == episode["outcome"], c.key


def test_node_killed_mid_run_loses_and_duplicates_nothing(cluster: Cluster, tmp_path: Path) -> None:
    import ray

    from foresight.core.runtime.cluster import RAY_ADDRESS_ENV
    from foresight.local import local_context

    ray.shutdown()
    os.environ[RAY_ADDRESS_ENV] = cluster.address
    try:
        ctx = local_context(tmp_path / "ray", {"builtin": BUILTIN_CONFIG_ROOT}, quiet=True)
        done: list[str] = []
        ctx.progress = lambda fraction, message="": done.append(message)  # noqa: ARG005
        config = EvaluationConfig(**{k: v for k, v in EVALUATE.items() if k != "kind"}, executor="ray")
        killer = threading.Thread(target=lambda: (_wait_for(lambda: len(done) >= 3), cluster.kill_node()))
        killer.start()
        run_evaluation(config, ctx)
        killer.join()
        records = read_records(ctx.workdir / "episodes.jsonl")
    finally:
        ray.shutdown()
        del os.environ[RAY_ADDRESS_ENV]
        cluster.node = None
    _wait_for(
        lambda: cluster.nodes_alive() == 1, timeout=90
    )  # the second node is really gone (once GCS noticed)
    assert sorted((r.scenario, r.seed) for r in records) == sorted({(r.scenario, r.seed) for r in records})
    assert [without(r.model_dump(mode="json"), NOISE) for r in records] == _local_records(tmp_path)
    cluster.start_node()  # a fresh second node for the tests after this one


def test_cancelled_job_leaves_no_ray_task_running(cluster: Cluster, tmp_path: Path) -> None:
    import ray

    service = Service(tmp_path, ray_address=cluster.address)
    long_run = {**EVALUATE, "seeds_per_scenario": 12, "max_steps": 1500, "executor": "ray"}
    ray.shutdown()
    ray.init(
        address=cluster.address, logging_level="ERROR", log_to_driver=False
    )  # to watch the cluster's CPUs
    try:
        service.migrate()
        service.serve()
        service.worker()
        with service.client() as client:
            job_id = client.post("/v1/jobs", json={"spec": long_run}).json()["id"]
            _wait_for(lambda: client.get(f"/v1/jobs/{job_id}").json()["progress"] > 0, timeout=240)
            assert ray.available_resources().get("CPU", 0) < 2  # episodes are running
            t0 = time.time()
            assert client.post(f"/v1/jobs/{job_id}/cancel").status_code in (200, 202)
            _wait_for(lambda: ray.available_resources().get("CPU", 0) == 2, timeout=30)
            freed_s = time.time() - t0
            assert wait_job(client, job_id, timeout=30)["status"] == "cancelled"
    finally:
        service.stop()
        ray.shutdown()
    # every CPU free again: no task of the cancelled job still runs (the issue asks for 2 s; the bound leaves room
    # for a loaded 2-core machine and the cluster's resource reports)
    print(f"cluster CPUs free {freed_s:.2f} s after the cancel request")
    assert freed_s < 10


def _wait_for(condition, timeout: float = 120) -> None:  # noqa: ANN001
    deadline = time.time() + timeout
    while time.time() < deadline:
        if condition():
            return
        time.sleep(0.2)
    raise AssertionError("condition not met in time")
