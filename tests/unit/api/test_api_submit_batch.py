"""Group-committed submissions on SQLite (store.submit_batch.SubmitBatcher): many concurrent submitters, from threads and
from an event loop, each get their own job, stored once with its 'queued' event."""

from __future__ import annotations

import asyncio
import threading

from sqlalchemy import func, select

from foresight.store import queue


def _stored(engine) -> tuple[dict[str, dict], dict[str, int]]:  # noqa: ANN001
    with engine.connect() as conn:
        jobs = {r["id"]: dict(r) for r in conn.execute(select(queue.jobs)).mappings()}
        events = dict(
            conn.execute(
                select(queue.events.c.job_id, func.count())
                .where(queue.events.c.message == queue.QUEUED)
                .group_by(queue.events.c.job_id)
            ).all()
        )
    return jobs, events


def test_concurrent_thread_submissions_are_each_stored_once(engine) -> None:  # noqa: ANN001
    returned: list[dict] = []
    lock = threading.Lock()

    def submit(n: int) -> None:
        for i in range(n):
            job, created = queue.submit(engine, kind="sleep", spec={"kind": "sleep", "i": i}, priority=i % 3)
            assert created
            with lock:
                returned.append(job)

    threads = [threading.Thread(target=submit, args=(25,)) for _ in range(20)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    jobs, events = _stored(engine)
    assert len(returned) == len(jobs) == 500 and {j["id"] for j in returned} == jobs.keys()
    assert all(events[i] == 1 for i in jobs) and len(events) == 500
    for job in returned:  # what the submitter got back is what was stored
        assert job == jobs[job["id"]]


def test_event_loop_submissions_wait_without_threads_and_keep_order(engine) -> None:  # noqa: ANN001
    async def main() -> list[tuple]:
        return await asyncio.gather(
            *(queue.submit_async(engine, kind="sleep", spec={"kind": "sleep"}) for _ in range(200))
        )

    threads_before = threading.active_count()
    returned = [job for job, created in asyncio.run(main()) if created]
    jobs, events = _stored(engine)
    assert len({j["id"] for j in returned}) == len(jobs) == 200 and all(events[i] == 1 for i in jobs)
    assert threading.active_count() <= threads_before + 1  # one submission thread, not one per request
    with engine.connect() as conn:
        inserted = list(conn.exec_driver_sql("SELECT id FROM jobs ORDER BY rowid").scalars())
    assert inserted == [j["id"] for j in returned]  # inserted in arrival order
