"""A worker thread against a real SQLite file: results, failures, cancellation, timeouts, stopping."""

from __future__ import annotations

import time

import pytest

from foresight.store import job_reads, queue


def _wait(engine, job_id: str, statuses: set[str], timeout: float = 10.0) -> dict:  # noqa: ANN001
    deadline = time.time() + timeout
    while time.time() < deadline:
        job = job_reads.get_job(engine, job_id)
        if job["status"] in statuses:
            return job
        time.sleep(0.02)
    raise AssertionError(f"job {job_id} still {job['status']}")


def _submit(engine, **spec) -> str:  # noqa: ANN001, ANN003
    timeout = spec.pop("timeout_s", None)
    return queue.submit(engine, kind="sleep", spec={"kind": "sleep", **spec}, timeout_s=timeout)[0]["id"]


def test_runs_a_job_and_records_artifacts(engine, start_worker) -> None:  # noqa: ANN001
    start_worker()
    job_id = _submit(engine, seconds=0.2, steps=4, artifact="out/note.txt")
    job = _wait(engine, job_id, {"succeeded"})
    assert job["result"] == {"slept_s": 0.2} and job["progress"] == 1.0
    arts = job_reads.events_after(engine, job_id, 0)
    assert [e["message"] for e in arts if e["type"] == "status"][-1] == "succeeded"
    with engine.connect() as conn:
        names = [
            r.name for r in conn.execute(queue.artifacts.select().where(queue.artifacts.c.job_id == job_id))
        ]
    assert names == ["out/note.txt"]


def test_failure_stores_type_and_message(engine, start_worker) -> None:  # noqa: ANN001
    start_worker()
    job = _wait(engine, _submit(engine, fail="it broke"), {"failed"})
    assert (job["error_type"], job["error_message"], job["attempts"]) == ("RuntimeError", "it broke", 1)


def test_cancel_is_noticed_within_two_seconds(engine, start_worker) -> None:  # noqa: ANN001
    start_worker()
    job_id = _submit(engine, seconds=30, steps=300)
    _wait(engine, job_id, {"running"})
    t0 = time.time()
    queue.request_cancel(engine, job_id)
    _wait(engine, job_id, {"cancelled"}, timeout=5)
    assert time.time() - t0 < 2.0


def test_timeout_fails_the_job(engine, start_worker) -> None:  # noqa: ANN001
    start_worker()
    job = _wait(engine, _submit(engine, seconds=30, steps=300, timeout_s=0.3), {"failed"})
    assert job["error_type"] == "Timeout"


def test_stop_releases_the_running_job_without_counting_it(engine, start_worker) -> None:  # noqa: ANN001
    worker = start_worker()
    job_id = _submit(engine, seconds=30, steps=300)
    _wait(engine, job_id, {"running"})
    worker.stop()
    job = _wait(engine, job_id, {"queued"}, timeout=5)
    assert job["attempts"] == 0 and job["lease_owner"] is None


def test_lost_lease_is_abandoned_and_the_job_finished_once(engine, start_worker) -> None:  # noqa: ANN001
    """A stalled claim (expired lease) is reaped and run by a live worker; the stale owner cannot finish it."""
    job_id = _submit(engine, seconds=0.1)
    stale = queue.claim(engine, "stalled-worker", ["sleep"], lease_s=0.05)
    start_worker()
    job = _wait(engine, job_id, {"succeeded"})
    assert job["attempts"] == 2
    with pytest.raises(queue.LeaseLost):
        queue.finish(engine, job_id, "stalled-worker", stale["attempts"], {"dup": True})
    assert job_reads.get_job(engine, job_id)["result"] == {"slept_s": 0.1}


def test_concurrency_runs_jobs_in_parallel(engine, start_worker) -> None:  # noqa: ANN001
    start_worker(concurrency=4)
    ids = [_submit(engine, seconds=0.5, steps=2) for _ in range(4)]
    t0 = time.time()
    for job_id in ids:
        _wait(engine, job_id, {"succeeded"})
    assert time.time() - t0 < 1.8
