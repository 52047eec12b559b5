"""The job queue's prebuilt statements (the hot path: claim, heartbeat, progress, finish, submit).

Building SQLAlchemy expressions per call cost more than the statements themselves (~1 ms a job on a busy
2-core machine), so these are text, built once. :data:`HELD` is THE guard of every worker transition: finish,
fail, cancel, release and progress all check it, in text here and through :func:`held` in expressions.
"""

from __future__ import annotations

import functools

from sqlalchemy import JSON, Boolean, bindparam, text

JOB_TYPES = {"spec": JSON, "result": JSON, "tags": JSON, "cancel_requested": Boolean}
CLAIM = """
UPDATE jobs SET status = 'running', lease_owner = :owner, lease_expires_at = :expires, attempts = attempts + 1,
                started_at = :now, progress = 0.0, message = ''
WHERE id = (SELECT id FROM jobs WHERE status = 'queued' AND kind IN :kinds
            ORDER BY priority DESC, created_at, id LIMIT 1 {lock})
  AND status = 'queued'
RETURNING *
"""
# PostgreSQL: skip rows other claimers hold, and write the status event in the same statement (a
# data-modifying CTE saves a round trip per claim).
CLAIM_PG_SQL = (
    text(
        "WITH claimed AS (" + CLAIM.format(lock="FOR UPDATE SKIP LOCKED") + "), "
        "ev AS (INSERT INTO job_events (job_id, at, type, message) "
        "SELECT id, :now, 'status', 'running (attempt ' || attempts || ', worker ' || :owner || ')' FROM claimed) "
        "SELECT * FROM claimed"
    )
    .bindparams(bindparam("kinds", expanding=True))
    .columns(**JOB_TYPES)
)
SUBMIT_COLUMNS = (
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
SUBMIT_SQL = (
    text(
        f"INSERT INTO jobs ({', '.join(SUBMIT_COLUMNS)}) VALUES ({', '.join(':' + c for c in SUBMIT_COLUMNS)}) RETURNING *"
    )
    .bindparams(
        bindparam("spec", type_=JSON),
        bindparam("tags", type_=JSON),
        bindparam("cancel_requested", type_=Boolean),
    )
    .columns(**JOB_TYPES)
)
ANY_QUEUED_SQL = text("SELECT 1 FROM jobs WHERE status = 'queued' AND kind IN :kinds LIMIT 1").bindparams(
    bindparam("kinds", expanding=True)
)
#: THE guard of every worker transition (finish, fail, cancel, release, progress): this attempt holds the lease
HELD = "id = :id AND status = 'running' AND lease_owner = :owner AND attempts = :attempt"
FINISH_PG_SQL = text(
    "WITH done AS (UPDATE jobs SET status = 'succeeded', result = :result, progress = 1.0, finished_at = :now, "
    f"lease_expires_at = NULL, error_type = NULL, error_message = NULL WHERE {HELD} RETURNING id), "
    "ev AS (INSERT INTO job_events (job_id, at, type, message, progress) SELECT id, :now, 'status', 'succeeded', 1.0 "
    "FROM done) SELECT count(*) FROM done"
).bindparams(bindparam("result", type_=JSON))
PROGRESS_SQL = text(f"UPDATE jobs SET progress = :progress, message = :message WHERE {HELD}")
BEAT_WORKER_SQL = text("UPDATE workers SET heartbeat_at = :now WHERE id = :owner")
BEAT_JOBS_SQL = (
    text(
        "UPDATE jobs SET lease_expires_at = :expires WHERE id IN :ids AND status = 'running' AND lease_owner = :owner "
        "RETURNING id, cancel_requested"
    )
    .bindparams(bindparam("ids", expanding=True))
    .columns(cancel_requested=Boolean)
)


# The same statements for the SQLite driver itself (qmark parameters), run inside write transactions.
EVENT_SQLITE = "INSERT INTO job_events (job_id, at, type, message, progress) VALUES (?, ?, ?, ?, ?)"
FINISH_SQLITE = (
    "UPDATE jobs SET status = 'succeeded', result = :result, progress = 1.0, finished_at = :now, "
    f"lease_expires_at = NULL, error_type = NULL, error_message = NULL WHERE {HELD}"
)


@functools.lru_cache(maxsize=16)
def claim_sqlite_sql(n_kinds: int) -> str:
    """The claim with named parameters ``:owner, :expires, :now, :k0 ... :k<n-1>``."""
    return CLAIM.format(lock="").replace(":kinds", "(" + ", ".join(f":k{i}" for i in range(n_kinds)) + ")")


def held(job_id: str, owner: str, attempt: int):  # noqa: ANN201
    """:data:`HELD` bound to one attempt, for SQLAlchemy statements."""
    return text(HELD).bindparams(id=job_id, owner=owner, attempt=attempt)
