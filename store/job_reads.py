"""Reading the job queue: jobs by id, prefix or idempotency key, pages of the list, events, artifacts, workers.

Nothing here writes; the transitions are ``store.queue``. Jobs come back as typed rows (``store.job_rows.JobRow``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from sqlalchemy import Connection, Engine, bindparam, func, select, text

from foresight.store import labels as labels_store
from foresight.store.job_rows import (
    FAILED,
    QUEUED,
    RUNNING,
    SUCCEEDED,
    JobNotFound,
    JobRow,
    artifacts,
    events,
    jobs,
    workers,
)
from foresight.store.session import is_sqlite

SHORT_ID_MIN = 8  #: the shortest id prefix accepted for a job (the CLI prints 12 characters)


def resolve_id(engine: Engine, job_id: str) -> str:
    """The full id of a job named by its id or a unique prefix of at least SHORT_ID_MIN hex characters (what
    the CLI and dashboard print); other strings come back unchanged (an unknown id stays unknown)."""
    if not SHORT_ID_MIN <= len(job_id) < 32 or any(c not in "0123456789abcdef" for c in job_id):
        return job_id
    with engine.connect() as conn:
        found = list(
            conn.execute(
                select(jobs.c.id).where(jobs.c.id.startswith(job_id, autoescape=True)).limit(2)
            ).scalars()
        )
    if len(found) > 1:
        raise JobNotFound(
            f"job id prefix {job_id!r} matches several jobs ({', '.join(found)}, ...): give more of it"
        )
    return found[0] if found else job_id


def get(conn: Connection, job_id: str) -> JobRow:
    """The job ``job_id`` read on ``conn`` (inside a caller's transaction); :class:`JobNotFound` if none."""
    row = conn.execute(select(jobs).where(jobs.c.id == job_id)).mappings().first()
    if row is None:
        raise JobNotFound(f"no job with id {job_id!r}")
    return JobRow.of(row)


def find_by_key(engine: Engine, key: str) -> JobRow | None:
    with engine.connect() as conn:
        row = conn.execute(select(jobs).where(jobs.c.idempotency_key == key)).mappings().first()
    return JobRow.of(row) if row else None


def list_filter(
    statuses: Sequence[str] = (),
    kinds: Sequence[str] = (),
    parent_id: str | None = None,
    name: str | None = None,
    tags: Sequence[str] = (),
    q: str | None = None,
) -> list:
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
    engine: Engine,
    *,
    statuses: Sequence[str] = (),
    kinds: Sequence[str] = (),
    parent_id: str | None = None,
    name: str | None = None,
    tags: Sequence[str] = (),
    q: str | None = None,
    limit: int = 50,
    offset: int = 0,
) -> tuple[int, list[JobRow]]:
    """``(total matching, one page of jobs)``, newest first, filtered by status, kind, parent and labels."""
    where = list_filter(statuses, kinds, parent_id, name, tags, q)
    with engine.connect() as conn:
        count = conn.execute(select(func.count()).select_from(jobs).where(*where)).scalar_one()
        rows = [JobRow.of(r) for r in conn.execute(list_page_query(where, limit, offset)).mappings()]
    return count, rows


def get_job(engine: Engine, job_id: str) -> JobRow:
    with engine.connect() as conn:
        return get(conn, job_id)


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


def job_detail(engine: Engine, job_id: str) -> tuple[JobRow, list[dict[str, Any]], list[dict[str, Any]]]:
    """(the job, its artifacts by name, its children (id, kind, status, progress) oldest first): three indexed
    lookups on one connection (the most frequent read: clients polling)."""
    params = {"job_id": job_id}
    with engine.connect() as conn:
        row = conn.execute(_JOB_BY_ID, params).mappings().first()
        if row is None:
            raise JobNotFound(f"no job with id {job_id!r}")
        arts = [dict(a) for a in conn.execute(_ARTIFACTS_OF, params).mappings()]
        children = [dict(c) for c in conn.execute(_CHILDREN_OF, params).mappings()]
    return JobRow.of(row), arts, children


async def job_detail_async(
    engine: Engine, job_id: str
) -> tuple[JobRow, list[dict[str, Any]], list[dict[str, Any]]]:
    """:func:`job_detail` from the event loop: on SQLite inline (three indexed lookups take well under a
    millisecond, less than a thread hand-off), on other databases in a worker thread."""
    if is_sqlite(engine):
        return job_detail(engine, job_id)
    import anyio.to_thread

    return await anyio.to_thread.run_sync(job_detail, engine, job_id)


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
        rows = (
            conn.execute(
                select(
                    jobs.c.id,
                    jobs.c.kind,
                    jobs.c.status,
                    jobs.c.result,
                    jobs.c.finished_at,
                    jobs.c.created_at,
                    jobs.c.name,
                    jobs.c.tags,
                )
                .where(jobs.c.kind.in_(list(kinds)), jobs.c.status.in_([SUCCEEDED, FAILED]))
                .order_by(jobs.c.created_at.desc())
                .limit(limit)
            )
            .mappings()
            .all()
        )
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
        rows = (
            conn.execute(
                select(workers)
                .where(workers.c.stopped_at.is_(None), workers.c.heartbeat_at >= heard_since)
                .order_by(workers.c.started_at)
            )
            .mappings()
            .all()
        )
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
