"""SQLAlchemy table models. Times are float seconds since the Unix epoch (UTC) in every ``*_at`` column:
one representation on SQLite and PostgreSQL, compared directly in queue SQL.
"""

from __future__ import annotations

import enum
from typing import Any

from sqlalchemy import (
    JSON,
    BigInteger,
    Boolean,
    CheckConstraint,
    Float,
    ForeignKey,
    Index,
    Integer,
    MetaData,
    String,
    Text,
    UniqueConstraint,
    text,
)
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column

NAMING = {
    "ix": "ix_%(column_0_label)s",
    "uq": "uq_%(table_name)s_%(column_0_name)s",
    "ck": "ck_%(table_name)s_%(constraint_name)s",
    "fk": "fk_%(table_name)s_%(column_0_name)s_%(referred_table_name)s",
    "pk": "pk_%(table_name)s",
}


class Base(DeclarativeBase):
    metadata = MetaData(naming_convention=NAMING)
    type_annotation_map = {dict[str, Any]: JSON, list[Any]: JSON}


class JobStatus(enum.StrEnum):
    queued = "queued"
    running = "running"
    succeeded = "succeeded"
    failed = "failed"
    cancelled = "cancelled"


FINISHED = (JobStatus.succeeded, JobStatus.failed, JobStatus.cancelled)


def _in(column: str, enum_type: type[enum.Enum]) -> str:
    return f"{column} IN ({', '.join(repr(m.value) for m in enum_type)})"


class Job(Base):
    __tablename__ = "jobs"
    __table_args__ = (
        CheckConstraint(_in("status", JobStatus), name="status"),
        CheckConstraint("status != 'running' OR lease_owner IS NOT NULL", name="running_has_owner"),
        Index("ix_jobs_kind_status", "kind", "status"),
    )

    id: Mapped[str] = mapped_column(String(32), primary_key=True)
    kind: Mapped[str] = mapped_column(String(32))
    spec: Mapped[dict[str, Any]]
    status: Mapped[str] = mapped_column(String(16), default=JobStatus.queued.value)
    priority: Mapped[int] = mapped_column(Integer, default=0)
    attempts: Mapped[int] = mapped_column(Integer, default=0)  #: claims so far (reset by a retry)
    max_attempts: Mapped[int] = mapped_column(Integer, default=3)
    timeout_s: Mapped[float | None] = mapped_column(Float)  #: [s] run time limit of one attempt
    idempotency_key: Mapped[str | None] = mapped_column(String(200), unique=True)
    parent_id: Mapped[str | None] = mapped_column(ForeignKey("jobs.id", ondelete="SET NULL"), index=True)
    lease_owner: Mapped[str | None] = mapped_column(String(64))
    lease_expires_at: Mapped[float | None] = mapped_column(Float)
    cancel_requested: Mapped[bool] = mapped_column(Boolean, default=False)
    progress: Mapped[float] = mapped_column(Float, default=0.0)
    message: Mapped[str] = mapped_column(Text, default="")
    error_type: Mapped[str | None] = mapped_column(String(200))
    error_message: Mapped[str | None] = mapped_column(Text)
    result: Mapped[dict[str, Any] | None]
    created_at: Mapped[float] = mapped_column(Float)
    started_at: Mapped[float | None] = mapped_column(Float)
    finished_at: Mapped[float | None] = mapped_column(Float)
    # what a researcher calls the run (set at submission, editable later: ``store.labels``)
    name: Mapped[str | None] = mapped_column(String(200), index=True)
    tags: Mapped[list[Any]] = mapped_column(
        JSON, default=list, server_default=text("'[]'")
    )  #: copy of job_tags, in order
    note: Mapped[str] = mapped_column(Text, default="", server_default="")


class JobTag(Base):
    """One tag of a job: the index the job list's ``?tag=`` filter reads (``jobs.tags`` keeps their order)."""

    __tablename__ = "job_tags"
    __table_args__ = (Index("ix_job_tags_tag", "tag", "job_id"),)

    job_id: Mapped[str] = mapped_column(ForeignKey("jobs.id", ondelete="CASCADE"), primary_key=True)
    tag: Mapped[str] = mapped_column(String(100), primary_key=True)


#: the claim's order (priority first, then oldest): one index walk, no sort, however long the queue
Index("ix_jobs_claim", Job.status, Job.priority.desc(), Job.created_at, Job.id)
#: the job list's order (newest first), alone and after each filter: a page is read off an index, not sorted
Index("ix_jobs_created", Job.created_at.desc(), Job.id)
Index("ix_jobs_status_created", Job.status, Job.created_at.desc(), Job.id)
Index("ix_jobs_kind_created", Job.kind, Job.created_at.desc(), Job.id)


class JobEvent(Base):
    """Progress, log and status lines of a job, in order (streamed as server-sent events)."""

    __tablename__ = "job_events"

    id: Mapped[int] = mapped_column(
        BigInteger().with_variant(Integer, "sqlite"), primary_key=True, autoincrement=True
    )
    job_id: Mapped[str] = mapped_column(ForeignKey("jobs.id", ondelete="CASCADE"), index=True)
    at: Mapped[float] = mapped_column(Float)
    type: Mapped[str] = mapped_column(String(16))  #: progress | log | status
    message: Mapped[str] = mapped_column(Text, default="")
    progress: Mapped[float | None] = mapped_column(Float)


class Worker(Base):
    __tablename__ = "workers"

    id: Mapped[str] = mapped_column(String(64), primary_key=True)
    host: Mapped[str] = mapped_column(String(255))
    pid: Mapped[int] = mapped_column(Integer)
    concurrency: Mapped[int] = mapped_column(Integer, default=1)
    kinds: Mapped[list[Any]]
    started_at: Mapped[float] = mapped_column(Float)
    heartbeat_at: Mapped[float] = mapped_column(Float, index=True)
    stopped_at: Mapped[float | None] = mapped_column(Float)


class Artifact(Base):
    """A file under the store root; ``path`` is relative to that root."""

    __tablename__ = "artifacts"
    __table_args__ = (UniqueConstraint("job_id", "name", name="uq_artifacts_job_name"),)

    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    job_id: Mapped[str | None] = mapped_column(ForeignKey("jobs.id", ondelete="SET NULL"), index=True)
    name: Mapped[str] = mapped_column(String(500))
    path: Mapped[str] = mapped_column(String(1000))
    size: Mapped[int] = mapped_column(BigInteger)
    sha256: Mapped[str] = mapped_column(String(64))
    created_at: Mapped[float] = mapped_column(Float)


class Bundle(Base):
    """A config bundle: a scenario matrix with its maps, seed manifests and planner grids."""

    __tablename__ = "bundles"
    __table_args__ = (CheckConstraint("source IN ('project', 'config_dir', 'upload')", name="source"),)

    id: Mapped[str] = mapped_column(String(200), primary_key=True)
    source: Mapped[str] = mapped_column(String(16))
    root: Mapped[str] = mapped_column(
        String(1000)
    )  #: absolute for project/config dirs; store-relative for uploads
    files: Mapped[list[Any]]  #: relative YAML/map file names
    scenarios: Mapped[list[Any]]  #: relative names of the scenario matrices in the bundle
    sha256: Mapped[str | None] = mapped_column(String(64))
    created_at: Mapped[float] = mapped_column(Float)


class Dataset(Base):
    __tablename__ = "datasets"

    id: Mapped[str] = mapped_column(String(200), primary_key=True)
    job_id: Mapped[str | None] = mapped_column(ForeignKey("jobs.id", ondelete="SET NULL"), index=True)
    path: Mapped[str] = mapped_column(String(1000))  #: store-relative
    sha256: Mapped[str | None] = mapped_column(String(64))
    summary: Mapped[dict[str, Any]]
    created_at: Mapped[float] = mapped_column(Float)


class ModelStatus(enum.StrEnum):
    candidate = "candidate"
    promoted = "promoted"
    default = "default"


class Model(Base):
    """A registry entry; ``read_only`` entries come from ``model/registry.yaml``."""

    __tablename__ = "models"
    __table_args__ = (CheckConstraint(_in("status", ModelStatus), name="status"),)

    id: Mapped[str] = mapped_column(String(200), primary_key=True)
    status: Mapped[str] = mapped_column(String(16), default=ModelStatus.candidate.value)
    checkpoint: Mapped[str] = mapped_column(String(1000))  #: store-relative (or repo-relative when read-only)
    sha256: Mapped[str] = mapped_column(String(64))
    time_base: Mapped[dict[str, Any]]
    lineage: Mapped[dict[str, Any]]  #: dataset ids and their hashes
    training: Mapped[dict[str, Any]]
    metrics: Mapped[dict[str, Any]]
    tags: Mapped[list[Any]]
    provenance: Mapped[str] = mapped_column(Text, default="")
    read_only: Mapped[bool] = mapped_column(Boolean, default=False)
    job_id: Mapped[str | None] = mapped_column(ForeignKey("jobs.id", ondelete="SET NULL"), index=True)
    created_at: Mapped[float] = mapped_column(Float)

    @property
    def kind(self) -> str:
        """checkpoint | plugin | external (``store.model_kinds``; kept in lineage, entries before kinds are
        checkpoints)."""
        return str((self.lineage or {}).get("kind", "checkpoint"))


class Evaluation(Base):
    __tablename__ = "evaluations"

    id: Mapped[str] = mapped_column(String(200), primary_key=True)
    job_id: Mapped[str | None] = mapped_column(ForeignKey("jobs.id", ondelete="SET NULL"), index=True)
    model_id: Mapped[str | None] = mapped_column(ForeignKey("models.id", ondelete="RESTRICT"), index=True)
    bundle_id: Mapped[str | None] = mapped_column(String(200))
    config: Mapped[dict[str, Any]]  #: resolved config
    metrics: Mapped[dict[str, Any]]
    per_scenario: Mapped[list[Any]]
    created_at: Mapped[float] = mapped_column(Float)


class Episode(Base):
    __tablename__ = "episodes"

    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    evaluation_id: Mapped[str] = mapped_column(ForeignKey("evaluations.id", ondelete="CASCADE"), index=True)
    scenario: Mapped[str] = mapped_column(String(200))
    seed: Mapped[int] = mapped_column(BigInteger)
    outcome: Mapped[str] = mapped_column(String(32))
    metrics: Mapped[dict[str, Any]]


class FailureTaxonomy(Base):
    __tablename__ = "failure_taxonomies"

    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    evaluation_id: Mapped[str] = mapped_column(ForeignKey("evaluations.id", ondelete="CASCADE"), index=True)
    category: Mapped[str] = mapped_column(String(100))
    count: Mapped[int] = mapped_column(Integer)
    examples: Mapped[list[Any]]


class Campaign(Base):
    __tablename__ = "campaigns"

    id: Mapped[str] = mapped_column(String(200), primary_key=True)
    job_id: Mapped[str | None] = mapped_column(ForeignKey("jobs.id", ondelete="SET NULL"), index=True)
    config: Mapped[dict[str, Any]]
    best: Mapped[dict[str, Any] | None]
    created_at: Mapped[float] = mapped_column(Float)


class CampaignCell(Base):
    __tablename__ = "campaign_cells"
    __table_args__ = (UniqueConstraint("campaign_id", "rank", name="uq_campaign_cells_rank"),)

    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    campaign_id: Mapped[str] = mapped_column(ForeignKey("campaigns.id", ondelete="CASCADE"), index=True)
    rank: Mapped[int] = mapped_column(Integer)
    params: Mapped[dict[str, Any]]
    metrics: Mapped[dict[str, Any]]


class GateResult(Base):
    __tablename__ = "gate_results"

    id: Mapped[int] = mapped_column(Integer, primary_key=True, autoincrement=True)
    job_id: Mapped[str | None] = mapped_column(ForeignKey("jobs.id", ondelete="SET NULL"), index=True)
    campaign_id: Mapped[str | None] = mapped_column(
        ForeignKey("campaigns.id", ondelete="CASCADE"), index=True
    )
    gate: Mapped[str] = mapped_column(String(100))
    passed: Mapped[bool] = mapped_column(Boolean)
    details: Mapped[dict[str, Any]]
    created_at: Mapped[float] = mapped_column(Float)
