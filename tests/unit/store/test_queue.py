"""The queue's guarded transitions on a real SQLite file."""

from __future__ import annotations

import time

import pytest

from foresight.store import job_reads, queue


def _submit(engine, **kw):  # noqa: ANN001, ANN202
    return queue.submit(engine, kind="sleep", spec={"kind": "sleep", **kw.pop("spec", {})}, **kw)[0]


def test_claim_takes_highest_priority_then_oldest(engine) -> None:  # noqa: ANN001
    low = _submit(engine)
    high = _submit(engine, priority=5)
    assert queue.claim(engine, "w1", ["sleep"], 10)["id"] == high["id"]
    got = queue.claim(engine, "w1", ["sleep"], 10)
    assert got["id"] == low["id"] and got["attempts"] == 1 and got["status"] == "running"
    assert queue.claim(engine, "w1", ["sleep"], 10) is None


def test_claim_filters_kinds(engine) -> None:  # noqa: ANN001
    _submit(engine)
    assert queue.claim(engine, "w1", ["simulate"], 10) is None


def test_finish_is_guarded_by_owner_and_attempt(engine) -> None:  # noqa: ANN001
    job = _submit(engine)
    claimed = queue.claim(engine, "w1", ["sleep"], 10)
    with pytest.raises(queue.LeaseLost):
        queue.finish(engine, job["id"], "w2", 1, {})
    with pytest.raises(queue.LeaseLost):
        queue.finish(engine, job["id"], "w1", 2, {})
    queue.finish(engine, job["id"], "w1", claimed["attempts"], {"ok": True})
    assert job_reads.get_job(engine, job["id"])["status"] == "succeeded"
    with pytest.raises(queue.LeaseLost):  # twice: the second finds no running row
        queue.finish(engine, job["id"], "w1", 1, {"ok": True})


def test_reap_requeues_then_fails_after_max_attempts(engine) -> None:  # noqa: ANN001
    job = _submit(engine, max_attempts=2)
    queue.claim(engine, "dead", ["sleep"], 0.01)
    time.sleep(0.02)
    assert queue.reap_stale(engine)["requeued"] == 1
    claimed = queue.claim(engine, "w2", ["sleep"], 0.01)
    assert claimed["attempts"] == 2
    time.sleep(0.02)
    assert queue.reap_stale(engine)["failed"] == 1
    final = job_reads.get_job(engine, job["id"])
    assert final["status"] == "failed" and final["error_type"] == "LeaseExpired"
    with pytest.raises(queue.LeaseLost):  # the stalled first worker cannot finish it any more
        queue.finish(engine, job["id"], "dead", 1, {})


def test_cancel_queued_running_and_finished(engine) -> None:  # noqa: ANN001
    queued = _submit(engine)
    assert queue.request_cancel(engine, queued["id"]) == "cancelled"
    running = _submit(engine)
    queue.claim(engine, "w1", ["sleep"], 10)
    assert queue.request_cancel(engine, running["id"]) == "running"
    cancel, lost = queue.heartbeat(engine, "w1", [running["id"]], 10)
    assert cancel == {running["id"]} and lost == set()
    with pytest.raises(queue.Conflict):
        queue.request_cancel(engine, queued["id"])
    with pytest.raises(queue.JobNotFound):
        queue.request_cancel(engine, "nope")


def test_retry_only_failed_or_cancelled(engine) -> None:  # noqa: ANN001
    job = _submit(engine)
    with pytest.raises(queue.Conflict):
        queue.retry(engine, job["id"])
    claimed = queue.claim(engine, "w1", ["sleep"], 10)
    assert (
        queue.fail_or_retry(engine, job["id"], "w1", claimed["attempts"], "RuntimeError", "boom", retry=False)
        == "failed"
    )
    failed = job_reads.get_job(engine, job["id"])
    assert (failed["error_type"], failed["error_message"]) == ("RuntimeError", "boom")
    again = queue.retry(engine, job["id"])  # the row as queued, whoever claims it next
    assert again == job_reads.get_job(engine, job["id"])
    assert again["status"] == "queued" and again["attempts"] == 0 and again["error_type"] is None
    assert queue.claim(engine, "w2", ["sleep"], 10)["id"] == job["id"] and again["status"] == "queued"


def test_fail_or_retry_requeues_while_attempts_remain(engine) -> None:  # noqa: ANN001
    job = _submit(engine, max_attempts=2)
    c = queue.claim(engine, "w1", ["sleep"], 10)
    assert (
        queue.fail_or_retry(engine, job["id"], "w1", c["attempts"], "OSError", "disk", retry=True) == "queued"
    )
    c = queue.claim(engine, "w1", ["sleep"], 10)
    assert (
        queue.fail_or_retry(engine, job["id"], "w1", c["attempts"], "OSError", "disk", retry=True) == "failed"
    )


def test_release_does_not_count_the_attempt(engine) -> None:  # noqa: ANN001
    job = _submit(engine)
    c = queue.claim(engine, "w1", ["sleep"], 10)
    queue.release(engine, job["id"], "w1", c["attempts"])
    again = job_reads.get_job(engine, job["id"])
    assert again["status"] == "queued" and again["attempts"] == 0 and again["lease_owner"] is None


def test_idempotency_key(engine) -> None:  # noqa: ANN001
    a, created_a = queue.submit(engine, kind="sleep", spec={"kind": "sleep"}, idempotency_key="k1")
    b, created_b = queue.submit(engine, kind="sleep", spec={"kind": "sleep"}, idempotency_key="k1")
    assert (created_a, created_b) == (True, False) and a["id"] == b["id"]
    with pytest.raises(queue.IdempotencyConflict):
        queue.submit(engine, kind="sleep", spec={"kind": "sleep", "seconds": 1}, idempotency_key="k1")


def test_delete_only_finished(engine) -> None:  # noqa: ANN001
    job = _submit(engine)
    with pytest.raises(queue.Conflict):
        queue.delete_job(engine, job["id"])
    queue.request_cancel(engine, job["id"])
    queue.delete_job(engine, job["id"])
    with pytest.raises(queue.JobNotFound):
        job_reads.get_job(engine, job["id"])


def test_concurrent_submissions_are_grouped_and_all_stored(engine) -> None:  # noqa: ANN001
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(16) as pool:
        jobs = list(pool.map(lambda i: _submit(engine, spec={"seconds": i % 3}), range(64)))
    assert len({j["id"] for j in jobs}) == 64 and all(j["status"] == "queued" for j in jobs)
    assert job_reads.depth(engine) == {"sleep": {"queued": 64}}
    for job in jobs[:5]:
        stored = job_reads.get_job(engine, job["id"])
        assert {k: stored[k] for k in job} == job  # what submit returned is what was stored
        assert [e["message"] for e in job_reads.events_after(engine, job["id"], 0)] == ["queued"]
