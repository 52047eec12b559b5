"""The job queue's vocabulary: its tables, statuses, errors and the typed row a job comes back as.

A :class:`JobRow` is a frozen dataclass with one typed attribute per column of ``jobs``; it also reads as a
mapping (``job["status"]``, ``dict(job)``, ``{**job}``) so that templates and serialisers take it as they took
the plain dicts before.
"""

from __future__ import annotations

import dataclasses
import uuid
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from typing import Any

from foresight.store.models import FINISHED, Artifact, Job, JobEvent, JobStatus, Worker
from foresight.store.session import json_deserializer

jobs = Job.__table__
events = JobEvent.__table__
workers = Worker.__table__
artifacts = Artifact.__table__

QUEUED, RUNNING = JobStatus.queued.value, JobStatus.running.value
SUCCEEDED, FAILED, CANCELLED = JobStatus.succeeded.value, JobStatus.failed.value, JobStatus.cancelled.value
FINISHED_VALUES = tuple(s.value for s in FINISHED)


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


@dataclass(frozen=True, slots=True, eq=False)  # equal to any mapping of the same items (Mapping.__eq__)
class JobRow(Mapping[str, Any]):
    """One row of ``jobs``, typed (``store.models.Job`` has the columns' meaning)."""

    id: str
    kind: str
    spec: dict[str, Any]
    status: str
    priority: int
    attempts: int
    max_attempts: int
    timeout_s: float | None
    idempotency_key: str | None
    parent_id: str | None
    lease_owner: str | None
    lease_expires_at: float | None
    cancel_requested: bool
    progress: float
    message: str
    error_type: str | None
    error_message: str | None
    result: dict[str, Any] | None
    created_at: float
    started_at: float | None
    finished_at: float | None
    name: str | None
    tags: list[str]
    note: str

    @classmethod
    def of(cls, row: Mapping[str, Any]) -> JobRow:
        """The row of a SQLAlchemy mapping (or a dict with every column; booleans and tags normalised)."""
        values = {f: row[f] for f in _FIELDS}
        values["cancel_requested"] = bool(values["cancel_requested"])
        values["tags"] = list(values["tags"] or [])
        values["note"] = values["note"] or ""
        return cls(**values)

    @classmethod
    def of_sqlite(cls, cur: Any) -> JobRow | None:
        """The first row of a ``RETURNING *`` read straight from the SQLite driver (JSON columns decoded)."""
        rows = cur.fetchall()
        if not rows:
            return None
        raw = dict(zip([d[0] for d in cur.description], rows[0], strict=True))
        for column in ("spec", "result", "tags"):
            raw[column] = json_deserializer(raw[column]) if raw[column] is not None else None
        return cls.of(raw)

    def __getitem__(self, key: str) -> Any:
        if key not in _FIELDS:
            raise KeyError(key)
        return getattr(self, key)

    def __iter__(self) -> Iterator[str]:
        return iter(_FIELDS)

    def __len__(self) -> int:
        return len(_FIELDS)


_FIELDS = tuple(f.name for f in dataclasses.fields(JobRow))
