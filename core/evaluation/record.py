"""The per-episode evaluation record: outcome, metrics, planner timing, taxonomy and provenance.

One record per (scenario, seed, planner config); episodes.jsonl holds one per line. Provenance is
part of the record (not only of the run) so that a single line can be audited on its own.
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from foresight.core.evaluation.metrics import (
    Efficiency,
    EpisodeGeometry,
    MetricsConfig,
    Safety,
    Smoothness,
    TraceLike,
    derive,
    efficiency,
    safety,
    smoothness,
    social_steps,
    timing_summary,
)
from foresight.core.evaluation.taxonomy import TaxonomyConfig, TaxonomyResult, classify

Outcome = Literal["collision_pedestrian", "collision_static", "success", "timeout", "error"]
OUTCOMES: tuple[str, ...] = Outcome.__args__  # type: ignore[attr-defined]


class Provenance(BaseModel):
    """Where an episode came from: enough to re-run it and to refuse comparing unlike runs."""

    model_config = ConfigDict(frozen=True)

    scenario: str
    archetype: str
    density: str | None = None
    seed: int
    planner: str  #: planner name actually run
    variant: str | None = None  #: planner-grid variant name (campaigns)
    planner_config_hash: str
    model_id: str  #: model id, or "cv" for constant velocity, or "none" for planners without a predictor
    checkpoint_sha256: str  #: checkpoint checksum, or "cv"/"none" like model_id
    code_version: str
    dt: float  #: [s]
    horizon: int  #: max_episode_steps
    map_sha256: str | None = None
    fallback: str | None = None  #: set when the planner silently fell back (e.g. to constant velocity)


class Timing(BaseModel):
    plan_ms_mean: float | None = None
    plan_ms_p95: float | None = None
    plan_ms_max: float | None = None
    wall_s: float | None = None  #: episode wall time [s]
    node: str | None = (
        None  #: the Ray node that ran the episode (``executor: ray``; None in-process or in a local pool)
    )


class PredictionQuality(BaseModel):
    """Predictor error on the episode's own pedestrians, when the planner reports its predictions."""

    ade: float | None = None  #: mean displacement error over all predicted points [m]
    fde: float | None = None  #: mean error of the last predicted point [m]
    samples: int = 0


class EpisodeRecord(BaseModel):
    model_config = ConfigDict(frozen=True)

    scenario: str
    seed: int
    planner: str
    variant: str | None = None
    outcome: Outcome
    error: str | None = None  #: the planner's error message when outcome == "error"
    collision_kind: str | None = None
    collision_point: tuple[float, float] | None = None
    steps: int
    time_to_goal_s: float | None  #: successes only [s]
    time_to_goal_norm: float  #: steps / horizon for successes, else 1.0
    safety: Safety
    efficiency: Efficiency
    smoothness: Smoothness
    timing: Timing
    prediction: PredictionQuality = Field(default_factory=PredictionQuality)
    taxonomy: TaxonomyResult
    provenance: Provenance

    @property
    def success(self) -> bool:
        return self.outcome == "success"

    @property
    def collision(self) -> bool:
        return self.outcome in ("collision_pedestrian", "collision_static")

    def comparable(self) -> dict[str, Any]:
        """The record without run-to-run noise (timing, code version), for determinism checks."""
        data = self.model_dump(mode="json", exclude={"timing": True, "provenance": {"code_version"}})
        return data


def build_record(
    trace: TraceLike,
    geom: EpisodeGeometry,
    *,
    outcome: str,
    provenance: Provenance,
    collision_kind: str | None = None,
    collision_step: int | None = None,
    collision_point: Any = None,
    error: str | None = None,
    plan_ms: list[float] | np.ndarray = (),
    wall_s: float | None = None,
    prediction: PredictionQuality | None = None,
    prediction_error: dict[int, float] | None = None,
    metrics_cfg: MetricsConfig | None = None,
    taxonomy_cfg: TaxonomyConfig | None = None,
) -> EpisodeRecord:
    """Compute every metric and the taxonomy of one finished episode."""
    mcfg = metrics_cfg or MetricsConfig()
    d = derive(trace, geom)
    success = outcome == "success"
    tax = classify(
        d,
        outcome,
        robot_radius=geom.robot_radius,
        ped_radius=geom.ped_radius,
        collision_kind=collision_kind,
        collision_step=collision_step,
        prediction_error=prediction_error,
        cfg=taxonomy_cfg,
        limits=geom.limits,
        static=geom.static,
    )
    point = None if collision_point is None else tuple(float(x) for x in np.asarray(collision_point)[:2])
    return EpisodeRecord(
        scenario=provenance.scenario,
        seed=provenance.seed,
        planner=provenance.planner,
        variant=provenance.variant,
        outcome=outcome,
        error=error,
        collision_kind=collision_kind,
        collision_point=point,
        steps=d.steps,
        time_to_goal_s=d.steps * d.dt if success else None,
        time_to_goal_norm=min(1.0, d.steps / geom.horizon) if success else 1.0,
        safety=safety(d, mcfg, collision_step).model_copy(update=social_steps(d, geom)),
        efficiency=efficiency(d, geom, mcfg, success),
        smoothness=smoothness(d, (taxonomy_cfg or TaxonomyConfig()).oscillation_omega_min),
        timing=Timing(**timing_summary(plan_ms), wall_s=wall_s),
        prediction=prediction or PredictionQuality(),
        taxonomy=tax,
        provenance=provenance,
    )
