"""Request bodies, one family per resource (``XCreate``, ``XUpdate``), and ``job_public`` (a job row as its response body).

The response bodies (``XPublic`` out, ``XsPublic`` lists) live in ``foresight.schemas``, which the CLI reads the
answers with; the request bodies check specs and ids against this server's settings."""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Annotated, Any, Literal, Union

from pydantic import AfterValidator, BaseModel, ConfigDict, Field

from foresight.core.jobs.kinds import KINDS
from foresight.core.jobs.results import verdict
from foresight.schemas import ArtifactPublic, JobError, JobPublic
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
        id=row["id"],
        kind=row["kind"],
        status=row["status"],
        spec=row["spec"],
        priority=row["priority"],
        attempts=row["attempts"],
        max_attempts=row["max_attempts"],
        timeout_s=row["timeout_s"],
        idempotency_key=row["idempotency_key"],
        parent_id=row["parent_id"],
        cancel_requested=row["cancel_requested"],
        name=row.get("name"),
        tags=row.get("tags") or [],
        note=row.get("note") or "",
        progress=row["progress"],
        message=row["message"],
        error=error,
        result=row["result"],
        verdict=verdict(row["kind"], row["result"]) if row["status"] == "succeeded" else None,
        worker=row["lease_owner"],
        created_at=iso(row["created_at"]),
        started_at=iso(row["started_at"]),
        finished_at=iso(row["finished_at"]),
        artifacts=arts,
        children=children,
    )


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
