"""Every job-queue statement, one named function per operation.

Each state transition is one guarded ``UPDATE ... WHERE status IN (...)``: a transition that finds no row
in the expected state changes nothing and raises (:class:`Conflict` for callers, :class:`LeaseLost` for a
worker whose lease was taken over). Worker transitions are also guarded by ``lease_owner`` and the attempt
number, so a worker that lost its lease (it stalled and the job was claimed again) can never finish,
fail or release the newer attempt: a job's result is written once.

The claim is a single ``UPDATE ... WHERE id = (SELECT ... LIMIT 1) AND status = 'queued' RETURNING``:
atomic under SQLite's single writer (``BEGIN IMMEDIATE``), and on PostgreSQL the inner select takes
``FOR UPDATE SKIP LOCKED`` so concurrent claimers pass over each other's rows instead of waiting.

Which path a statement takes per database (prebuilt text, SQLite's driver inside the write lock, the submission
thread) is decided here, never by callers. Reads are ``store.job_reads``, deletion with files
``store.job_files``, the rows and errors ``store.job_rows``.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Iterable, Sequence
from typing import Any

from sqlalchemy import Connection, Engine, delete, insert, select, update

from foresight.store.job_reads import get
from foresight.store.job_rows import (  # noqa: F401 (the queue's vocabulary, re-exported for its callers)
    CANCELLED,
    FAILED,
    FINISHED_VALUES,
    QUEUED,
    RUNNING,
    SUCCEEDED,
    Conflict,
    IdempotencyConflict,
    JobNotFound,
    JobRow,
    LeaseLost,
    QueueError,
    artifacts,
    events,
    jobs,
    new_id,
    stored_text,
    workers,
)
from foresight.store.queue_sql import (
    ANY_QUEUED_SQL,
    BEAT_JOBS_SQL,
    BEAT_WORKER_SQL,
    CLAIM_PG_SQL,
    EVENT_SQLITE,
    FINISH_PG_SQL,
    FINISH_SQLITE,
    PROGRESS_SQL,
    claim_sqlite_sql,
    held,
)
from foresight.store.session import write_tx
from foresight.store.submission import submit, submit_async  # noqa: F401 (the transition to queued)
from foresight.store.submit_batch import EVENT_SQL


def _add_event(
    conn: Connection, job_id: str, type_: str, message: str = "", progress: float | None = None
) -> None:
    conn.execute(
        EVENT_SQL,
        {
            "job_id": job_id,
            "at": time.time(),
            "type": type_,
            "message": stored_text(message),
            "progress": progress,
        },
    )


# ------------------------------------------------------------------------------------------ worker side


def claim(
    engine: Engine, worker_id: str, kinds: Sequence[str], lease_s: float, *, peek: bool = True
) -> JobRow | None:
    """Take the highest-priority, oldest queued job of one of ``kinds``; None when there is none.

    ``peek`` reads first and only takes the write lock when a job is waiting, so that idle workers polling
    do not queue for the lock; a busy worker (its last claim found a job) skips that read.
    """
    if peek:
        with engine.connect() as conn:
            if conn.execute(ANY_QUEUED_SQL, {"kinds": list(kinds)}).first() is None:
                return None
    now = time.time()
    params = {"owner": worker_id, "expires": now + lease_s, "now": now, "kinds": list(kinds)}
    if engine.dialect.name == "postgresql":
        with write_tx(engine) as conn:
            _no_fsync(conn)
            row = conn.execute(CLAIM_PG_SQL, params).mappings().first()
        return JobRow.of(row) if row else None
    with write_tx(engine) as conn:
        # SQLite allows one writer at a time: between BEGIN IMMEDIATE and COMMIT the statements go straight to
        # the driver (SQLAlchemy's per-statement work held the lock ~3x longer; API submissions wait on it)
        cur = conn.connection.dbapi_connection.cursor()
        kinds = {f"k{i}": k for i, k in enumerate(params["kinds"])}
        cur.execute(
            claim_sqlite_sql(len(kinds)),
            {"owner": worker_id, "expires": params["expires"], "now": now, **kinds},
        )
        row = JobRow.of_sqlite(cur)
        if row is None:
            return None
        cur.execute(
            EVENT_SQLITE,
            (row.id, now, "status", f"{RUNNING} (attempt {row.attempts}, worker {worker_id})", None),
        )
    return row


def claim_id(engine: Engine, job_id: str, worker_id: str, lease_s: float) -> JobRow | None:
    """Take one queued job by id (a pipeline runs its own children in its slot); None when it is not queued."""
    now = time.time()
    with write_tx(engine) as conn:
        row = (
            conn.execute(
                update(jobs)
                .where(jobs.c.id == job_id, jobs.c.status == QUEUED)
                .values(
                    status=RUNNING,
                    lease_owner=worker_id,
                    lease_expires_at=now + lease_s,
                    attempts=jobs.c.attempts + 1,
                    started_at=now,
                    progress=0.0,
                    message="",
                )
                .returning(*jobs.c)
            )
            .mappings()
            .first()
        )
        if row is None:
            return None
        _add_event(conn, job_id, "status", f"{RUNNING} (attempt {row['attempts']}, worker {worker_id})")
    return JobRow.of(row)


def _no_fsync(conn: Connection) -> None:
    """PostgreSQL: commit this transaction without waiting for its WAL flush (claims, heartbeats, progress).

    A database crash may then forget the last moments of these: a forgotten claim puts the job back in
    the queue while its worker still runs it, but a job's finish (result, artifacts, records; always
    flushed) is guarded by owner and attempt, so the work may run twice, its result is stored once.
    """
    if conn.dialect.name == "postgresql":
        conn.exec_driver_sql("SET LOCAL synchronous_commit TO OFF")


def heartbeat(
    engine: Engine, worker_id: str, held: Iterable[str], lease_s: float
) -> tuple[set[str], set[str]]:
    """Renew the worker's heartbeat and the leases of the jobs it holds.

    Returns ``(cancel_requested, lost)``: held jobs whose cancellation was asked for, and held jobs this
    worker no longer owns.
    """
    held = list(held)
    now = time.time()
    with write_tx(engine) as conn:
        _no_fsync(conn)
        conn.execute(BEAT_WORKER_SQL, {"now": now, "owner": worker_id})
        if not held:
            return set(), set()
        rows = conn.execute(BEAT_JOBS_SQL, {"expires": now + lease_s, "ids": held, "owner": worker_id}).all()
    owned = {r.id for r in rows}
    return {r.id for r in rows if r.cancel_requested}, set(held) - owned


def report_progress(
    engine: Engine, job_id: str, owner: str, attempt: int, fraction: float, message: str
) -> None:
    with write_tx(engine) as conn:
        _no_fsync(conn)
        held = {"id": job_id, "owner": owner, "attempt": attempt}
        n = conn.execute(PROGRESS_SQL, {**held, "progress": fraction, "message": stored_text(message)})
        if n.rowcount:
            _add_event(conn, job_id, "progress", message, fraction)


def log(engine: Engine, job_id: str, message: str) -> None:
    with write_tx(engine) as conn:
        _add_event(conn, job_id, "log", message)


def finish(
    engine: Engine,
    job_id: str,
    owner: str,
    attempt: int,
    result: dict[str, Any],
    new_artifacts: Sequence[dict[str, Any]] = (),
    record: Callable[[Connection], None] | None = None,
    publish: Callable[[], None] | None = None,
) -> None:
    """Mark a held job succeeded, storing its result summary, artifact records and (through ``record``) its
    result rows in the same transaction; ``publish`` (moving the attempt's files into place) runs once the
    lease is checked, while the transaction holds the job's row (a lost lease publishes nothing)."""
    now = time.time()
    with write_tx(engine) as conn:
        params = {"id": job_id, "owner": owner, "attempt": attempt, "result": result, "now": now}
        if engine.dialect.name == "postgresql":
            done = conn.execute(FINISH_PG_SQL, params).scalar_one()
        else:  # straight to the driver while SQLite's write lock is held (see claim)
            cur = conn.connection.dbapi_connection.cursor()
            done = cur.execute(FINISH_SQLITE, {**params, "result": json.dumps(result)}).rowcount
            if done:
                cur.execute(EVENT_SQLITE, (job_id, now, "status", SUCCEEDED, 1.0))
        if done == 0:
            raise LeaseLost(f"job {job_id}: lease lost before finishing (attempt {attempt})")
        if publish is not None:
            publish()
        if attempt > 1:
            conn.execute(
                delete(artifacts).where(artifacts.c.job_id == job_id)
            )  # a previous attempt's records
        if new_artifacts:
            conn.execute(
                insert(artifacts), [{"job_id": job_id, "created_at": now, **art} for art in new_artifacts]
            )
        if record is not None:
            record(conn)


def fail_or_retry(
    engine: Engine, job_id: str, owner: str, attempt: int, error_type: str, message: str, *, retry: bool
) -> str:
    """Fail a held job, or queue it again when ``retry`` and attempts remain; returns the new status."""
    now = time.time()
    with write_tx(engine) as conn:
        job = conn.execute(select(jobs.c.max_attempts).where(held(job_id, owner, attempt))).first()
        if job is None:
            raise LeaseLost(f"job {job_id}: lease lost before failing (attempt {attempt})")
        again = retry and attempt < job.max_attempts
        error_type, message = stored_text(error_type), stored_text(message)
        values: dict[str, Any] = dict(error_type=error_type, error_message=message, lease_expires_at=None)
        if again:
            values.update(status=QUEUED, lease_owner=None)
        else:
            values.update(status=FAILED, finished_at=now)
        conn.execute(update(jobs).where(held(job_id, owner, attempt)).values(**values))
        status = QUEUED if again else FAILED
        _add_event(conn, job_id, "status", f"{status}: {error_type}: {message}")
    return status


def mark_cancelled(engine: Engine, job_id: str, owner: str, attempt: int) -> None:
    """A held job stopped because its cancellation was requested."""
    with write_tx(engine) as conn:
        n = conn.execute(
            update(jobs)
            .where(held(job_id, owner, attempt))
            .values(status=CANCELLED, finished_at=time.time(), lease_expires_at=None)
        )
        if n.rowcount == 0:
            raise LeaseLost(f"job {job_id}: lease lost before cancelling (attempt {attempt})")
        _add_event(conn, job_id, "status", CANCELLED)


def release(engine: Engine, job_id: str, owner: str, attempt: int) -> None:
    """Give a held job back to the queue without counting the attempt (worker shutting down)."""
    with write_tx(engine) as conn:
        n = conn.execute(
            update(jobs)
            .where(held(job_id, owner, attempt))
            .values(status=QUEUED, lease_owner=None, lease_expires_at=None, attempts=jobs.c.attempts - 1)
        )
        if n.rowcount == 0:
            raise LeaseLost(f"job {job_id}: lease lost before releasing (attempt {attempt})")
        _add_event(conn, job_id, "status", f"{QUEUED} (released by worker {owner})")


def reap_stale(engine: Engine, now: float | None = None) -> dict[str, int]:
    """Jobs whose lease expired (their worker died): queue them again, or fail them past their attempts.

    A job whose cancellation was requested is cancelled instead.
    """
    now = time.time() if now is None else now
    expired = (jobs.c.status == RUNNING, jobs.c.lease_expires_at < now)
    done = dict(finished_at=now, lease_expires_at=None)
    with write_tx(engine) as conn:
        cancelled = (
            conn.execute(
                update(jobs)
                .where(*expired, jobs.c.cancel_requested)
                .values(status=CANCELLED, **done)
                .returning(jobs.c.id)
            )
            .scalars()
            .all()
        )
        failed = (
            conn.execute(
                update(jobs)
                .where(*expired, jobs.c.attempts >= jobs.c.max_attempts)
                .values(
                    status=FAILED,
                    error_type="LeaseExpired",
                    error_message="the worker stopped heartbeating and no attempts remain",
                    **done,
                )
                .returning(jobs.c.id)
            )
            .scalars()
            .all()
        )
        requeued = (
            conn.execute(
                update(jobs)
                .where(*expired)
                .values(
                    status=QUEUED,
                    lease_owner=None,
                    lease_expires_at=None,
                    error_type="LeaseExpired",
                    error_message="the worker stopped heartbeating; queued again",
                )
                .returning(jobs.c.id)
            )
            .scalars()
            .all()
        )
        for ids, message in (
            (cancelled, CANCELLED),
            (failed, f"{FAILED}: lease expired"),
            (requeued, f"{QUEUED}: lease expired"),
        ):
            for job_id in ids:
                _add_event(conn, job_id, "status", message)
    return {"cancelled": len(cancelled), "failed": len(failed), "requeued": len(requeued)}


def register_worker(
    engine: Engine, worker_id: str, host: str, pid: int, concurrency: int, kinds: list[str]
) -> None:
    now = time.time()
    with write_tx(engine) as conn:
        conn.execute(
            insert(workers).values(
                id=worker_id,
                host=host,
                pid=pid,
                concurrency=concurrency,
                kinds=kinds,
                started_at=now,
                heartbeat_at=now,
            )
        )


def stop_worker(engine: Engine, worker_id: str) -> None:
    with write_tx(engine) as conn:
        conn.execute(update(workers).where(workers.c.id == worker_id).values(stopped_at=time.time()))


def prune_workers(engine: Engine, older_than_s: float = 86400.0) -> int:
    """Forget workers that stopped (or went silent) more than ``older_than_s`` ago."""
    with write_tx(engine) as conn:
        return conn.execute(
            delete(workers).where(workers.c.heartbeat_at < time.time() - older_than_s)
        ).rowcount


# ------------------------------------------------------------------------------------------ caller side


def request_cancel(engine: Engine, job_id: str) -> str:
    """Cancel a queued job at once, or flag a running one for its worker; returns the resulting status."""
    now = time.time()
    with write_tx(engine) as conn:
        n = conn.execute(
            update(jobs)
            .where(jobs.c.id == job_id, jobs.c.status == QUEUED)
            .values(status=CANCELLED, cancel_requested=True, finished_at=now)
        ).rowcount
        if n:
            _add_event(conn, job_id, "status", CANCELLED)
            return CANCELLED
        n = conn.execute(
            update(jobs).where(jobs.c.id == job_id, jobs.c.status == RUNNING).values(cancel_requested=True)
        ).rowcount
        if n:
            _add_event(conn, job_id, "log", "cancellation requested")
            return RUNNING
        job = get(conn, job_id)
    raise Conflict(f"job {job_id} is already {job.status}; only queued or running jobs can be cancelled")


def retry(engine: Engine, job_id: str) -> JobRow:
    """Queue a failed or cancelled job again, with a fresh attempt count; the job as queued (read in the same
    transaction: a worker may claim it the moment it commits)."""
    with write_tx(engine) as conn:
        n = conn.execute(
            update(jobs)
            .where(jobs.c.id == job_id, jobs.c.status.in_((FAILED, CANCELLED)))
            .values(
                status=QUEUED,
                attempts=0,
                cancel_requested=False,
                lease_owner=None,
                lease_expires_at=None,
                progress=0.0,
                message="",
                error_type=None,
                error_message=None,
                finished_at=None,
            )
        ).rowcount
        if n:
            _add_event(conn, job_id, "status", f"{QUEUED} (retry)")
            return get(conn, job_id)
        job = get(conn, job_id)
    raise Conflict(f"job {job_id} is {job.status}; only failed or cancelled jobs can be retried")


def delete_job(engine: Engine, job_id: str) -> list[dict[str, Any]]:
    """Delete a finished job with its events; returns its artifact records (also deleted) for file clean-up."""
    with write_tx(engine) as conn:
        arts = [
            dict(r) for r in conn.execute(select(artifacts).where(artifacts.c.job_id == job_id)).mappings()
        ]
        conn.execute(delete(events).where(events.c.job_id == job_id))
        conn.execute(delete(artifacts).where(artifacts.c.job_id == job_id))
        n = conn.execute(delete(jobs).where(jobs.c.id == job_id, jobs.c.status.in_(FINISHED_VALUES))).rowcount
        if n == 0:
            job = get(conn, job_id)
            raise Conflict(
                f"job {job_id} is {job.status}; only finished jobs can be deleted (cancel it first)"
            )
    return arts
