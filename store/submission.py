"""Submitting a job: its row, the idempotency check, and which path it takes per database.

Plain submissions (no idempotency key, no parent) on SQLite go through the engine's submission thread
(``store.submit_batch``), which takes the single writer lock once for many requests; the rest are one
transaction each. Callers never choose: ``submit`` from threads, ``submit_async`` from the event loop.
"""

from __future__ import annotations

import functools
import time
from typing import Any

from sqlalchemy import Engine
from sqlalchemy.exc import IntegrityError

from foresight.store import labels as labels_store
from foresight.store import submit_batch
from foresight.store.job_reads import find_by_key, get_job
from foresight.store.job_rows import QUEUED, IdempotencyConflict, JobRow, new_id
from foresight.store.queue_sql import SUBMIT_SQL
from foresight.store.session import is_sqlite, write_tx


def _new_row(
    kind: str,
    spec: dict[str, Any],
    priority: int,
    timeout_s: float | None,
    max_attempts: int,
    idempotency_key: str | None,
    parent_id: str | None,
    labels: dict[str, Any] | None,
) -> dict[str, Any]:
    """A job row; ``labels`` the optional ``name``, ``tags`` and ``note`` (``store.labels``)."""
    labels = labels or {}
    return dict(
        id=new_id(),
        kind=kind,
        spec=spec,
        status=QUEUED,
        priority=priority,
        attempts=0,
        max_attempts=max_attempts,
        timeout_s=timeout_s,
        idempotency_key=idempotency_key,
        parent_id=parent_id,
        cancel_requested=False,
        progress=0.0,
        message="",
        created_at=time.time(),
        name=labels.get("name"),
        tags=list(labels.get("tags") or []),
        note=labels.get("note") or "",
    )


def submit(
    engine: Engine,
    *,
    kind: str,
    spec: dict[str, Any],
    priority: int = 0,
    timeout_s: float | None = None,
    max_attempts: int = 3,
    idempotency_key: str | None = None,
    parent_id: str | None = None,
    labels: dict[str, Any] | None = None,
) -> tuple[JobRow, bool]:
    """Queue a job; returns ``(job, created)``. A known idempotency key returns its job (``created`` False).
    ``labels``: the job's optional ``name``, ``tags`` and ``note``. Plain submissions on SQLite go through the
    engine's submission thread (``store.submit_batch``)."""
    if idempotency_key is not None:
        existing = find_by_key(engine, idempotency_key)
        if existing is not None:
            return _same_submission(existing, kind, spec), False
    row = _new_row(kind, spec, priority, timeout_s, max_attempts, idempotency_key, parent_id, labels)
    if _batched(engine, idempotency_key, parent_id):
        submit_batch.commit(engine, row)
        return JobRow.of({**_JOB_DEFAULTS, **row}), True
    try:
        with write_tx(engine) as conn:
            job = conn.execute(SUBMIT_SQL, row).mappings().one()
            labels_store.insert_tags(conn, [row])
            conn.execute(
                submit_batch.EVENT_SQL,
                {
                    "job_id": row["id"],
                    "at": row["created_at"],
                    "type": "status",
                    "message": QUEUED,
                    "progress": None,
                },
            )
    except IntegrityError:
        existing = find_by_key(engine, idempotency_key) if idempotency_key else None
        if existing is None:
            raise
        return _same_submission(existing, kind, spec), False  # a concurrent submission with the same key won
    return JobRow.of(job), True


def _batched(engine: Engine, idempotency_key: str | None, parent_id: str | None) -> bool:
    """Whether a submission goes through the submission thread: plain ones (no key to look up first, no parent)
    on SQLite, whose single writer lock that thread takes once for many requests."""
    return idempotency_key is None and parent_id is None and is_sqlite(engine)


async def submit_async(
    engine: Engine,
    *,
    kind: str,
    spec: dict[str, Any],
    priority: int = 0,
    timeout_s: float | None = None,
    max_attempts: int = 3,
    idempotency_key: str | None = None,
    parent_id: str | None = None,
    labels: dict[str, Any] | None = None,
) -> tuple[JobRow, bool]:
    """:func:`submit` from the event loop: a plain submission on SQLite waits on a future while the submission
    thread writes it (holding no thread); the rest (keys, parents, PostgreSQL) runs in a worker thread."""
    if _batched(engine, idempotency_key, parent_id):
        row = _new_row(kind, spec, priority, timeout_s, max_attempts, None, None, labels)
        await submit_batch.commit_async(engine, row)
        return JobRow.of({**_JOB_DEFAULTS, **row}), True
    import anyio.to_thread

    if parent_id is not None:
        await anyio.to_thread.run_sync(get_job, engine, parent_id)  # JobNotFound naming an unknown parent
    call = functools.partial(
        submit,
        engine,
        kind=kind,
        spec=spec,
        priority=priority,
        timeout_s=timeout_s,
        max_attempts=max_attempts,
        idempotency_key=idempotency_key,
        parent_id=parent_id,
        labels=labels,
    )
    return await anyio.to_thread.run_sync(call)


#: the columns a fresh job has beyond what submit sets
_JOB_DEFAULTS = {
    "lease_owner": None,
    "lease_expires_at": None,
    "error_type": None,
    "error_message": None,
    "result": None,
    "started_at": None,
    "finished_at": None,
}


def _same_submission(job: JobRow, kind: str, spec: dict[str, Any]) -> JobRow:
    if job["kind"] != kind or job["spec"] != spec:
        raise IdempotencyConflict(
            f"idempotency key {job['idempotency_key']!r} was used for job {job['id']} with a different spec"
        )
    return job
