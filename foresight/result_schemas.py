"""The HTTP API's response bodies that embed evaluation and campaign results: evaluations, campaigns, their
episodes and the comparison of two (the others, and what they share, in ``foresight.schemas``). The server answers
with them and the CLI reads the answers back through them."""

from __future__ import annotations

from datetime import datetime
from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from foresight.core.evaluation.aggregate import GroupStats
from foresight.core.evaluation.campaign_result import CellMetrics, CellParams, CellResult
from foresight.core.evaluation.delta import Delta, EpisodeChange
from foresight.core.evaluation.evaluation_result import EvaluationMetrics, EvaluationRunConfig


# Evaluations
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


# Campaigns
class CampaignCellPublic(BaseModel):
    rank: int
    params: CellParams
    metrics: CellMetrics


class SuiteHeadline(BaseModel):
    """A suite's headline in a list: its success and collision rates (None: no episodes) and its episodes."""

    success: float | None
    collision: float | None
    episodes: int


class CampaignSummaryPublic(BaseModel):
    """A campaign in a list: what it ran and its best cell's headline (the cells are in ``GET /v1/campaigns/{id}``)."""

    id: str
    job_id: str | None
    config: dict[str, Any] = Field(description="matrix, seed_manifest, grid, horizon")
    best: CellParams | None = Field(description="checkpoint and variant of the best cell")
    best_metrics: dict[str, SuiteHeadline] | None = Field(description="the best cell's suites (global, hard)")
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


# Comparisons
class ChangedEpisodePublic(EpisodeChange):
    """An episode whose outcome differs between two paired results, with its side-by-side player."""

    player: str | None = Field(
        None, description="dashboard URL of both runs side by side (None: a trace is missing)"
    )


class Sides(BaseModel):
    """One thing on each side of a comparison: A's and B's (None where a side has none)."""

    a: Any = None
    b: Any = None


class ComparisonPublic(BaseModel):
    """``GET /v1/compare``: two evaluations or campaign cells side by side (``a`` and ``b`` as resolved ids)."""

    a: str
    b: str
    sources: Sides | None = Field(None, description="what each side is: evaluation or campaign")
    setup: Sides | None = Field(None, description="each side's run setup (planner, model, matrix, ...)")
    differs: dict[str, Sides] | None = Field(
        None, description="planner, model, matrix, episodes, horizon where they differ"
    )
    config_diff: dict[str, Sides] = Field(
        description="resolved-config key -> both values, differing keys only"
    )
    paired: bool = False
    metrics: dict[str, Delta] = Field(description="headline metric -> B - A with its interval")
    changed_episodes: list[ChangedEpisodePublic] | None = Field(
        None, description="paired results only: the episodes whose outcome differs"
    )
