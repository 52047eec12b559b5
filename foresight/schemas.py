"""The HTTP API's response bodies (``XPublic`` one resource, ``XsPublic`` a page of them), one model each: the server
(``foresight.api``) answers with them and the CLI (``foresight.cli.client``) reads every answer back through them, so
a field the two disagree on is one readable error naming it, never a ``KeyError`` or a silent ``None``.

Jobs, workers, the registries, datasets, planners and health here; the bodies that embed evaluation and campaign
results (evaluations, campaigns, episodes, comparisons) in ``foresight.result_schemas``, so that a command reading a
job does not load the evaluation stack. Only pydantic and light core types: no web framework, no database (the CLI's
install has neither). The request bodies, which check ids and specs against the server's settings, stay in
``foresight.api.schemas``.
"""

from __future__ import annotations

from datetime import datetime
from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from foresight.core.runtime.verdict import Verdict


# Jobs
class ArtifactPublic(BaseModel):
    name: str
    size: int
    sha256: str
    url: str


class JobError(BaseModel):
    type: str
    message: str


class JobPublic(BaseModel):
    id: str
    kind: str
    status: str
    spec: dict[str, Any]
    priority: int
    attempts: int
    max_attempts: int
    timeout_s: float | None
    idempotency_key: str | None
    parent_id: str | None
    name: str | None = None
    tags: list[str] = Field(default_factory=list)
    note: str = ""
    cancel_requested: bool
    progress: float
    message: str
    error: JobError | None
    result: dict[str, Any] | None
    verdict: Verdict | None = Field(
        None,
        description="a succeeded job's gate/integrity verdict (None: no gate); "
        "failed_gate / failed_integrity are results, not crashes (CLI exit code 2)",
    )
    worker: str | None
    created_at: datetime
    started_at: datetime | None
    finished_at: datetime | None
    artifacts: list[ArtifactPublic] | None = None
    children: list[str] | None = None


class JobsPublic(BaseModel):
    data: list[JobPublic]
    count: int
    limit: int
    offset: int


# Workers and queue
class WorkerPublic(BaseModel):
    id: str
    host: str
    pid: int
    concurrency: int
    kinds: list[str]
    started_at: datetime
    heartbeat_at: datetime
    jobs: list[str]


class WorkersPublic(BaseModel):
    data: list[WorkerPublic]
    count: int
    queue: dict[str, dict[str, int]] = Field(description="job counts per kind and status")


class KindPublic(BaseModel):
    kind: str
    description: str
    spec_schema: dict[str, Any]


# Models
class ModelPublic(BaseModel):
    model_config = ConfigDict(from_attributes=True)

    id: str
    status: str
    checkpoint: str
    sha256: str
    time_base: dict[str, Any]
    lineage: dict[str, Any]
    training: dict[str, Any]
    metrics: dict[str, Any]
    tags: list[str]
    provenance: str
    read_only: bool
    job_id: str | None
    kind: str = Field("checkpoint", description="checkpoint | plugin | external")


class ModelsPublic(BaseModel):
    data: list[ModelPublic]
    count: int
    limit: int | None = None
    offset: int = 0


# Bundles
class BundlePublic(BaseModel):
    model_config = ConfigDict(from_attributes=True)

    id: str
    source: str
    files: list[str]
    scenarios: list[str] = Field(description="scenario matrix files in the bundle")
    sha256: str | None


class BundlesPublic(BaseModel):
    data: list[BundlePublic]
    count: int


class ScenarioPublic(BaseModel):
    matrix: str
    name: str
    map: str
    archetype: str | None
    seeds: list[int]


# Datasets
class DatasetPublic(BaseModel):
    model_config = ConfigDict(from_attributes=True)

    id: str
    job_id: str | None
    sha256: str | None
    summary: dict[str, Any]


# Planners
class PlannerPublic(BaseModel):
    name: str
    origin: str = Field(description='"builtin", "external" or "plugin DIST VERSION"')
    description: str
    takes_model: bool = Field(description="the spec's planner.model names a predictor (predictive planner)")
    config_schema: dict[str, Any] = Field(description="JSON schema of planner.config")


class PlannersPublic(BaseModel):
    data: list[PlannerPublic]
    count: int
    external_commands: list[str] = Field(description="names an external planner's config.command may take")


class PredictorPublic(BaseModel):
    name: str = Field(description="the model name a spec's planner.model or predict_eval model may take")
    origin: str = Field(description='"plugin DIST VERSION"')
    timebase: dict[str, Any] | None = Field(default=None, description="declared dt [s], history and horizon")
    frame: str | None = Field(default=None, description='"world" or "pedestrian"')
    modes: int | None = Field(default=None, description="modes per pedestrian (K)")
    error: str | None = Field(default=None, description="why it does not load, when it does not")


class PredictorsPublic(BaseModel):
    data: list[PredictorPublic]
    count: int
    external: list[str] = Field(
        description="operator-configured external predictors: model name external:NAME"
    )


class DiskPublic(BaseModel):
    """Free space where the store and the database live (``store.space``)."""

    full: bool  #: a disk under 1 MiB free, or a request that met a full disk in the last 10 s
    store_free_bytes: int | None
    database_free_bytes: int | None  #: None: the database is on another machine


class Health(BaseModel):
    status: str  #: "ok", or "degraded: ..." saying why
    database: str
    revision: str
    kinds: list[str]
    disk: DiskPublic | None = None


# Job events
class JobEventPublic(BaseModel):
    """One server-sent event of ``GET /v1/jobs/{id}/events``: a progress, log or status line."""

    type: str
    at: float = Field(description="[s] Unix time")
    message: str
    progress: float | None = None


class JobEndPublic(BaseModel):
    """The last event of the stream (``end``): the job's final status."""

    status: str
