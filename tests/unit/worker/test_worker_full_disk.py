"""A job that fills the store fails clearly, is not retried, and leaves no partial files behind."""

from __future__ import annotations

import time

from foresight.store import job_reads, queue
from foresight.store.registry import sync_bundles

COLLECT = {
    "kind": "collect",
    "scenarios": ["crossing_low"],
    "seeds_per_scenario": 4,
    "max_steps": 200,
    "check_quality": False,
}


def test_a_job_that_hits_enospc_fails_once_and_frees_its_folder(
    engine, settings, start_worker, small_store
) -> None:  # noqa: ANN001
    (small_store / "ballast").write_bytes(b"\0" * (1024 * 1024 - 48 * 1024))  # leave ~48 KiB free
    sync_bundles(engine, settings)
    start_worker(store=small_store)
    job_id = queue.submit(engine, kind="collect", spec=COLLECT)[0]["id"]
    deadline = time.time() + 120
    while (job := job_reads.get_job(engine, job_id))["status"] not in (
        "failed",
        "succeeded",
    ) and time.time() < deadline:
        time.sleep(0.05)
    assert job["status"] == "failed" and job["attempts"] == 1, job
    assert job["error_type"] == "OSError" and "No space left on device" in job["error_message"]
    assert "partial files were removed" in job["error_message"]
    assert not (small_store / "jobs" / job_id).exists()
