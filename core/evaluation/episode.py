"""One evaluated episode: run it with a recording planner wrapper, then turn the trace into a record.

The wrapper times every decision, keeps the planner's diagnostics (for diagnostics runs and for the
predictor's in-loop ADE/FDE), notices a silent fallback to constant velocity, and turns a planner
exception or an invalid command into the ``error`` outcome instead of a crashed evaluation.
"""

from __future__ import annotations

import contextlib
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from foresight.core.evaluation.metrics import EpisodeGeometry, MetricsConfig
from foresight.core.evaluation.plannerspec import ResolvedPlanner, build_planner
from foresight.core.evaluation.record import EpisodeRecord, PredictionQuality, Provenance, build_record
from foresight.core.evaluation.taxonomy import TaxonomyConfig
from foresight.core.scenarios.model import ResolvedScenario
from foresight.core.sim.observation import Observation
from foresight.core.sim.planner import EpisodeInfo, Planner
from foresight.core.version import code_version

#: keep the predictions of every k-th decision for the in-loop ADE/FDE (cost stays small)
PREDICTION_STRIDE = 5


class PlannerFailure(Exception):
    """The planner raised or returned an invalid command; the episode ends with outcome ``error``."""


@dataclass
class StepLog:
    """Per-decision data the wrapper collected."""

    plan_ms: list[float] = field(default_factory=list)
    diagnostics: list[dict[str, Any] | None] = field(default_factory=list)  #: only when keep_diagnostics
    predictions: list[tuple[int, np.ndarray, np.ndarray, np.ndarray]] = field(
        default_factory=list
    )  #: (step, ids, pos, times)
    sources: set[str] = field(default_factory=set)  #: forecast sources seen
    #: per logged prediction: its (N, T) per-axis std [m] when the planner reported one (episode player), else None
    spreads: list[np.ndarray | None] = field(default_factory=list)


class RecordingPlanner:
    """Planner protocol wrapper: times ``plan``, keeps diagnostics, converts failures to PlannerFailure."""

    def __init__(self, inner: Planner, keep_diagnostics: bool = False):
        self.inner = inner
        self.name = getattr(inner, "name", type(inner).__name__)
        self.keep = keep_diagnostics
        self.log = StepLog()

    def reset(self, info: EpisodeInfo) -> None:
        self.log = StepLog()
        try:
            self.inner.reset(info)
        except Exception as exc:  # noqa: BLE001 - as in plan: the episode ends as "error"
            raise PlannerFailure(f"{type(exc).__name__} at reset: {exc}") from exc

    def finish(self, outcome: str) -> None:
        """The optional ``finish(outcome)`` of the planner interface; its failure changes no result."""
        finish = getattr(self.inner, "finish", None)
        if finish is not None:
            with contextlib.suppress(Exception):  # the episode is over and recorded either way
                finish(outcome)

    @property
    def diagnostics(self) -> dict[str, Any] | None:
        return getattr(self.inner, "diagnostics", None)  # optional in the planner interface

    def plan(self, obs: Observation) -> tuple[float, float]:
        t0 = time.perf_counter()
        try:
            v, w = self.inner.plan(obs)
        except Exception as exc:  # noqa: BLE001 - any planner failure must become an "error" record, not a crash
            raise PlannerFailure(f"{type(exc).__name__}: {exc}") from exc
        self.log.plan_ms.append((time.perf_counter() - t0) * 1e3)
        if not (math.isfinite(float(v)) and math.isfinite(float(w))):
            raise PlannerFailure(f"invalid command ({v}, {w}) at step {obs.step}")
        self._observe_diagnostics(obs.step)
        return float(v), float(w)

    def _observe_diagnostics(self, step: int) -> None:
        diag = self.diagnostics
        if self.keep:
            self.log.diagnostics.append(diag)
        if not diag:
            return
        if "forecast_source" in diag:
            self.log.sources.add(str(diag["forecast_source"]))
        pred = diag.get("predictions")
        if (
            pred is not None and step % PREDICTION_STRIDE == 0
        ):  # the same sample in evaluations and diagnostics
            self.log.predictions.append(
                (step, np.asarray(pred["ped_ids"]), np.asarray(pred["positions"]), np.asarray(pred["times"]))
            )
            self.log.spreads.append(np.asarray(pred["sigma"]) if pred.get("sigma") is not None else None)


def prediction_quality(
    trace: Any, predictions: list, dt: float
) -> tuple[PredictionQuality, dict[int, float]]:
    """ADE/FDE of the logged forecasts against the trace's true positions, and mean error per ped id."""
    T = trace.steps
    ids_all, pos_all = trace.ped_ids, trace.ped_pos
    errs: list[np.ndarray] = []
    finals: list[np.ndarray] = []
    per_ped: dict[int, list[float]] = {}
    for step, ids, pos, times in predictions:
        if ids.size == 0:
            continue
        rows = step + np.rint(np.asarray(times) / dt).astype(int)
        keep = rows <= T
        if not keep.any():
            continue
        rows = rows[keep]
        slot_match = ids_all[step][None, :] == ids[:, None]  # (N, slots)
        present = slot_match.any(axis=1)
        slots = np.argmax(slot_match, axis=1)
        actual = pos_all[rows[None, :], slots[:, None]]  # (N, H', 2)
        valid = present[:, None] & (ids_all[rows[None, :], slots[:, None]] == ids[:, None])
        e = np.linalg.norm(pos[:, : rows.size] - actual, axis=2)
        errs.append(e[valid])
        if keep.all():
            finals.append(e[valid[:, -1], -1])
        for pid, row_e, row_v in zip(ids.tolist(), e, valid, strict=True):
            if row_v.any():
                per_ped.setdefault(int(pid), []).append(float(row_e[row_v].mean()))
    flat = np.concatenate(errs) if errs else np.zeros(0)
    fin = np.concatenate(finals) if finals else np.zeros(0)
    quality = PredictionQuality(
        ade=float(flat.mean()) if flat.size else None,
        fde=float(fin.mean()) if fin.size else None,
        samples=int(flat.size),
    )
    return quality, {k: float(np.mean(v)) for k, v in per_ped.items()}


def geometry_of(scenario: ResolvedScenario, sim: Any) -> EpisodeGeometry:
    """Radii, horizon and route of the episode just run (the simulator sampled the route)."""
    return EpisodeGeometry(
        robot_radius=float(sim.limits.radius),
        ped_radius=float(sim.ped_radius),
        horizon=int(sim.horizon),
        route=np.asarray(sim.route.waypoints, dtype=float),
        goal_tolerance=float(sim.route.tolerance),
        limits=sim.limits,
        static=sim.static,
        **crowdnav_metrics(scenario, float(sim.dt)),
    )


def crowdnav_metrics(scenario: ResolvedScenario, dt: float) -> dict[str, Any]:
    """A generated (CrowdNav) crowd's social metrics: discomfort at its discomfort distance, intrusion over the
    1.25 s its robot's predictor looks ahead (CrowdNav++: 5 steps of 0.25 s)."""
    gen = scenario.scenario.crowd_generator
    if gen is None:
        return {}
    return {"discomfort_clearance": gen.discomfort_dist, "intrusion_steps": max(1, int(round(1.25 / dt)))}


def fallback_of(rp: ResolvedPlanner, sources: set[str]) -> str | None:
    """A learned model was requested but some decisions used constant velocity for every pedestrian."""
    if rp.learned and "constant_velocity" in sources:
        return "forecasts came from constant velocity although a learned model was requested"
    return None


@dataclass
class EpisodeRun:
    record: EpisodeRecord
    trace: Any
    log: StepLog
    geometry: EpisodeGeometry


def record_of(
    scenario: ResolvedScenario,
    seed: int,
    sim: Any,
    rp: ResolvedPlanner,
    *,
    outcome: str,
    error: str | None = None,
    log: StepLog | None = None,
    wall_s: float | None = None,
    metrics_cfg: MetricsConfig | None = None,
    taxonomy_cfg: TaxonomyConfig | None = None,
) -> tuple[EpisodeRecord, EpisodeGeometry]:
    """The record (metrics, taxonomy, provenance) of the episode ``sim`` just ran, and its geometry."""
    log = log or StepLog()
    trace = sim.trace
    geom = geometry_of(scenario, sim)
    quality, per_ped = prediction_quality(trace, log.predictions, trace.dt)
    sc = scenario.scenario
    prov = Provenance(
        scenario=sc.name,
        archetype=sc.archetype,
        density=sc.density_label,
        seed=int(seed),
        planner=rp.name,
        variant=rp.variant,
        planner_config_hash=rp.config_hash,
        model_id=rp.model_id,
        checkpoint_sha256=rp.checkpoint_sha256,
        code_version=code_version(),
        dt=float(trace.dt),
        horizon=geom.horizon,
        map_sha256=scenario.map_sha256,
        fallback=fallback_of(rp, log.sources),
    )
    kind = trace.collision_kind or None
    record = build_record(
        trace,
        geom,
        outcome=outcome,
        provenance=prov,
        collision_kind=kind,
        collision_step=trace.collision_step if trace.collision_step >= 0 else None,
        collision_point=trace.collision_point if kind else None,
        error=error,
        plan_ms=log.plan_ms,
        wall_s=wall_s,
        prediction=quality,
        prediction_error=per_ped,
        metrics_cfg=metrics_cfg,
        taxonomy_cfg=taxonomy_cfg,
    )
    return record, geom


def run_one(
    scenario: ResolvedScenario,
    seed: int,
    rp: ResolvedPlanner,
    *,
    max_steps: int | None = None,
    metrics_cfg: MetricsConfig | None = None,
    taxonomy_cfg: TaxonomyConfig | None = None,
    keep_diagnostics: bool = False,
    simulator: Any = None,
    check: Callable[[], None] | None = None,
) -> EpisodeRun:
    """Run and record one (scenario, seed, planner) episode; ``check`` as in :func:`run_episode`."""
    from foresight.core.sim.episode import run_episode
    from foresight.core.sim.simulator import Simulator

    sim = simulator or Simulator()
    planner = RecordingPlanner(build_planner(rp), keep_diagnostics)
    t0 = time.perf_counter()
    error = None
    try:
        run_episode(scenario, seed, planner, simulator=sim, max_steps=max_steps, check=check)
        outcome = sim.trace.outcome
    except PlannerFailure as exc:
        outcome, error = "error", str(exc)
    planner.finish(outcome)
    record, geom = record_of(
        scenario,
        seed,
        sim,
        rp,
        outcome=outcome,
        error=error,
        log=planner.log,
        wall_s=time.perf_counter() - t0,
        metrics_cfg=metrics_cfg,
        taxonomy_cfg=taxonomy_cfg,
    )
    if (
        outcome in ("timeout", "collision_pedestrian")
        and (taxonomy_cfg or TaxonomyConfig()).check_reachability
    ):
        reachable = reachability_checked(scenario, seed, max_steps)
        if reachable is not None:
            record = record.model_copy(
                update={"taxonomy": record.taxonomy.model_copy(update={"reachable": reachable})}
            )
    return EpisodeRun(record=record, trace=sim.trace, log=planner.log, geometry=geom)


def reachability_checked(scenario: ResolvedScenario, seed: int, max_steps: int | None = None) -> bool | None:
    """Whether any robot could have reached the goal (``core.sim.feasibility``), where that has an answer: None
    where pedestrians react to the robot (their paths depend on what it does)."""
    from foresight.core.sim.feasibility import peds_react, reachability

    if peds_react(scenario):
        return None
    return reachability(scenario, seed, max_steps=max_steps).reachable
