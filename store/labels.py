"""Job labels: a name, tags and a free-text note that researchers give their runs, to find them again.

Tags live twice: in ``jobs.tags`` (their order, read with the job) and in ``job_tags`` (one row per tag, the
index the list's ``?tag=`` filter reads on SQLite and PostgreSQL alike, where a JSON column has no portable
containment test). Both are written in the same transaction.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

from sqlalchemy import Connection, Engine, delete, func, insert, or_, select, update

from foresight.store.models import Job, JobTag
from foresight.store.session import write_tx

jobs = Job.__table__
job_tags = JobTag.__table__

UNSET: Any = object()  #: "leave as it is" for :func:`edit`


def insert_tags(conn: Connection, rows: Iterable[dict[str, Any]]) -> None:
    """The ``job_tags`` rows of freshly inserted jobs (each row a job with ``id`` and ``tags``)."""
    values = [{"job_id": r["id"], "tag": t} for r in rows for t in r.get("tags") or ()]
    if values:
        conn.execute(insert(job_tags), values)


def merged_tags(
    current: Sequence[str], *, replace: Sequence[str] | None, add: Sequence[str], remove: Sequence[str]
) -> list[str]:
    """The tag list after an edit: ``replace`` (when given) instead of ``current``, then ``add`` appended
    (no duplicates), then ``remove`` dropped; first-seen order kept."""
    out: list[str] = []
    for t in [*(current if replace is None else replace), *add]:
        if t not in out and t not in remove:
            out.append(t)
    return out


def edit(
    engine: Engine,
    job_id: str,
    *,
    name: Any = UNSET,
    note: Any = UNSET,
    tags: Sequence[str] | None = None,
    add: Sequence[str] = (),
    remove: Sequence[str] = (),
) -> bool:
    """Change a job's labels (any status); False when there is no such job."""
    with write_tx(engine) as conn:
        current = conn.execute(select(jobs.c.tags).where(jobs.c.id == job_id)).first()
        if current is None:
            return False
        values: dict[str, Any] = {}
        if name is not UNSET:
            values["name"] = name
        if note is not UNSET:
            values["note"] = note
        if tags is not None or add or remove:
            new = merged_tags(current[0] or [], replace=tags, add=add, remove=remove)
            values["tags"] = new
            conn.execute(delete(job_tags).where(job_tags.c.job_id == job_id))
            insert_tags(conn, [{"id": job_id, "tags": new}])
        if values:
            conn.execute(update(jobs).where(jobs.c.id == job_id).values(**values))
    return True


def label_filter(name: str | None = None, tags: Sequence[str] = (), q: str | None = None) -> list:
    """WHERE terms of the job list: exact ``name``, every one of ``tags``, and ``q`` as a case-insensitive
    substring of the name or the note."""
    where: list = []
    if name:
        where.append(jobs.c.name == name)
    for tag in dict.fromkeys(tags):
        where.append(jobs.c.id.in_(select(job_tags.c.job_id).where(job_tags.c.tag == tag)))
    if q:
        pattern = "%" + q.lower().replace("\\", "\\\\").replace("%", "\\%").replace("_", "\\_") + "%"
        where.append(
            or_(
                func.lower(jobs.c.name).like(pattern, escape="\\"),
                func.lower(jobs.c.note).like(pattern, escape="\\"),
            )
        )
    return where


def known_tags(engine: Engine, limit: int = 200) -> list[tuple[str, int]]:
    """(tag, number of jobs) of the most used tags: what the dashboard offers as filters."""
    with engine.connect() as conn:
        rows = conn.execute(
            select(job_tags.c.tag, func.count())
            .group_by(job_tags.c.tag)
            .order_by(func.count().desc(), job_tags.c.tag)
            .limit(limit)
        )
        return [(t, n) for t, n in rows]
