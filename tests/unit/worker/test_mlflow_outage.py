"""An MLflow server that does not answer never fails a job: the job succeeds and its log says the copy failed."""

from __future__ import annotations

import socket
import time

from foresight.store import job_reads, queue
from foresight.store.registry import sync_bundles


def test_an_mlflow_outage_is_a_warning_in_the_job_log(engine, settings, start_worker) -> None:  # noqa: ANN001
    with socket.socket() as s:  # a port nothing listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    sync_bundles(engine, settings)
    start_worker(mlflow_tracking_uri=f"http://someone:secret@127.0.0.1:{port}")
    spec = {
        "kind": "evaluate",
        "scenarios": ["crossing_low"],
        "seeds_per_scenario": 1,
        "max_steps": 20,
        "planner": {"name": "goal"},
    }
    job_id = queue.submit(engine, kind="evaluate", spec=spec)[0]["id"]
    deadline = time.time() + 90
    while (job := job_reads.get_job(engine, job_id))["status"] not in (
        "succeeded",
        "failed",
    ) and time.time() < deadline:
        time.sleep(0.05)
    assert job["status"] == "succeeded", (job["error_type"], job["error_message"])
    assert job["result"]["episodes"] == 1
    log = [e["message"] for e in job_reads.events_after(engine, job_id, 0) if e["type"] == "log"]
    warnings = [m for m in log if m.startswith("warning: MLflow export")]
    assert len(warnings) == 1, log
    assert (
        f"to http://127.0.0.1:{port} failed" in warnings[0] and "secret" not in warnings[0]
    )  # no credentials
