"""A crowd-size bomb and oversized settings are refused at submission (422 naming the setting, in under a
second, nothing stored), and a job that allocates past the worker's memory limit fails with a reason while the
worker lives on: through the real server and worker processes."""

from __future__ import annotations

import io
import tarfile
import time
from pathlib import Path

import httpx

from .service import Service, wait_job

#: a 10^6 m pedestrian route at 2 pedestrians per m^2: twelve million pedestrians in a few hundred bytes
LONG_ROUTE_MAP = b"""format: foresight.map/1
name: long
width: 40
height: 30
obstacles: []
robot_spawn_zones: [{rect: [3, 13.5, 3, 3]}]
robot_goal_zones: [{rect: [34, 13.5, 3, 3]}]
robot_routes: [{spawn: 0, goal: 0, waypoints: [[4.5, 15], [35.5, 15]]}]
ped_spawn_zones: [{rect: [17.5, 1, 2.5, 2]}]
ped_goal_zones: [{rect: [17.5, 27, 2.5, 2]}]
ped_routes: [{spawn: 0, goal: 0, waypoints: [[18.75, 2], [18.75, 1000000], [18.75, 28]]}]
"""
#: a plaza full of walkers: within every limit, but its trace alone takes ~250 MB
PLAZA_MAP = b"""format: foresight.map/1
name: plaza
width: 100
height: 100
obstacles: []
robot_spawn_zones: [{rect: [1, 1, 2, 2]}]
robot_goal_zones: [{rect: [96, 96, 2, 2]}]
robot_routes: [{spawn: 0, goal: 0, waypoints: [[2, 2], [97, 97]]}]
ped_crowded_zones: [{rect: [10, 10, 80, 80]}]
"""
MATRIX = b"""map_search_paths: [../maps]
scenarios:
- name: bomb
  map_file: long.yaml
  simulation_config: {max_episode_steps: 100, ped_density: 2}
  seeds: [1]
- name: plaza
  map_file: plaza.yaml
  simulation_config: {max_episode_steps: 2500, population_size: 2500}
  seeds: [1]
"""


def _bundle(client: httpx.Client) -> None:
    buf = io.BytesIO()
    with tarfile.open(fileobj=buf, mode="w:gz") as tar:
        for name, data in {
            "maps/long.yaml": LONG_ROUTE_MAP,
            "maps/plaza.yaml": PLAZA_MAP,
            "scenarios/m.yaml": MATRIX,
        }.items():
            info = tarfile.TarInfo(name)
            info.size = len(data)
            tar.addfile(info, io.BytesIO(data))
    r = client.post(
        "/v1/bundles",
        params={"name": "crowds"},
        content=buf.getvalue(),
        headers={"Content-Type": "application/gzip"},
    )
    assert r.status_code == 201, r.text


def _refused(client: httpx.Client, spec: dict) -> str:
    """The 422 body of a refused submission, as text, after checking it is refused in under a second (the
    faster of two tries: the first may pay for imports a busy test machine makes slow)."""
    took = []
    for _ in range(2):
        t0 = time.perf_counter()
        r = client.post("/v1/jobs", json={"spec": spec, "timeout_s": 120})
        took.append(time.perf_counter() - t0)
        assert r.status_code == 422, r.text
    assert min(took) < 1.0, f"refused after {min(took):.2f} s"
    return r.text


def test_bombs_are_refused_and_a_memory_overrun_fails_the_job(tmp_path: Path) -> None:
    service = Service(tmp_path, worker_memory_mb="350")
    try:
        service.migrate()
        service.serve()
        service.worker()
        with service.client() as client:
            _bundle(client)
            bomb = {
                "kind": "evaluate",
                "bundle": "crowds",
                "matrix": "scenarios/m.yaml",
                "scenarios": ["bomb"],
                "seeds_per_scenario": 1,
                "planner": {"name": "goal"},
            }
            body = _refused(client, bomb)
            assert "ped_density" in body and "pedestrians" in body and "5000" in body, body
            simulate = {
                "kind": "simulate",
                "bundle": "crowds",
                "matrix": "scenarios/m.yaml",
                "scenarios": ["bomb"],
            }
            assert "ped_density" in _refused(client, simulate)

            many = {
                "kind": "evaluate",
                "scenarios": ["crossing_low"],
                "seeds_per_scenario": 1,
                "planner": {
                    "name": "predictive",
                    "model": "cv",
                    "config": {"sampling": {"speed_ratios": [0.5] * 100_000}},
                },
            }
            body = _refused(client, many)
            assert "speed_ratios" in body and "100000 entries, at most 256" in body, body
            long_text = {
                "kind": "evaluate",
                "scenarios": ["crossing_low"],
                "seeds_per_scenario": 1,
                "planner": {"name": "goal"},
                "scenario_overrides": {"metadata": {"x": "y" * 10_000}},
            }
            assert "10000 characters" in _refused(client, long_text)
            huge = {
                "kind": "evaluate",
                "scenarios": ["crossing_low"],
                "seeds_per_scenario": 1,
                "planner": {"name": "orca", "config": {"time_horizon": 1e300}},
            }
            assert "time_horizon" in _refused(client, huge)
            assert client.get("/v1/jobs").json()["count"] == 0  # nothing refused was stored

            # within every limit, past the worker's memory: the job fails naming the limit, the worker lives on
            plaza = {
                "kind": "simulate",
                "bundle": "crowds",
                "matrix": "scenarios/m.yaml",
                "scenarios": ["plaza"],
                "render": False,
            }
            r = client.post("/v1/jobs", json={"spec": plaza, "timeout_s": 120})
            assert r.status_code == 201, r.text
            job = wait_job(client, r.json()["id"], timeout=120)
            assert job["status"] == "failed" and job["error"]["type"] == "MemoryError", job
            assert (
                "350 MiB" in job["error"]["message"]
                and "FORESIGHT_WORKER_MEMORY_MB" in job["error"]["message"]
            )
            assert job["attempts"] == 1  # not retried: the same job would fail the same way
            r = client.post("/v1/jobs", json={"spec": {"kind": "sleep", "seconds": 0.1}})
            assert wait_job(client, r.json()["id"])["status"] == "succeeded"  # the worker still serves
    finally:
        service.stop()
