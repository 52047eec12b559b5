"""Request and response bodies, one family per resource (``XCreate`` in, ``XPublic`` out, ``XsPublic`` lists)."""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Annotated, Any, Literal, Union

from pydantic import AfterValidator, BaseModel, ConfigDict, Field

from foresight.core.evaluation.aggregate import GroupStats
from foresight.core.evaluation.campaign_result import CellMetrics, CellParams, CellResult
from foresight.core.evaluation.evaluation_result import EvaluationMetrics, EvaluationRunConfig
from foresight.core.jobs.kinds import KINDS
from foresight.core.jobs.results import Verdict, verdict
from foresight.store.settings import Settings

Ident = Annotated[str, Field(min_length=1, max_length=200, pattern=r"^[A-Za-z0-9][A-Za-z0-9._:\-]*$")]
Rank = Annotated[int, Field(ge=1, le=100_000, description="a campaign cell's rank: 1 = the best cell")]


def iso(ts: float | None) -> datetime | None:
    return datetime.fromtimestamp(ts, UTC) if ts is not None else None


def _job_spec_type() -> Any:
    specs = tuple(kind.spec for kind in KINDS.values())
    if len(specs) == 1:
        return specs[0]
    return Annotated[Union[specs], Field(discriminator="kind")]  # noqa: UP007 (a runtime tuple of models)


def _known_data_root(spec: Any) -> Any:
    """An ``import_dataset`` spec names a data root of this server (checked against the settings in the
    environment, every process's settings source): a 422 naming the field, the name and the known roots."""
    if getattr(spec, "kind", None) == "import_dataset":
        try:
            Settings().data_root(spec.root)
        except LookupError as exc:
            raise ValueError(f"spec.import_dataset.root: {exc}") from None
    return spec


JobSpec = Annotated[_job_spec_type(), AfterValidator(_known_data_root)]


# Jobs
Tag = Annotated[
    str,
    Field(
        min_length=1,
        max_length=100,
        pattern=r"^[A-Za-z0-9][A-Za-z0-9._:/=+\-]*$",
        description="a label such as 'baseline' or 'ablation:no-pred'",
    ),
]
JobName = Annotated[
    str,
    Field(
        min_length=1,
        max_length=200,
        pattern=r"^[^\x00-\x1f\x7f]+$",
        description="what the run is called (need not be unique)",
    ),
]
JobNote = Annotated[
    str,
    Field(
        max_length=10_000,
        pattern=r"^[^\x00-\x08\x0b\x0c\x0e-\x1f\x7f]*$",
        description="free text: why the run was made, what was seen",
    ),
]
MAX_TAGS = 20  #: tags per job


def _unique(tags: list[str]) -> list[str]:
    return list(dict.fromkeys(tags))


Tags = Annotated[list[Tag], Field(max_length=MAX_TAGS), AfterValidator(_unique)]


class JobCreate(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    spec: JobSpec  # type: ignore[valid-type]
    priority: int = Field(0, ge=-1000, le=1000, description="higher runs first")
    timeout_s: float | None = Field(None, gt=0, le=7 * 86400, description="[s] limit of one attempt")
    max_attempts: int | None = Field(None, ge=1, le=20, description="claims before a lost job fails")
    idempotency_key: str | None = Field(None, min_length=1, max_length=200, pattern=r"^[\x21-\x7e]+$")
    parent_id: Ident | None = None
    name: JobName | None = None
    tags: Tags = Field(default_factory=list)
    note: JobNote = ""

    def labels(self) -> dict[str, Any]:
        return {"name": self.name, "tags": self.tags, "note": self.note}


class JobUpdate(BaseModel):
    """Change a job's labels (any status): fields left out stay as they are; ``name: null`` removes the name.
    ``tags`` replaces the tag list, ``add_tags`` / ``remove_tags`` edit it."""

    model_config = ConfigDict(extra="forbid")

    name: JobName | None = None
    note: JobNote | None = None
    tags: Tags | None = None
    add_tags: Tags = Field(default_factory=list)
    remove_tags: Tags = Field(default_factory=list)


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


def job_public(
    row: dict[str, Any], artifacts: list[dict] | None = None, children: list[str] | None = None
) -> JobPublic:
    error = (
        JobError(type=row["error_type"], message=row["error_message"] or "") if row["error_type"] else None
    )
    arts = None
    if artifacts is not None:
        arts = [
            ArtifactPublic(
                name=a["name"],
                size=a["size"],
                sha256=a["sha256"],
                url=f"/v1/jobs/{row['id']}/artifacts/{a['name']}",
            )
            for a in artifacts
        ]
    return JobPublic(
        id=row["id"], kind=row["kind"], status=row["status"], spec=row["spec"], priority=row["priority"],
        attempts=row["attempts"], max_attempts=row["max_attempts"], timeout_s=row["timeout_s"],
        idempotency_key=row["idempotency_key"], parent_id=row["parent_id"], cancel_requested=row["cancel_requested"],
        name=row.get("name"), tags=row.get("tags") or [], note=row.get("note") or "",
        progress=row["progress"], message=row["message"], error=error, result=row["result"],
        verdict=verdict(row["kind"], row["result"]) if row["status"] == "succeeded" else None,
        worker=row["lease_owner"], created_at=iso(row["created_at"]), started_at=iso(row["started_at"]),
        finished_at=iso(row["finished_at"]), artifacts=arts, children=children,
    )  # fmt: skip


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
class ModelCreate(BaseModel):
    """Register a checkpoint that a finished job wrote as a model; it starts as a candidate (promotion follows
    evaluation and gates: ``POST /v1/models/{id}/promote``)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)

    id: Ident
    job_id: Ident
    artifact: str = Field(min_length=1, max_length=500, description="artifact name in that job")
    status: Literal["candidate"] = "candidate"
    time_base: dict[str, Any] = Field(
        default_factory=dict, max_length=3, description="dt, history, horizon: when given, the checkpoint's"
    )
    lineage: dict[str, Any] = Field(default_factory=dict)
    training: dict[str, Any] = Field(default_factory=dict)
    metrics: dict[str, Any] = Field(default_factory=dict)
    tags: list[Annotated[str, Field(max_length=100)]] = Field(default_factory=list, max_length=50)
    provenance: str = Field("", max_length=5000)


class ModelPromote(BaseModel):
    model_config = ConfigDict(extra="forbid")

    to: Literal["promoted", "default"] = "promoted"


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


# Results
class DatasetPublic(BaseModel):
    model_config = ConfigDict(from_attributes=True)

    id: str
    job_id: str | None
    sha256: str | None
    summary: dict[str, Any]


class EvaluationSummaryPublic(BaseModel):
    """An evaluation in a list: its config and headline metrics (the per-scenario table and taxonomy are in
    ``GET /v1/evaluations/{id}``)."""

    model_config = ConfigDict(from_attributes=True)

    id: str
    job_id: str | None
    model_id: str | None
    bundle_id: str | None
    config: EvaluationRunConfig
    metrics: EvaluationMetrics
    name: str | None = Field(None, description="its job's name")
    tags: list[str] = Field(default_factory=list, description="its job's tags")


class EvaluationPublic(EvaluationSummaryPublic):
    per_scenario: list[GroupStats]
    taxonomy: list[dict[str, Any]] = Field(default_factory=list)


class EvaluationsPublic(BaseModel):
    data: list[EvaluationSummaryPublic]
    count: int
    limit: int
    offset: int


class EpisodePublic(BaseModel):
    """One evaluated episode in a list, with the links to watch it."""

    scenario: str
    seed: int
    outcome: str
    label: str | None = Field(description="failure taxonomy label (None for successes)")
    steps: int
    trace: str | None = Field(description="API URL of its compact trace (None: the evaluation stored none)")
    player: str | None = Field(description="dashboard URL of the episode player")


class CampaignCellPublic(BaseModel):
    rank: int
    params: CellParams
    metrics: CellMetrics


class CampaignSummaryPublic(BaseModel):
    """A campaign in a list: what it ran and its best cell's headline (the cells are in ``GET /v1/campaigns/{id}``)."""

    id: str
    job_id: str | None
    config: dict[str, Any] = Field(description="matrix, seed_manifest, grid, horizon")
    best: CellParams | None = Field(description="checkpoint and variant of the best cell")
    best_metrics: dict[str, Any] | None = Field(
        description="the best cell's suites: success, collision rates"
    )
    name: str | None = None
    tags: list[str] = Field(default_factory=list)
    created_at: datetime


class CampaignsPublic(BaseModel):
    data: list[CampaignSummaryPublic]
    count: int
    limit: int
    offset: int


class CampaignPublic(BaseModel):
    id: str
    job_id: str | None
    config: dict[str, Any]
    best: CellResult | None
    cells: list[CampaignCellPublic]
    gates: list[dict[str, Any]]


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
