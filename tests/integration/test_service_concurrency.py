"""4 worker processes x 500 short jobs each: every job done exactly once, on SQLite and on PostgreSQL."""

from __future__ import annotations

import time
from collections import Counter
from pathlib import Path

from sqlalchemy import func, insert, select

from foresight.store import queue
from foresight.store.session import make_engine, write_tx

from .service import Service

WORKERS, JOBS_PER_WORKER = 4, 500


def _bulk_submit(engine, n: int) -> list[str]:  # noqa: ANN001
    now = time.time()
    rows = [
        dict(
            id=queue.new_id(),
            kind="sleep",
            spec={"kind": "sleep", "seconds": 0.0},
            status="queued",
            priority=0,
            attempts=0,
            max_attempts=3,
            cancel_requested=False,
            progress=0.0,
            message="",
            created_at=now + i * 1e-6,
        )
        for i in range(n)
    ]
    with write_tx(engine) as conn:
        conn.execute(insert(queue.jobs), rows)
    return [r["id"] for r in rows]


def _run(svc: Service, url: str | None) -> None:
    svc.migrate()
    engine = make_engine(url or f"sqlite:///{svc.tmp / 'data' / 'foresight.db'}")
    ids = _bulk_submit(engine, WORKERS * JOBS_PER_WORKER)
    t0 = time.time()
    for _ in range(WORKERS):
        svc.worker()
    deadline = time.time() + 150
    while time.time() < deadline:
        with engine.connect() as conn:
            done = conn.execute(
                select(func.count()).select_from(queue.jobs).where(queue.jobs.c.status == "succeeded")
            ).scalar()
        if done == len(ids):
            break
        time.sleep(0.25)
    elapsed = time.time() - t0
    with engine.connect() as conn:
        jobs = conn.execute(
            select(queue.jobs.c.id, queue.jobs.c.status, queue.jobs.c.attempts, queue.jobs.c.lease_owner)
        ).all()
        starts = Counter(
            conn.execute(
                select(queue.events.c.job_id).where(
                    queue.events.c.type == "status", queue.events.c.message.like("running%")
                )
            ).scalars()
        )
        finishes = Counter(
            conn.execute(
                select(queue.events.c.job_id).where(
                    queue.events.c.type == "status", queue.events.c.message == "succeeded"
                )
            ).scalars()
        )
    engine.dispose()
    assert Counter(j.status for j in jobs) == {"succeeded": len(ids)}, svc.logs()
    assert all(j.attempts == 1 for j in jobs)
    assert set(starts.values()) == {1} and set(finishes.values()) == {1} and len(finishes) == len(ids)
    owners = Counter(j.lease_owner for j in jobs)
    assert len(owners) == WORKERS, owners  # every worker took a share
    print(
        f"{len(ids)} jobs by {WORKERS} workers in {elapsed:.1f} s ({len(ids) / elapsed:.0f} jobs/s), shares {sorted(owners.values())}"
    )


def test_four_workers_sqlite(tmp_path: Path) -> None:
    svc = Service(tmp_path)
    try:
        _run(svc, None)
    finally:
        svc.stop()


def test_four_workers_postgres(tmp_path: Path, pg_url: str) -> None:
    svc = Service(tmp_path, database_url=pg_url)
    try:
        _run(svc, pg_url)
    finally:
        svc.stop()
