"""Hard-seed diagnostics report: outcomes and failure mechanisms of every diagnosed seed, and per seed the
episode render, the critical moment (predicted vs actual futures of the nearest pedestrians) and an
animated replay.

Input: the ``diagnose`` stage's result (``DiagnosticsResult``, its dict or ``diagnostics.json``) and the
per-seed trace JSON it wrote under the same work dir. A replay needs the full episode (every pedestrian),
which the trace JSON does not hold: it is linked when the stage wrote one (``replay`` field or
``diagnostics/<scenario>_<seed>.gif``), else rendered here from a ``Trace`` (or its ``.npz``) and the map.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from foresight.core.evaluation.diagnostics import (
    DiagnosticsResult,
    PredictedVsActual,
    SeedSummary,
    SeedTrace,
    TraceStep,
)
from foresight.core.maps.model import MapDef
from foresight.core.render.animation import render_replay
from foresight.core.render.charts import taxonomy_bars
from foresight.core.render.moment import render_critical_moment
from foresight.core.reports.common import existing, figure_path, fmt, publish, read
from foresight.core.reports.document import Document

DEFAULT_PED_RADIUS = 0.4  #: [m] only for drawing


def _critical_step(trace: SeedTrace) -> int:
    """The taxonomy's critical step, else the first collision, else the closest approach, else the end."""
    for step in (trace.record.taxonomy.critical_step, trace.record.safety.first_collision_step):
        if step is not None and step >= 0:
            return step
    finite = [(s.min_distance, i) for i, s in enumerate(trace.steps) if s.min_distance is not None]
    return min(finite)[1] if finite else max(len(trace.steps) - 1, 0)


def _forecasts_at(steps: list[TraceStep], t: int) -> tuple[int, list[PredictedVsActual]]:
    """(step, rows) of the latest ``predicted_vs_actual`` at or before ``t`` (empty when none was recorded)."""
    for i in range(min(t, len(steps) - 1), -1, -1):
        if steps[i].predicted_vs_actual:
            return i, steps[i].predicted_vs_actual
    return t, []


def _plan(step: TraceStep, dt: float) -> Any:
    """The robot's plan at a step: a path the planner logged (``chosen``: plan/path/trajectory as (K, 2)), else
    its command rolled out for PLAN_S seconds; None without a command."""
    from foresight.core.render.moment import rollout

    for key in ("plan", "path", "trajectory"):
        logged = (step.chosen or {}).get(key)
        if isinstance(logged, list) and logged and all(isinstance(p, list) and len(p) >= 2 for p in logged):
            return [p[:2] for p in logged]
    if step.command is None or None in step.command[:2] or None in step.robot[:3]:
        return None
    return rollout(step.robot[:3], step.command[:2], dt)  # type: ignore[arg-type]


def _pedestrians_at(sim_trace: Any, t: int) -> list[tuple[int, Any, Any]]:
    """(id, position, velocity) of the pedestrians in the scene at step ``t`` of a full episode trace."""
    if sim_trace is None or t > sim_trace.steps:
        return []
    ids, pos, vel = sim_trace.ped_ids[t], sim_trace.ped_pos[t], sim_trace.ped_vel[t]
    return [(int(i), pos[k], vel[k]) for k, i in enumerate(ids) if i >= 0]


def _moment(
    workdir: Path, seed: SeedSummary, trace: SeedTrace, mapdef: MapDef | None, sim_trace: Any = None
) -> str | None:
    if not trace.steps:
        return None
    t = min(_critical_step(trace), len(trace.steps) - 1)
    made_at, rows = _forecasts_at(trace.steps, t)
    at = trace.steps[made_at]
    path, rel = figure_path(workdir, f"moment_{seed.scenario}_{seed.seed}.png")
    title = f"{seed.scenario} seed {seed.seed}: step {t} ({t * trace.dt:.1f} s)" + (
        f", forecast made at step {made_at}" if rows else ""
    )
    render_critical_moment(
        [s.robot[:2] for s in trace.steps],
        made_at,
        [r.model_dump() for r in rows],
        path,
        mapdef=mapdef,
        title=title,
        collision_point=trace.record.collision_point,
        robot_radius=_robot_radius(seed),
        heading=at.robot[2],
        plan=_plan(at, trace.dt),
        pedestrians=_pedestrians_at(sim_trace, made_at),
    )
    return rel


def _sim_trace(workdir: Path, seed: SeedSummary) -> Any:
    """The episode's full trace (``diagnostics/trace_<scenario>_<seed>.npz``) when stored, else None."""
    npz = workdir / f"diagnostics/trace_{seed.scenario}_{seed.seed}.npz"
    if not npz.is_file():
        return None
    from foresight.core.sim.trace import Trace

    return Trace.load(npz)


def _robot_radius(seed: SeedSummary) -> float:
    """min distance - min clearance = robot + pedestrian radius, so the robot is drawn at its size."""
    if seed.min_distance is None or seed.min_clearance is None:
        return 1.0
    return max(0.1, seed.min_distance - seed.min_clearance - DEFAULT_PED_RADIUS)


def _replay(
    workdir: Path, seed: SeedSummary, trace_json: SeedTrace | None, mapdef: MapDef | None, trace: Any
) -> str | None:
    name, s = seed.scenario, seed.seed
    for rel in (seed.replay, f"diagnostics/{name}_{s}.gif", f"diagnostics/replay_{name}_{s}.gif"):
        if existing(workdir, rel):
            return str(rel)
    npz = workdir / f"diagnostics/trace_{name}_{s}.npz"
    if trace is None and npz.is_file():
        from foresight.core.sim.trace import Trace

        trace = Trace.load(npz)
    if trace is None or mapdef is None:
        return None
    rel = f"diagnostics/replay_{name}_{s}.gif"
    record = trace_json.record if trace_json is not None else None
    render_replay(
        trace,
        mapdef,
        workdir / rel,
        predictions=[st.model_dump() for st in trace_json.steps] if trace_json is not None else None,
        title=f"{name} seed {s}: {seed.outcome}",
        collision_step=record.safety.first_collision_step if record is not None else None,
        collision_point=record.collision_point if record is not None else None,
        robot_radius=_robot_radius(seed),
        ped_radius=DEFAULT_PED_RADIUS,
    )
    return rel


def _seed_section(doc: Document, workdir: Path, seed: SeedSummary, mapdef: MapDef | None, trace: Any) -> None:
    doc.section(f"{seed.scenario} seed {seed.seed}: {seed.outcome}", level=3)
    doc.bullets(
        [
            f"outcome **{seed.outcome}**, label {seed.label or '-'}, tags {', '.join(seed.tags) or '-'}",
            f"steps {seed.steps}, first collision step {_or_dash(seed.first_collision_step)}",
            f"min distance {fmt(seed.min_distance, 2, ' m')}, min clearance {fmt(seed.min_clearance, 2, ' m')}",
            f"command speed mean {fmt(seed.mean_command_v, 2, ' m/s')}, max {fmt(seed.max_command_v, 2, ' m/s')}",
            f"planner time {fmt(seed.plan_ms_mean, 2, ' ms')} per step, prediction ADE {fmt(seed.prediction_ade, 2, ' m')}",
        ]
    )
    if existing(workdir, seed.render):
        doc.image(str(seed.render), "Episode: robot path by time, pedestrian tracks, collision point")
    trace_json = None
    if existing(workdir, seed.trace):
        trace_json = read(SeedTrace, workdir / seed.trace)
        moment = _moment(
            workdir, seed, trace_json, mapdef, trace if trace is not None else _sim_trace(workdir, seed)
        )
        if moment:
            doc.image(
                moment,
                "Critical moment: predicted (dashed) vs actual (solid) futures of the nearest pedestrians",
            )
        doc.links([("per-step trace (JSON)", seed.trace)])
    else:
        doc.note("No per-step trace stored for this seed: no critical-moment picture.")
    replay = _replay(workdir, seed, trace_json, mapdef, trace)
    if replay:
        doc.image(replay, "Animated replay (GIF) with predicted pedestrian futures")
    else:
        doc.note("No replay: no full episode trace (.npz or Trace) and map were available.")


def _or_dash(x: Any) -> Any:
    return "-" if x is None else x


def build_diagnostics_document(
    res: DiagnosticsResult,
    workdir: Path,
    maps: Mapping[str, MapDef] | None = None,
    traces: Mapping[tuple[str, int], Any] | None = None,
) -> Document:
    planner = res.planner
    label = planner.variant or planner.name
    doc = Document(f"Hard-seed diagnostics: {label}")
    doc.section("Summary")
    doc.text(
        f"Solved **{res.solved}/{res.episodes}** hard seeds with planner `{label}` (config "
        f"`{planner.config_hash[:12]}`, model `{planner.model_id}`), code `{res.code_version}`, "
        f"{fmt(res.wall_s, 1, ' s')}."
    )
    doc.table(["outcome", "episodes"], [[k, v] for k, v in sorted(res.outcomes.items())] or [["-", 0]])
    doc.section("Failure taxonomy")
    by_scenario: dict[str, dict[str, int]] = {}
    for s in res.seeds:
        if s.label:
            counts = by_scenario.setdefault(s.scenario, {})
            counts[s.label] = counts.get(s.label, 0) + 1
    if by_scenario:
        path, rel = figure_path(workdir, "diagnostics_taxonomy.png")
        taxonomy_bars(by_scenario, path, title="Failure mechanisms of the hard seeds per scenario")
        doc.image(rel, "Failed hard seeds per scenario by primary taxonomy label")
        doc.table(["label", "episodes"], [[k, v] for k, v in res.taxonomy.items() if v])
    else:
        doc.note("Every hard seed was solved: nothing to classify.")
    doc.section("Hard seeds")
    doc.table(
        [
            "scenario",
            "seed",
            "outcome",
            "label",
            "tags",
            "steps",
            "first collision",
            "min clearance [m]",
            "prediction ADE [m]",
        ],
        [
            [
                s.scenario,
                s.seed,
                s.outcome,
                s.label or "-",
                ", ".join(s.tags) or "-",
                s.steps,
                _or_dash(s.first_collision_step),
                fmt(s.min_clearance),
                fmt(s.prediction_ade),
            ]
            for s in res.seeds
        ],
    )
    doc.section("Episodes")
    if not res.seeds:
        doc.note("No seeds were diagnosed.")
    for s in res.seeds:
        _seed_section(doc, workdir, s, (maps or {}).get(s.scenario), (traces or {}).get((s.scenario, s.seed)))
    doc.section("Artifacts")
    doc.links([(f"{k}: {v}", v) for k, v in res.artifacts.items()] + [("report (Markdown)", "report.md")])
    return doc


def write_diagnostics_report(
    result: Any,
    workdir: str | Path,
    *,
    maps: Mapping[str, MapDef] | None = None,
    traces: Mapping[tuple[str, int], Any] | None = None,
) -> list[Path]:
    """Write figures, replays, ``report.md`` and ``report.html`` for a diagnostics run; returns their paths.

    ``result``: a :class:`DiagnosticsResult`, its JSON dict or ``diagnostics.json``. ``maps``: scenario name ->
    map, for map backgrounds and for rendering replays (e.g. ``{n: matrix.get(n).map for n in matrix.names}``);
    ``traces``: (scenario, seed) -> episode Trace.
    """
    workdir = Path(workdir)
    return publish(
        build_diagnostics_document(read(DiagnosticsResult, result), workdir, maps, traces), workdir
    )
