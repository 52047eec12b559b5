"""An evaluation's result models: the stage result, its headline metrics and run config, the planner provenance.

Kept apart from the runner so that readers of results (store, API, reports) do not load the episode machinery.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Literal

from pydantic import BaseModel

from foresight.core.evaluation.aggregate import Aggregates, GroupStats
from foresight.core.evaluation.gates import GateResult
from foresight.core.evaluation.integrity import IntegrityReport
from foresight.core.evaluation.metrics import MetricsConfig
from foresight.core.evaluation.taxonomy import TaxonomyConfig
from foresight.core.runtime.execution import Execution

if TYPE_CHECKING:
    from foresight.core.evaluation.plannerspec import ResolvedPlanner


class PlannerProvenance(BaseModel):
    name: str
    variant: str | None
    config: dict[str, Any]  #: fully resolved planner config (every key)
    config_hash: str
    model_id: str
    checkpoint_sha256: str
    origin: str = (
        "builtin"  #: "builtin", "external", "plugin DIST VERSION" (the plugin's version) or "module"
    )


def planner_provenance(rp: ResolvedPlanner) -> PlannerProvenance:
    return PlannerProvenance(
        name=rp.name,
        variant=rp.variant,
        config=rp.config,
        config_hash=rp.config_hash,
        model_id=rp.model_id,
        checkpoint_sha256=rp.checkpoint_sha256,
        origin=rp.origin,
    )


class EvaluationResult(BaseModel):
    status: Literal["passed", "failed_gate", "failed_integrity"]
    exit_code: int  #: 0 passed, 2 gate or integrity failure
    success_rate: float | None
    collision_rate: float | None
    episodes: int
    planner: PlannerProvenance
    code_version: str
    bundle: str
    matrix: str
    seed_source: str  #: "matrix", "N per scenario" or the seed manifest
    horizon: str  #: "scenario" or the override
    workers: int
    execution: Execution | None = (
        None  #: which executor ran the episodes, on how many CPUs (None: older results)
    )
    aggregates: Aggregates
    taxonomy: dict[str, int]
    taxonomy_config: TaxonomyConfig
    metrics_config: MetricsConfig
    integrity: IntegrityReport
    gate: GateResult
    artifacts: dict[str, str]
    wall_s: float
    config: dict[str, Any]  #: the stage config as given (with defaults), for re-running


class EvaluationMetrics(BaseModel):
    """An evaluation's headline numbers: the ``metrics`` its result row and API record keep."""

    success_rate: float | None
    collision_rate: float | None
    episodes: int
    status: str
    overall: GroupStats


class EvaluationRunConfig(BaseModel):
    """What an evaluation ran: the stage config as given and the planner's fully resolved config."""

    stage: dict[str, Any]
    planner: dict[str, Any]


def evaluation_metrics(result: EvaluationResult) -> EvaluationMetrics:
    return EvaluationMetrics(
        success_rate=result.success_rate,
        collision_rate=result.collision_rate,
        episodes=result.episodes,
        status=result.status,
        overall=result.aggregates.overall,
    )


def evaluation_run_config(result: EvaluationResult) -> EvaluationRunConfig:
    return EvaluationRunConfig(stage=result.config, planner=result.planner.config)
