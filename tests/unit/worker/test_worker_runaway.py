"""Runaway jobs in a worker: cancel and timeout inside one long episode, the default timeout, and
the step budget re-checked before a stage runs (child jobs never pass the API)."""

from __future__ import annotations

import time

from foresight.store import job_reads, queue
from foresight.store.registry import sync_bundles

#: one episode whose robot cannot move: 100,000 steps (minutes) unless stopped from inside
STUCK = {
    "kind": "collect",
    "scenarios": ["crossing_low"],
    "seeds_per_scenario": 1,
    "max_steps": 100_000,
    "policy": "planner",
    "planner": {"name": "goal", "config": {"speed": 0.0}},
}


def _wait(engine, job_id: str, statuses: set[str], timeout: float = 30.0) -> dict:  # noqa: ANN001
    deadline = time.time() + timeout
    while time.time() < deadline:
        job = job_reads.get_job(engine, job_id)
        if job["status"] in statuses:
            return job
        time.sleep(0.02)
    raise AssertionError(f"job {job_id} still {job['status']}")


def _submit(engine, spec: dict, timeout_s: float | None = None) -> str:  # noqa: ANN001
    return queue.submit(engine, kind=spec["kind"], spec=spec, timeout_s=timeout_s)[0]["id"]


def test_cancel_stops_a_long_episode_within_two_seconds(engine, settings, start_worker) -> None:  # noqa: ANN001
    sync_bundles(engine, settings)
    start_worker()
    job_id = _submit(engine, STUCK)
    _wait(engine, job_id, {"running"})
    time.sleep(1.5)  # inside the episode by now
    t0 = time.time()
    queue.request_cancel(engine, job_id)
    _wait(engine, job_id, {"cancelled"})
    assert time.time() - t0 < 2.0


def test_timeout_stops_a_long_episode_within_two_seconds(engine, settings, start_worker) -> None:  # noqa: ANN001
    sync_bundles(engine, settings)
    start_worker()
    job_id = _submit(engine, STUCK, timeout_s=2.0)
    job = _wait(engine, job_id, {"failed"})
    assert job["error_type"] == "Timeout" and "longer than 2 s" in job["error_message"]
    assert job["finished_at"] - job["started_at"] < 2.0 + 2.0


def test_a_job_without_timeout_gets_the_server_default(engine, start_worker) -> None:  # noqa: ANN001
    start_worker(job_timeout_s=0.5)
    job = _wait(engine, _submit(engine, {"kind": "sleep", "seconds": 30, "steps": 300}), {"failed"})
    assert job["error_type"] == "Timeout" and "longer than 0.5 s" in job["error_message"]


def test_the_worker_checks_the_step_budget_before_the_stage(engine, settings, start_worker) -> None:  # noqa: ANN001
    sync_bundles(engine, settings)
    start_worker(max_job_steps=50_000)
    job = _wait(engine, _submit(engine, STUCK), {"failed"})
    assert job["error_type"] == "ConfigError" and job["attempts"] == 1
    assert "1 episodes of 100000 simulation steps" in job["error_message"]
    assert "budget of 50000 steps" in job["error_message"] and "max_steps" in job["error_message"]
