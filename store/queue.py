"""Every job-queue statement, one named function per operation.

Each state transition is one guarded ``UPDATE ... WHERE status IN (...)``: a transition that finds no row
in the expected state changes nothing and raises (:class:`Conflict` for callers, :class:`LeaseLost` for a
worker whose lease was taken over). Worker transitions are also guarded by ``lease_owner`` and the attempt
number, so a worker that lost its lease (it stalled and the job was claimed again) can never finish,
fail or release the newer attempt: a job's result is written once.

The claim is a single ``UPDATE ... WHERE id = (SELECT ... LIMIT 1) AND status = 'queued' RETURNING``:
atomic under SQLite's single writer (``BEGIN IMMEDIATE``), and on PostgreSQL the inner select takes
``FOR UPDATE SKIP LOCKED`` so concurrent claimers pass over each other's rows instead of waiting.
"""

from __future__ import annotations

import functools
import json
import threading
import time
import uuid
import weakref
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

from sqlalchemy import (
    JSON,
    Boolean,
    Connection,
    Engine,
    bindparam,
    delete,
    func,
    insert,
    select,
    text,
    update,
)
from sqlalchemy.exc import IntegrityError

from foresight.store import folders
from foresight.store import labels as labels_store
from foresight.store.models import FINISHED, Artifact, Dataset, Job, JobEvent, JobStatus, Model, Worker
from foresight.store.session import is_sqlite, write_tx

jobs = Job.__table__
events = JobEvent.__table__
workers = Worker.__table__
artifacts = Artifact.__table__

QUEUED, RUNNING = JobStatus.queued.value, JobStatus.running.value
SUCCEEDED, FAILED, CANCELLED = JobStatus.succeeded.value, JobStatus.failed.value, JobStatus.cancelled.value
FINISHED_VALUES = tuple(s.value for s in FINISHED)

# The hot path (claim, heartbeat, progress, finish) runs prebuilt textual statements: building SQLAlchemy
# expressions per call cost more than the statements themselves (~1 ms a job on a busy 2-core machine).
_JOB_TYPES = {"spec": JSON, "result": JSON, "tags": JSON, "cancel_requested": Boolean}
_CLAIM = """
UPDATE jobs SET status = 'running', lease_owner = :owner, lease_expires_at = :expires, attempts = attempts + 1,
                started_at = :now, progress = 0.0, message = ''
WHERE id = (SELECT id FROM jobs WHERE status = 'queued' AND kind IN :kinds
            ORDER BY priority DESC, created_at, id LIMIT 1 {lock})
  AND status = 'queued'
RETURNING *
"""
# PostgreSQL: skip rows other claimers hold, and write the status event in the same statement (a
# data-modifying CTE saves a round trip per claim).
_CLAIM_PG_SQL = (
    text(
        "WITH claimed AS (" + _CLAIM.format(lock="FOR UPDATE SKIP LOCKED") + "), "
        "ev AS (INSERT INTO job_events (job_id, at, type, message) "
        "SELECT id, :now, 'status', 'running (attempt ' || attempts || ', worker ' || :owner || ')' FROM claimed) "
        "SELECT * FROM claimed"
    )
    .bindparams(bindparam("kinds", expanding=True))
    .columns(**_JOB_TYPES)
)
_SUBMIT_COLUMNS = (
    "id",
    "kind",
    "spec",
    "status",
    "priority",
    "attempts",
    "max_attempts",
    "timeout_s",
    "idempotency_key",
    "parent_id",
    "cancel_requested",
    "progress",
    "message",
    "created_at",
    "name",
    "tags",
    "note",
)
_SUBMIT_SQL = (
    text(
        f"INSERT INTO jobs ({', '.join(_SUBMIT_COLUMNS)}) VALUES ({', '.join(':' + c for c in _SUBMIT_COLUMNS)}) RETURNING *"
    )
    .bindparams(
        bindparam("spec", type_=JSON),
        bindparam("tags", type_=JSON),
        bindparam("cancel_requested", type_=Boolean),
    )
    .columns(**_JOB_TYPES)
)
_ANY_QUEUED_SQL = text("SELECT 1 FROM jobs WHERE status = 'queued' AND kind IN :kinds LIMIT 1").bindparams(
    bindparam("kinds", expanding=True)
)
_EVENT_SQL = text(
    "INSERT INTO job_events (job_id, at, type, message, progress) VALUES (:job_id, :at, :type, :message, :progress)"
)
_HELD = "id = :id AND status = 'running' AND lease_owner = :owner AND attempts = :attempt"
_FINISH_PG_SQL = text(
    "WITH done AS (UPDATE jobs SET status = 'succeeded', result = :result, progress = 1.0, finished_at = :now, "
    f"lease_expires_at = NULL, error_type = NULL, error_message = NULL WHERE {_HELD} RETURNING id), "
    "ev AS (INSERT INTO job_events (job_id, at, type, message, progress) SELECT id, :now, 'status', 'succeeded', 1.0 "
    "FROM done) SELECT count(*) FROM done"
).bindparams(bindparam("result", type_=JSON))
_PROGRESS_SQL = text(f"UPDATE jobs SET progress = :progress, message = :message WHERE {_HELD}")
_BEAT_WORKER_SQL = text("UPDATE workers SET heartbeat_at = :now WHERE id = :owner")
_BEAT_JOBS_SQL = (
    text(
        "UPDATE jobs SET lease_expires_at = :expires WHERE id IN :ids AND status = 'running' AND lease_owner = :owner "
        "RETURNING id, cancel_requested"
    )
    .bindparams(bindparam("ids", expanding=True))
    .columns(cancel_requested=Boolean)
)


# The same statements for the SQLite driver itself (qmark parameters), run inside write transactions.
_EVENT_SQLITE = "INSERT INTO job_events (job_id, at, type, message, progress) VALUES (?, ?, ?, ?, ?)"
_FINISH_SQLITE = (
    "UPDATE jobs SET status = 'succeeded', result = ?, progress = 1.0, finished_at = ?, lease_expires_at = NULL, "
    "error_type = NULL, error_message = NULL WHERE id = ? AND status = 'running' AND lease_owner = ? AND attempts = ?"
)  # the guard of _HELD


@functools.lru_cache(maxsize=16)
def _claim_sqlite_sql(n_kinds: int) -> str:
    """The claim with named parameters ``:owner, :expires, :now, :k0 ... :k<n-1>``."""
    return _CLAIM.format(lock="").replace(":kinds", "(" + ", ".join(f":k{i}" for i in range(n_kinds)) + ")")


def _sqlite_job(cur: Any) -> dict[str, Any] | None:
    """The first row of a ``RETURNING *`` as the dict SQLAlchemy would give (JSON and booleans decoded)."""
    rows = cur.fetchall()
    if not rows:
        return None
    job = dict(zip([d[0] for d in cur.description], rows[0], strict=True))
    job["spec"] = json.loads(job["spec"]) if job["spec"] is not None else None
    job["result"] = json.loads(job["result"]) if job["result"] is not None else None
    job["tags"] = json.loads(job["tags"]) if job["tags"] is not None else []
    job["cancel_requested"] = bool(job["cancel_requested"])
    return job


class QueueError(Exception):
    """A job-queue operation could not be done."""

    def __init__(self, message: str | None = None):
        super().__init__(message or (self.__doc__ or "").strip())


class JobNotFound(QueueError):
    """No job with this id."""


class Conflict(QueueError):
    """The job is not in a state that allows this operation."""


class IdempotencyConflict(Conflict):
    """This idempotency key was already used for a different spec."""


class LeaseLost(QueueError):
    """This worker no longer holds the job's lease (it expired and the job was claimed again, or cancelled)."""


def new_id() -> str:
    return uuid.uuid4().hex


def stored_text(text: str) -> str:
    """``text`` as a text column can hold it: PostgreSQL refuses NUL characters (a worker then failed to record
    an error three times and the job ended as LeaseExpired, hiding the cause)."""
    return text.replace("\x00", "\\x00")


def _add_event(
    conn: Connection, job_id: str, type_: str, message: str = "", progress: float | None = None
) -> None:
    conn.execute(
        _EVENT_SQL,
        {
            "job_id": job_id,
            "at": time.time(),
            "type": type_,
            "message": stored_text(message),
            "progress": progress,
        },
    )


SHORT_ID_MIN = 8  #: the shortest id prefix accepted for a job (the CLI prints 12 characters)


def resolve_id(engine: Engine, job_id: str) -> str:
    """The full id of a job named by its id or a unique prefix of at least SHORT_ID_MIN hex characters (what
    the CLI and dashboard print); other strings come back unchanged (an unknown id stays unknown)."""
    if not SHORT_ID_MIN <= len(job_id) < 32 or any(c not in "0123456789abcdef" for c in job_id):
        return job_id
    with engine.connect() as conn:
        found = list(conn.execute(select(jobs.c.id).where(jobs.c.id.startswith(job_id, autoescape=True)).limit(2))
                     .scalars())  # fmt: skip
    if len(found) > 1:
        raise JobNotFound(
            f"job id prefix {job_id!r} matches several jobs ({', '.join(found)}, ...): give more of it"
        )
    return found[0] if found else job_id


def _get(conn: Connection, job_id: str) -> dict[str, Any]:
    row = conn.execute(select(jobs).where(jobs.c.id == job_id)).mappings().first()
    if row is None:
        raise JobNotFound(f"no job with id {job_id!r}")
    return dict(row)


# ---------------------------------------------------------------------------------------------- submission


def _new_row(kind: str, spec: dict[str, Any], priority: int, timeout_s: float | None, max_attempts: int,
             idempotency_key: str | None, parent_id: str | None, labels: dict[str, Any] | None) -> dict[str, Any]:  # fmt: skip
    """A job row; ``labels`` the optional ``name``, ``tags`` and ``note`` (``store.labels``)."""
    labels = labels or {}
    return dict(
        id=new_id(), kind=kind, spec=spec, status=QUEUED, priority=priority, attempts=0,
        max_attempts=max_attempts, timeout_s=timeout_s, idempotency_key=idempotency_key, parent_id=parent_id,
        cancel_requested=False, progress=0.0, message="", created_at=time.time(),
        name=labels.get("name"), tags=list(labels.get("tags") or []), note=labels.get("note") or "",
    )  # fmt: skip


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
) -> tuple[dict[str, Any], bool]:
    """Queue a job; returns ``(job, created)``. A known idempotency key returns its job (``created`` False).
    ``labels``: the job's optional ``name``, ``tags`` and ``note``."""
    if idempotency_key is not None:
        existing = find_by_key(engine, idempotency_key)
        if existing is not None:
            return _same_submission(existing, kind, spec), False
    row = _new_row(kind, spec, priority, timeout_s, max_attempts, idempotency_key, parent_id, labels)
    if idempotency_key is None and parent_id is None and is_sqlite(engine):
        done = threading.Event()
        failed: list[BaseException] = []
        _batcher(engine).put(row, lambda error: (error and failed.append(error), done.set()))
        done.wait()
        if failed:
            raise failed[0]
        return {**_JOB_DEFAULTS, **row}, True
    try:
        with write_tx(engine) as conn:
            job = conn.execute(_SUBMIT_SQL, row).mappings().one()
            labels_store.insert_tags(conn, [row])
            _add_event(conn, row["id"], "status", QUEUED)
    except IntegrityError:
        existing = find_by_key(engine, idempotency_key) if idempotency_key else None
        if existing is None:
            raise
        return _same_submission(existing, kind, spec), False  # a concurrent submission with the same key won
    return dict(job), True


async def submit_plain(engine: Engine, *, kind: str, spec: dict[str, Any], priority: int = 0,
                       timeout_s: float | None = None, max_attempts: int = 3,
                       labels: dict[str, Any] | None = None) -> dict[str, Any]:  # fmt: skip
    """Queue a job without idempotency key or parent from the event loop, on SQLite: the request waits on a
    future while the engine's submission thread (:class:`SubmitBatcher`) writes it, so it holds no thread."""
    import asyncio

    loop = asyncio.get_running_loop()
    future: asyncio.Future[None] = loop.create_future()

    def settle(error: BaseException | None) -> None:
        if not future.done():
            future.set_exception(error) if error is not None else future.set_result(None)

    row = _new_row(kind, spec, priority, timeout_s, max_attempts, None, None, labels)
    _batcher(engine).put(row, lambda error: loop.call_soon_threadsafe(settle, error))
    await future
    return {**_JOB_DEFAULTS, **row}


class SubmitBatcher:
    """Group commit of plain submissions on SQLite, by one thread per engine and process.

    Submissions queue here in arrival order; the thread takes every submission waiting, inserts them in one
    write transaction (one writer-lock hand-off and one commit for many requests), and reports to each.
    Before, each request's own thread-pool thread raced for the process's writer lock: Python locks are not
    fair, so under 40 contending threads some requests waited for many batches (p99 97 ms in-process, 40 ms
    with this thread, at ~1.5x the throughput). The thread exits when idle and starts again on demand.
    """

    IDLE_S = 5.0  #: [s] the thread stops after this long without submissions

    def __init__(self, engine: Engine) -> None:
        self.engine = engine
        self._pending: list[tuple[dict[str, Any], Callable[[BaseException | None], Any]]] = []
        self._cv = threading.Condition()
        self._running = False

    def put(self, row: dict[str, Any], done: Callable[[BaseException | None], Any]) -> None:
        """Queue ``row``; ``done(None)`` once it is committed, ``done(error)`` if its batch failed (from the
        submission thread)."""
        with self._cv:
            self._pending.append((row, done))
            if not self._running:
                self._running = True
                threading.Thread(target=self._run, name="foresight-submit", daemon=True).start()
            self._cv.notify()

    def _run(self) -> None:
        while True:
            with self._cv:
                if not self._pending and not self._cv.wait_for(lambda: self._pending, timeout=self.IDLE_S):
                    self._running = False
                    return
                batch, self._pending = self._pending, []
            error: BaseException | None = None
            try:
                with write_tx(self.engine) as conn:
                    conn.execute(insert(jobs), [row for row, _ in batch])
                    labels_store.insert_tags(conn, [row for row, _ in batch])
                    conn.execute(_EVENT_SQL, [{"job_id": row["id"], "at": row["created_at"], "type": "status",
                                               "message": QUEUED, "progress": None} for row, _ in batch])  # fmt: skip
            except Exception as exc:  # noqa: BLE001 (every submission of the batch fails the same way)
                error = exc
            for _, done in batch:
                done(error)


_batchers: weakref.WeakValueDictionary[int, SubmitBatcher] = (
    weakref.WeakValueDictionary()
)  # by id(engine.pool)
_batchers_lock = threading.Lock()


def _batcher(engine: Engine) -> SubmitBatcher:
    with _batchers_lock:
        batcher = _batchers.get(id(engine.pool))
        if batcher is None or batcher.engine.pool is not engine.pool:
            batcher = _batchers[id(engine.pool)] = SubmitBatcher(engine)
        return batcher


#: the columns a fresh job has beyond what submit sets
_JOB_DEFAULTS = {"lease_owner": None, "lease_expires_at": None, "error_type": None, "error_message": None,
                 "result": None, "started_at": None, "finished_at": None}  # fmt: skip


def _same_submission(job: dict[str, Any], kind: str, spec: dict[str, Any]) -> dict[str, Any]:
    if job["kind"] != kind or job["spec"] != spec:
        raise IdempotencyConflict(
            f"idempotency key {job['idempotency_key']!r} was used for job {job['id']} with a different spec"
        )
    return job


def find_by_key(engine: Engine, key: str) -> dict[str, Any] | None:
    with engine.connect() as conn:
        row = conn.execute(select(jobs).where(jobs.c.idempotency_key == key)).mappings().first()
    return dict(row) if row else None


# ------------------------------------------------------------------------------------------ worker side


def claim(
    engine: Engine, worker_id: str, kinds: Sequence[str], lease_s: float, *, peek: bool = True
) -> dict[str, Any] | None:
    """Take the highest-priority, oldest queued job of one of ``kinds``; None when there is none.

    ``peek`` reads first and only takes the write lock when a job is waiting, so that idle workers polling
    do not queue for the lock; a busy worker (its last claim found a job) skips that read.
    """
    if peek:
        with engine.connect() as conn:
            if conn.execute(_ANY_QUEUED_SQL, {"kinds": list(kinds)}).first() is None:
                return None
    now = time.time()
    params = {"owner": worker_id, "expires": now + lease_s, "now": now, "kinds": list(kinds)}
    if engine.dialect.name == "postgresql":
        with write_tx(engine) as conn:
            _no_fsync(conn)
            row = conn.execute(_CLAIM_PG_SQL, params).mappings().first()
        return dict(row) if row else None
    with write_tx(engine) as conn:
        # SQLite allows one writer at a time: between BEGIN IMMEDIATE and COMMIT the statements go straight to
        # the driver (SQLAlchemy's per-statement work held the lock ~3x longer; API submissions wait on it)
        cur = conn.connection.dbapi_connection.cursor()
        kinds = {f"k{i}": k for i, k in enumerate(params["kinds"])}
        cur.execute(
            _claim_sqlite_sql(len(kinds)),
            {"owner": worker_id, "expires": params["expires"], "now": now, **kinds},
        )
        row = _sqlite_job(cur)
        if row is None:
            return None
        cur.execute(
            _EVENT_SQLITE,
            (row["id"], now, "status", f"{RUNNING} (attempt {row['attempts']}, worker {worker_id})", None),
        )
    return row


def claim_id(engine: Engine, job_id: str, worker_id: str, lease_s: float) -> dict[str, Any] | None:
    """Take one queued job by id (a pipeline runs its own children in its slot); None when it is not queued."""
    now = time.time()
    with write_tx(engine) as conn:
        row = conn.execute(
            update(jobs).where(jobs.c.id == job_id, jobs.c.status == QUEUED)
            .values(status=RUNNING, lease_owner=worker_id, lease_expires_at=now + lease_s,
                    attempts=jobs.c.attempts + 1, started_at=now, progress=0.0, message="")
            .returning(*jobs.c)
        ).mappings().first()  # fmt: skip
        if row is None:
            return None
        _add_event(conn, job_id, "status", f"{RUNNING} (attempt {row['attempts']}, worker {worker_id})")
    return dict(row)


def _no_fsync(conn: Connection) -> None:
    """PostgreSQL: commit this transaction without waiting for its WAL flush (claims, heartbeats, progress).

    A database crash may then forget the last moments of these: a forgotten claim puts the job back in
    the queue while its worker still runs it, but a job's finish (result, artifacts, records; always
    flushed) is guarded by owner and attempt, so the work may run twice, its result is stored once.
    """
    if conn.dialect.name == "postgresql":
        conn.exec_driver_sql("SET LOCAL synchronous_commit TO OFF")


def _held(job_id: str, owner: str, attempt: int):  # noqa: ANN202
    return (
        jobs.c.id == job_id,
        jobs.c.status == RUNNING,
        jobs.c.lease_owner == owner,
        jobs.c.attempts == attempt,
    )


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
        conn.execute(_BEAT_WORKER_SQL, {"now": now, "owner": worker_id})
        if not held:
            return set(), set()
        rows = conn.execute(_BEAT_JOBS_SQL, {"expires": now + lease_s, "ids": held, "owner": worker_id}).all()
    owned = {r.id for r in rows}
    return {r.id for r in rows if r.cancel_requested}, set(held) - owned


def report_progress(
    engine: Engine, job_id: str, owner: str, attempt: int, fraction: float, message: str
) -> None:
    with write_tx(engine) as conn:
        _no_fsync(conn)
        held = {"id": job_id, "owner": owner, "attempt": attempt}
        n = conn.execute(_PROGRESS_SQL, {**held, "progress": fraction, "message": stored_text(message)})
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
) -> None:
    """Mark a held job succeeded, storing its result summary, artifact records and (through ``record``) its
    result rows in the same transaction."""
    now = time.time()
    with write_tx(engine) as conn:
        params = {"id": job_id, "owner": owner, "attempt": attempt, "result": result, "now": now}
        if engine.dialect.name == "postgresql":
            done = conn.execute(_FINISH_PG_SQL, params).scalar_one()
        else:  # straight to the driver while SQLite's write lock is held (see claim)
            cur = conn.connection.dbapi_connection.cursor()
            done = cur.execute(_FINISH_SQLITE, (json.dumps(result), now, job_id, owner, attempt)).rowcount
            if done:
                cur.execute(_EVENT_SQLITE, (job_id, now, "status", SUCCEEDED, 1.0))
        if done == 0:
            raise LeaseLost(f"job {job_id}: lease lost before finishing (attempt {attempt})")
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
        job = conn.execute(select(jobs.c.max_attempts).where(*_held(job_id, owner, attempt))).first()
        if job is None:
            raise LeaseLost(f"job {job_id}: lease lost before failing (attempt {attempt})")
        again = retry and attempt < job.max_attempts
        error_type, message = stored_text(error_type), stored_text(message)
        values: dict[str, Any] = dict(error_type=error_type, error_message=message, lease_expires_at=None)
        if again:
            values.update(status=QUEUED, lease_owner=None)
        else:
            values.update(status=FAILED, finished_at=now)
        conn.execute(update(jobs).where(*_held(job_id, owner, attempt)).values(**values))
        status = QUEUED if again else FAILED
        _add_event(conn, job_id, "status", f"{status}: {error_type}: {message}")
    return status


def mark_cancelled(engine: Engine, job_id: str, owner: str, attempt: int) -> None:
    """A held job stopped because its cancellation was requested."""
    with write_tx(engine) as conn:
        n = conn.execute(
            update(jobs)
            .where(*_held(job_id, owner, attempt))
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
            .where(*_held(job_id, owner, attempt))
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
        failed = conn.execute(
            update(jobs)
            .where(*expired, jobs.c.attempts >= jobs.c.max_attempts)
            .values(status=FAILED, error_type="LeaseExpired",
                    error_message="the worker stopped heartbeating and no attempts remain", **done)
            .returning(jobs.c.id)
        ).scalars().all()  # fmt: skip
        requeued = conn.execute(
            update(jobs)
            .where(*expired)
            .values(status=QUEUED, lease_owner=None, lease_expires_at=None, error_type="LeaseExpired",
                    error_message="the worker stopped heartbeating; queued again")
            .returning(jobs.c.id)
        ).scalars().all()  # fmt: skip
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
            insert(workers).values(id=worker_id, host=host, pid=pid, concurrency=concurrency, kinds=kinds,
                                   started_at=now, heartbeat_at=now)
        )  # fmt: skip


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
            update(jobs).where(jobs.c.id == job_id, jobs.c.status == QUEUED)
            .values(status=CANCELLED, cancel_requested=True, finished_at=now)
        ).rowcount  # fmt: skip
        if n:
            _add_event(conn, job_id, "status", CANCELLED)
            return CANCELLED
        n = conn.execute(
            update(jobs).where(jobs.c.id == job_id, jobs.c.status == RUNNING).values(cancel_requested=True)
        ).rowcount
        if n:
            _add_event(conn, job_id, "log", "cancellation requested")
            return RUNNING
        job = _get(conn, job_id)
    raise Conflict(f"job {job_id} is already {job['status']}; only queued or running jobs can be cancelled")


def retry(engine: Engine, job_id: str) -> dict[str, Any]:
    """Queue a failed or cancelled job again, with a fresh attempt count; the job as queued (read in the same
    transaction: a worker may claim it the moment it commits)."""
    with write_tx(engine) as conn:
        n = conn.execute(
            update(jobs)
            .where(jobs.c.id == job_id, jobs.c.status.in_((FAILED, CANCELLED)))
            .values(status=QUEUED, attempts=0, cancel_requested=False, lease_owner=None, lease_expires_at=None,
                    progress=0.0, message="", error_type=None, error_message=None, finished_at=None)
        ).rowcount  # fmt: skip
        if n:
            _add_event(conn, job_id, "status", f"{QUEUED} (retry)")
            return _get(conn, job_id)
        job = _get(conn, job_id)
    raise Conflict(f"job {job_id} is {job['status']}; only failed or cancelled jobs can be retried")


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
            job = _get(conn, job_id)
            raise Conflict(
                f"job {job_id} is {job['status']}; only finished jobs can be deleted (cancel it first)"
            )
    return arts


def list_filter(statuses: Sequence[str] = (), kinds: Sequence[str] = (), parent_id: str | None = None,
                name: str | None = None, tags: Sequence[str] = (), q: str | None = None) -> list:  # fmt: skip
    """The WHERE terms of the job list (labels: ``store.labels.label_filter``)."""
    where = labels_store.label_filter(name, tags, q)
    if statuses:
        where.append(jobs.c.status.in_(list(statuses)))
    if kinds:
        where.append(jobs.c.kind.in_(list(kinds)))
    if parent_id:
        where.append(jobs.c.parent_id == parent_id)
    return where


def list_page_query(where: list, limit: int, offset: int):  # noqa: ANN201
    """One page of the job list, newest first (the order of the ``ix_jobs_*created`` indexes)."""
    return (
        select(jobs).where(*where).order_by(jobs.c.created_at.desc(), jobs.c.id).limit(limit).offset(offset)
    )


def list_jobs(
    engine: Engine, *, statuses: Sequence[str] = (), kinds: Sequence[str] = (), parent_id: str | None = None,
    name: str | None = None, tags: Sequence[str] = (), q: str | None = None, limit: int = 50, offset: int = 0,
) -> tuple[int, list[dict[str, Any]]]:  # fmt: skip
    """``(total matching, one page of jobs)``, newest first, filtered by status, kind, parent and labels."""
    where = list_filter(statuses, kinds, parent_id, name, tags, q)
    with engine.connect() as conn:
        count = conn.execute(select(func.count()).select_from(jobs).where(*where)).scalar_one()
        rows = [dict(r) for r in conn.execute(list_page_query(where, limit, offset)).mappings()]
    return count, rows


def get_job(engine: Engine, job_id: str) -> dict[str, Any]:
    with engine.connect() as conn:
        return _get(conn, job_id)


def events_after(engine: Engine, job_id: str, after_id: int, limit: int = 500) -> list[dict[str, Any]]:
    with engine.connect() as conn:
        rows = conn.execute(
            select(events)
            .where(events.c.job_id == job_id, events.c.id > after_id)
            .order_by(events.c.id)
            .limit(limit)
        ).mappings()
        return [dict(r) for r in rows]


def depth(engine: Engine) -> dict[str, dict[str, int]]:
    """Job counts per kind and status."""
    with engine.connect() as conn:
        rows = conn.execute(
            select(jobs.c.kind, jobs.c.status, func.count()).group_by(jobs.c.kind, jobs.c.status)
        )
        out: dict[str, dict[str, int]] = {}
        for kind, status, count in rows:
            out.setdefault(kind, {})[status] = count
    return out


_JOB_BY_ID = select(jobs).where(jobs.c.id == bindparam("job_id"))
_ARTIFACTS_OF = (
    select(artifacts.c.name, artifacts.c.size, artifacts.c.sha256, artifacts.c.path)
    .where(artifacts.c.job_id == bindparam("job_id"))
    .order_by(artifacts.c.name)
)
_CHILDREN_OF = (
    select(jobs.c.id, jobs.c.kind, jobs.c.name, jobs.c.status, jobs.c.progress)
    .where(jobs.c.parent_id == bindparam("job_id"))
    .order_by(jobs.c.created_at)
)


def job_detail(
    engine: Engine, job_id: str
) -> tuple[dict[str, Any], list[dict[str, Any]], list[dict[str, Any]]]:
    """(the job, its artifacts by name, its children (id, kind, name, status, progress) oldest first): three indexed
    lookups on one connection (the most frequent read: clients polling)."""
    params = {"job_id": job_id}
    with engine.connect() as conn:
        row = conn.execute(_JOB_BY_ID, params).mappings().first()
        if row is None:
            raise JobNotFound(f"no job with id {job_id!r}")
        arts = [dict(a) for a in conn.execute(_ARTIFACTS_OF, params).mappings()]
        children = [dict(c) for c in conn.execute(_CHILDREN_OF, params).mappings()]
    return dict(row), arts, children


def find_artifact(engine: Engine, job_id: str, name: str) -> dict[str, Any]:
    """The artifact record ``name`` of a job; :class:`JobNotFound` naming the job or the artifact."""
    with engine.connect() as conn:
        row = (
            conn.execute(select(artifacts).where(artifacts.c.job_id == job_id, artifacts.c.name == name))
            .mappings()
            .first()
        )
    if row is None:
        get_job(engine, job_id)
        raise JobNotFound(f"job {job_id} has no artifact {name!r}")
    return dict(row)


def finished_jobs(engine: Engine, kinds: Sequence[str], limit: int) -> list[dict[str, Any]]:
    """The newest succeeded or failed jobs of ``kinds`` (id, kind, status, result, finished_at, created_at, name,
    tags)."""
    with engine.connect() as conn:
        rows = conn.execute(
            select(jobs.c.id, jobs.c.kind, jobs.c.status, jobs.c.result, jobs.c.finished_at, jobs.c.created_at,
                   jobs.c.name, jobs.c.tags)
            .where(jobs.c.kind.in_(list(kinds)), jobs.c.status.in_([SUCCEEDED, FAILED]))
            .order_by(jobs.c.created_at.desc()).limit(limit)
        ).mappings().all()  # fmt: skip
    return [dict(r) for r in rows]


def ping(engine: Engine) -> str:
    """The database's dialect name, after a round trip (``SELECT 1``)."""
    with engine.connect() as conn:
        conn.execute(text("SELECT 1"))
    return engine.dialect.name


def alive_workers(engine: Engine, heard_since: float) -> list[dict[str, Any]]:
    """Workers not stopped and heard from since ``heard_since``, oldest first, each with ``jobs``: the ids of
    the running jobs it holds."""
    with engine.connect() as conn:
        rows = conn.execute(
            select(workers).where(workers.c.stopped_at.is_(None), workers.c.heartbeat_at >= heard_since)
            .order_by(workers.c.started_at)
        ).mappings().all()  # fmt: skip
        running = conn.execute(select(jobs.c.id, jobs.c.lease_owner).where(jobs.c.status == RUNNING)).all()
    held: dict[str, list[str]] = {}
    for job_id, owner in running:
        held.setdefault(owner, []).append(job_id)
    return [{**r, "jobs": held.get(r["id"], [])} for r in rows]


def oldest_queued_at(engine: Engine) -> float | None:
    """When the oldest queued job was submitted (None: nothing queued)."""
    with engine.connect() as conn:
        return conn.execute(
            select(jobs.c.created_at).where(jobs.c.status == QUEUED).order_by(jobs.c.created_at).limit(1)
        ).scalar()


def delete_job_and_files(engine: Engine, store_root: Path, job_id: str) -> None:
    """Delete a finished job and its whole folder (partial files a failed run or a full disk left too, not only
    the recorded artifacts), keeping the files a model or dataset record uses."""
    with engine.connect() as conn:
        used = set(conn.execute(select(Model.checkpoint).where(Model.job_id == job_id)).scalars())
        used |= set(conn.execute(select(Dataset.path).where(Dataset.job_id == job_id)).scalars())
    delete_job(engine, job_id)
    folder = folders.resolve_under(store_root, folders.job_dir(store_root, job_id))
    for path in sorted(folder.rglob("*"), reverse=True) if folder.is_dir() else []:
        if not path.is_dir() and path.relative_to(store_root.resolve()).as_posix() not in used:
            path.unlink(missing_ok=True)
    folders.remove_empty(folder)
