"""Job errors are readable without a token: they name files relative to the store or the configs."""

from __future__ import annotations

import time

from foresight.store import job_reads, queue


def test_job_errors_show_paths_relative_to_the_store_or_configs(engine, settings, start_worker) -> None:  # noqa: ANN001
    from foresight.store.registry import sync_bundles

    sync_bundles(engine, settings)
    start_worker()
    spec = {"kind": "evaluate", "matrix": "scenarios/not_there.yaml", "planner": {"name": "goal"}}
    job_id = queue.submit(engine, kind="evaluate", spec=spec)[0]["id"]  # as a pipeline child would be
    deadline = time.time() + 60
    while (job := job_reads.get_job(engine, job_id))["status"] not in (
        "failed",
        "succeeded",
    ) and time.time() < deadline:
        time.sleep(0.05)
    assert job["status"] == "failed" and "not_there.yaml" in job["error_message"]
    assert str(settings.project_configs.resolve()) not in job["error_message"]
    assert str(settings.store_root) not in job["error_message"]
