"""Stage ``diagnose``: hard-seed diagnostics, one traced episode per (scenario, seed) of a seed manifest.

For each seed: a per-step trace (robot pose, command, nearest distance, the planner's chosen candidate
with its cost terms, predicted vs actual positions of the nearest pedestrians), a summary (outcome,
taxonomy label, first collision step, minimum distance) and a PNG. Unlike the reference's diagnostics
(which always exited 0), the summary carries the taxonomy so a hard seed's failure mechanism is visible.
"""

from __future__ import annotations

import json
import time
from typing import Any

import numpy as np
from pydantic import BaseModel, Field

from foresight.core import files
from foresight.core.evaluation.config import DiagnosticsConfig
from foresight.core.evaluation.episode import EpisodeRun
from foresight.core.evaluation.evaluation_result import PlannerProvenance, planner_provenance
from foresight.core.evaluation.metrics import derive
from foresight.core.evaluation.plannerspec import preflight, resolve_planner
from foresight.core.evaluation.record import EpisodeRecord
from foresight.core.evaluation.runner import EpisodeSettings, Job, load_selection, run_jobs
from foresight.core.evaluation.taxonomy import TaxonomyConfig, count_labels
from foresight.core.runtime.context import StageContext
from foresight.core.runtime.execution import Execution, execution
from foresight.core.version import code_version


class SeedSummary(BaseModel):
    scenario: str
    seed: int
    outcome: str
    steps: int
    label: str | None
    tags: list[str]
    first_collision_step: int | None
    min_distance: float | None  #: centre distance [m]
    min_clearance: float | None  #: surface gap [m]
    mean_command_v: float | None  #: [m/s]
    max_command_v: float | None
    plan_ms_mean: float | None
    prediction_ade: float | None
    trace: str  #: artifact name of the per-step JSON
    render: str | None = None  #: artifact name of the PNG
    replay: str | None = None  #: artifact name of the animated GIF replay (predicted futures drawn)


class DiagnosticsResult(BaseModel):
    episodes: int
    solved: int
    outcomes: dict[str, int]
    taxonomy: dict[str, int]
    taxonomy_config: TaxonomyConfig
    seeds: list[SeedSummary]
    planner: PlannerProvenance
    code_version: str
    execution: Execution | None = (
        None  #: which executor ran the episodes, on how many CPUs (None: older results)
    )
    artifacts: dict[str, str]
    wall_s: float
    config: dict  #: the stage config as given (with defaults)


class PredictedVsActual(BaseModel):
    """A pedestrian's forecast made at a step against where it really was (None: not in the scene then)."""

    ped_id: int
    times: list[float]  #: [s] after the step
    predicted: list[list[float]]  #: (H, 2)
    actual: list[list[float] | None]


class TraceStep(BaseModel):
    step: int
    robot: list[float | None]  #: x, y, heading, v, omega
    command: list[float | None] | None = None  #: (v, omega) commanded at this step; None at the last state
    min_distance: float | None  #: centre distance to the nearest pedestrian [m]
    min_clearance: float | None = None  #: surface gap [m]
    plan_ms: float | None = None
    chosen: dict[str, Any] | None = None  #: the planner's diagnostics of its decision (without predictions)
    predicted_vs_actual: list[PredictedVsActual] = Field(default_factory=list)


class SeedTrace(BaseModel):
    """``diagnostics/trace_<scenario>_<seed>.json``: one diagnosed episode step by step, with its record."""

    scenario: str
    seed: int
    horizon: int
    dt: float
    record: EpisodeRecord
    steps: list[TraceStep]


def jsonable(x: Any, digits: int = 4) -> Any:
    """numpy values and containers -> plain JSON types; floats rounded (0.1 mm keeps traces small)."""
    if isinstance(x, dict):
        return {str(k): jsonable(v, digits) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v, digits) for v in x]
    if isinstance(x, np.ndarray):
        return jsonable(x.tolist(), digits)
    if isinstance(x, np.generic):
        return jsonable(x.item(), digits)
    if isinstance(x, float):
        return round(x, digits) if np.isfinite(x) else None
    return x


def _predicted_vs_actual(run: EpisodeRun, step: int, diag: dict[str, Any], k: int) -> list[dict[str, Any]]:
    """Forecast of the ``k`` nearest pedestrians at ``step`` against where they really went."""
    pred = diag.get("predictions")
    if not pred or k == 0:
        return []
    tr = run.trace
    ids, pos, times = np.asarray(pred["ped_ids"]), np.asarray(pred["positions"]), np.asarray(pred["times"])
    rows = step + np.rint(times / tr.dt).astype(int)
    robot = tr.robot[step, :2]
    out = []
    for i in np.argsort(np.linalg.norm(pos[:, 0] - robot, axis=1))[:k] if ids.size else []:
        slots = np.flatnonzero(tr.ped_ids[step] == ids[i])
        actual: list[Any] = []
        for r in rows:
            ok = slots.size and r <= tr.steps and tr.ped_ids[r, slots[0]] == ids[i]
            actual.append(tr.ped_pos[r, slots[0]].tolist() if ok else None)
        out.append(
            {"ped_id": int(ids[i]), "times": times.tolist(), "predicted": pos[i].tolist(), "actual": actual}
        )
    return out


def step_trace(run: EpisodeRun, max_peds: int) -> list[dict[str, Any]]:
    d = derive(run.trace, run.geometry)
    steps = []
    for t in range(d.steps):
        diag = run.log.diagnostics[t] if t < len(run.log.diagnostics) else None
        chosen = {k: v for k, v in (diag or {}).items() if k != "predictions"}
        steps.append(
            {
                "step": t,
                "robot": jsonable(run.trace.robot[t]),
                "command": jsonable(run.trace.command[t]),
                "min_distance": jsonable(float(d.nearest[t])),
                "min_clearance": jsonable(float(d.clearance[t])),
                "plan_ms": jsonable(run.log.plan_ms[t]) if t < len(run.log.plan_ms) else None,
                "chosen": jsonable(chosen) if diag else None,
                "predicted_vs_actual": jsonable(_predicted_vs_actual(run, t, diag, max_peds)) if diag else [],
            }
        )
    return steps


def _render(run: EpisodeRun, scenario: Any, ctx: StageContext, name: str, title: str) -> str | None:
    from foresight.core.render.trace import render_trace

    tr, rec = run.trace, run.record
    render_trace(
        tr,
        scenario.map,
        ctx.artifact(name),
        title=title,
        collision_step=rec.safety.first_collision_step,
        collision_point=rec.collision_point,
        goal=run.geometry.route[-1],
        robot_radius=run.geometry.robot_radius,
    )
    return name


def _replay(run: EpisodeRun, scenario: Any, ctx: StageContext, name: str, title: str, steps: list) -> str:
    from foresight.core.render.animation import render_replay

    rec = run.record
    render_replay(
        run.trace,
        scenario.map,
        ctx.artifact(name),
        predictions=steps,
        title=title,
        collision_step=rec.safety.first_collision_step,
        collision_point=rec.collision_point,
        robot_radius=run.geometry.robot_radius,
        ped_radius=run.geometry.ped_radius,
    )
    return name


def _summary(run: EpisodeRun, trace_name: str, render_name: str | None, replay: str | None) -> SeedSummary:
    r, cmd = run.record, run.trace.command
    return SeedSummary(
        scenario=r.scenario,
        seed=r.seed,
        outcome=r.outcome,
        steps=r.steps,
        label=r.taxonomy.label,
        tags=list(r.taxonomy.tags),
        first_collision_step=r.safety.first_collision_step,
        min_distance=r.safety.min_distance,
        min_clearance=r.safety.min_clearance,
        mean_command_v=float(cmd[:, 0].mean()) if len(cmd) else None,
        max_command_v=float(cmd[:, 0].max()) if len(cmd) else None,
        plan_ms_mean=r.timing.plan_ms_mean,
        prediction_ade=r.prediction.ade,
        trace=trace_name,
        render=render_name,
        replay=replay,
    )


def _write_seed(run: EpisodeRun, scenario: Any, config: DiagnosticsConfig, ctx: StageContext) -> SeedSummary:
    name, seed = run.record.scenario, run.record.seed
    trace_name = f"diagnostics/trace_{name}_{seed}.json"
    steps = step_trace(run, config.max_predicted_peds)
    files.write_text(
        ctx.artifact(trace_name),
        SeedTrace(
            scenario=name,
            seed=seed,
            horizon=run.geometry.horizon,
            dt=run.trace.dt,
            record=run.record,
            steps=steps,
        ).model_dump_json(),
    )
    render = replay = None
    if config.render:
        title = f"{name} seed {seed}: {run.record.outcome} ({run.record.taxonomy.label or 'solved'})"
        render = _render(run, scenario, ctx, f"diagnostics/{name}_{seed}.png", title)
        replay = _replay(run, scenario, ctx, f"diagnostics/replay_{name}_{seed}.gif", title, steps)
    return _summary(run, trace_name, render, replay)


def run_diagnostics(config: DiagnosticsConfig, ctx: StageContext) -> DiagnosticsResult:
    """Trace every (scenario, seed) of the manifest; writes traces, PNGs, a summary JSON and a report."""
    t0 = time.perf_counter()
    path, matrix, pairs = load_selection(config, ctx)
    rp = resolve_planner(config.planner, ctx)
    preflight(rp, [matrix.get(s) for s in dict.fromkeys(s for s, _ in pairs)])
    settings = EpisodeSettings(
        str(path),
        config.max_steps,
        config.metrics,
        config.taxonomy,
        keep_diagnostics=True,
        overrides=config.scenario_overrides,
    )
    jobs = [Job(i, name, seed, rp) for i, (name, seed) in enumerate(pairs)]

    def progress(done: int, total: int, rec: EpisodeRecord) -> None:
        ctx.progress(0.9 * done / total, f"{rec.scenario} seed {rec.seed}: {rec.outcome}")

    # the same runner as evaluations (worker processes for learned models), so a seed behaves identically
    runs: list[EpisodeRun] = run_jobs(
        jobs, settings, ctx, matrix=matrix, on_record=progress, executor=config.executor
    )
    seeds = [_write_seed(run, matrix.get(run.record.scenario), config, ctx) for run in runs]
    ctx.progress(1.0, "done")
    outcomes: dict[str, int] = {}
    for s in seeds:
        outcomes[s.outcome] = outcomes.get(s.outcome, 0) + 1
    result = DiagnosticsResult(
        episodes=len(seeds),
        solved=outcomes.get("success", 0),
        outcomes=outcomes,
        taxonomy=count_labels([s.label for s in seeds]),
        taxonomy_config=config.taxonomy,
        seeds=seeds,
        planner=planner_provenance(rp),
        code_version=code_version(),
        execution=execution(config.executor, ctx.workers),
        artifacts={"summary": "diagnostics.json", "report": "diagnostics_report.md"},
        wall_s=time.perf_counter() - t0,
        config=config.model_dump(mode="json"),
    )
    files.write_text(ctx.artifact("diagnostics.json"), json.dumps(result.model_dump(mode="json"), indent=2))
    files.write_text(ctx.artifact("diagnostics_report.md"), report(result))
    return result


def report(res: DiagnosticsResult) -> str:
    lines = [
        "# Hard-seed diagnostics",
        "",
        f"Planner `{res.planner.variant or res.planner.name}` (config {res.planner.config_hash[:12]}, "
        f"model {res.planner.model_id}), code {res.code_version}.",
        "",
        f"Solved {res.solved}/{res.episodes}. Outcomes: "
        + ", ".join(f"{k} {v}" for k, v in sorted(res.outcomes.items()))
        + ".",
        "",
        "| scenario | seed | outcome | label | tags | steps | first collision | min clearance [m] |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for s in res.seeds:
        clr = f"{s.min_clearance:.2f}" if s.min_clearance is not None else "-"
        lines.append(
            f"| {s.scenario} | {s.seed} | {s.outcome} | {s.label or '-'} | {', '.join(s.tags) or '-'} | "
            f"{s.steps} | {s.first_collision_step if s.first_collision_step is not None else '-'} | {clr} |"
        )
    return "\n".join(lines) + "\n"
