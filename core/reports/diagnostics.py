"""Hard-seed diagnostics report: outcomes and failure mechanisms of every diagnosed seed, and per seed the
episode render, the critical moment (predicted vs actual futures of the nearest pedestrians) and an
animated replay.

Input: the ``diagnose`` stage's result (``DiagnosticsResult``, its dict or ``diagnostics.json``) and the
per-seed trace JSON it wrote under the same work dir. A replay needs the full episode (every pedestrian),
which the trace JSON does not hold: it is linked when the stage wrote one (``replay`` field or
``diagnostics/<scenario>_<seed>.gif``), else rendered here from a ``Trace`` (or its ``.npz``) and the map.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from foresight.core.maps.model import MapDef
from foresight.core.render.animation import render_replay
from foresight.core.render.charts import taxonomy_bars
from foresight.core.render.moment import render_critical_moment
from foresight.core.reports.common import as_dict, existing, figure_path, fmt, publish
from foresight.core.reports.document import Document

DEFAULT_PED_RADIUS = 0.4  #: [m] only for drawing


def _critical_step(record: Mapping[str, Any], steps: list[dict[str, Any]]) -> int:
    """The taxonomy's critical step, else the first collision, else the closest approach, else the end."""
    tax = record.get("taxonomy") or {}
    for step in (tax.get("critical_step"), (record.get("safety") or {}).get("first_collision_step")):
        if step is not None and int(step) >= 0:
            return int(step)
    dists = [s.get("min_distance") for s in steps]
    finite = [(d, i) for i, d in enumerate(dists) if d is not None]
    return min(finite)[1] if finite else max(len(steps) - 1, 0)


def _forecasts_at(steps: list[dict[str, Any]], t: int) -> tuple[int, list[dict[str, Any]]]:
    """(step, rows) of the latest ``predicted_vs_actual`` at or before ``t`` (empty when none was recorded)."""
    for i in range(min(t, len(steps) - 1), -1, -1):
        rows = steps[i].get("predicted_vs_actual") or []
        if rows:
            return i, rows
    return t, []


def _moment(workdir: Path, seed: Mapping[str, Any], trace: Mapping[str, Any], mapdef: MapDef | None) -> str | None:
    steps = trace.get("steps") or []
    if not steps:
        return None
    record = trace.get("record") or {}
    t = _critical_step(record, steps)
    made_at, rows = _forecasts_at(steps, t)
    robot = [s["robot"][:2] for s in steps]
    if len(steps) and t >= len(steps):
        t = len(steps) - 1
    radius = _robot_radius(seed)
    path, rel = figure_path(workdir, f"moment_{seed['scenario']}_{seed['seed']}.png")
    title = (f"{seed['scenario']} seed {seed['seed']}: step {t} ({t * float(trace.get('dt', 0.1)):.1f} s), "
             f"forecast made at step {made_at}")
    render_critical_moment(robot, made_at, rows, path, mapdef=mapdef, title=title,
                           collision_point=record.get("collision_point"), robot_radius=radius)
    return rel


def _robot_radius(seed: Mapping[str, Any]) -> float:
    """min distance - min clearance = robot + pedestrian radius, so the robot is drawn at its size."""
    d, c = seed.get("min_distance"), seed.get("min_clearance")
    if d is None or c is None:
        return 1.0
    return max(0.1, float(d) - float(c) - DEFAULT_PED_RADIUS)


def _replay(workdir: Path, seed: Mapping[str, Any], trace_json: Mapping[str, Any], mapdef: MapDef | None,
            trace: Any) -> str | None:
    name, s = seed["scenario"], seed["seed"]
    for rel in (seed.get("replay"), f"diagnostics/{name}_{s}.gif", f"diagnostics/replay_{name}_{s}.gif"):
        if existing(workdir, rel):
            return str(rel)
    npz = workdir / f"diagnostics/trace_{name}_{s}.npz"
    if trace is None and npz.is_file():
        from foresight.core.sim.trace import Trace

        trace = Trace.load(npz)
    if trace is None or mapdef is None:
        return None
    rel = f"diagnostics/replay_{name}_{s}.gif"
    record = trace_json.get("record") or {}
    render_replay(trace, mapdef, workdir / rel, predictions=trace_json.get("steps"),
                  title=f"{name} seed {s}: {seed.get('outcome')}",
                  collision_step=(record.get("safety") or {}).get("first_collision_step"),
                  collision_point=record.get("collision_point"), robot_radius=_robot_radius(seed),
                  ped_radius=DEFAULT_PED_RADIUS)
    return rel


def _seed_section(doc: Document, workdir: Path, seed: Mapping[str, Any], mapdef: MapDef | None, trace: Any) -> None:
    doc.section(f"{seed['scenario']} seed {seed['seed']}: {seed.get('outcome')}", level=3)
    doc.bullets([
        f"outcome **{seed.get('outcome')}**, label {seed.get('label') or '-'}, tags {', '.join(seed.get('tags') or []) or '-'}",
        f"steps {seed.get('steps')}, first collision step {seed.get('first_collision_step', '-')}",
        f"min distance {fmt(seed.get('min_distance'), 2, ' m')}, min clearance {fmt(seed.get('min_clearance'), 2, ' m')}",
        f"command speed mean {fmt(seed.get('mean_command_v'), 2, ' m/s')}, max {fmt(seed.get('max_command_v'), 2, ' m/s')}",
        f"planner time {fmt(seed.get('plan_ms_mean'), 2, ' ms')} per step, prediction ADE {fmt(seed.get('prediction_ade'), 2, ' m')}",
    ])
    if existing(workdir, seed.get("render")):
        doc.image(str(seed["render"]), "Episode: robot path by time, pedestrian tracks, collision point")
    trace_json: dict[str, Any] = {}
    if existing(workdir, seed.get("trace")):
        trace_json = json.loads((workdir / seed["trace"]).read_text())
        moment = _moment(workdir, seed, trace_json, mapdef)
        if moment:
            doc.image(moment, "Critical moment: predicted (dashed) vs actual (solid) futures of the nearest pedestrians")
        doc.links([("per-step trace (JSON)", str(seed["trace"]))])
    else:
        doc.note("No per-step trace stored for this seed: no critical-moment picture.")
    replay = _replay(workdir, seed, trace_json, mapdef, trace)
    if replay:
        doc.image(replay, "Animated replay (GIF) with predicted pedestrian futures")
    else:
        doc.note("No replay: no full episode trace (.npz or Trace) and map were available.")


def build_diagnostics_document(res: Mapping[str, Any], workdir: Path, maps: Mapping[str, MapDef] | None = None,
                               traces: Mapping[tuple[str, int], Any] | None = None) -> Document:
    planner = res.get("planner") or {}
    seeds = list(res.get("seeds") or [])
    doc = Document(f"Hard-seed diagnostics: {planner.get('variant') or planner.get('name', 'planner')}")
    doc.section("Summary")
    doc.text(f"Solved **{res.get('solved', '?')}/{res.get('episodes', '?')}** hard seeds with planner "
             f"`{planner.get('variant') or planner.get('name', '?')}` (config `{str(planner.get('config_hash', '?'))[:12]}`, "
             f"model `{planner.get('model_id', '?')}`), code `{res.get('code_version', '?')}`, "
             f"{fmt(res.get('wall_s'), 1, ' s')}.")
    outcomes = res.get("outcomes") or {}
    doc.table(["outcome", "episodes"], [[k, v] for k, v in sorted(outcomes.items())] or [["-", 0]])
    doc.section("Failure taxonomy")
    by_scenario: dict[str, dict[str, int]] = {}
    for s in seeds:
        if s.get("label"):
            counts = by_scenario.setdefault(s["scenario"], {})
            counts[s["label"]] = counts.get(s["label"], 0) + 1
    if by_scenario:
        path, rel = figure_path(workdir, "diagnostics_taxonomy.png")
        taxonomy_bars(by_scenario, path, title="Failure mechanisms of the hard seeds per scenario")
        doc.image(rel, "Failed hard seeds per scenario by primary taxonomy label")
        doc.table(["label", "episodes"], [[k, v] for k, v in (res.get("taxonomy") or {}).items() if v])
    else:
        doc.note("Every hard seed was solved: nothing to classify.")
    doc.section("Hard seeds")
    doc.table(["scenario", "seed", "outcome", "label", "tags", "steps", "first collision", "min clearance [m]",
               "prediction ADE [m]"],
              [[s["scenario"], s["seed"], s.get("outcome"), s.get("label") or "-", ", ".join(s.get("tags") or []) or "-",
                s.get("steps"), s.get("first_collision_step") if s.get("first_collision_step") is not None else "-",
                fmt(s.get("min_clearance")), fmt(s.get("prediction_ade"))] for s in seeds])
    doc.section("Episodes")
    if not seeds:
        doc.note("No seeds were diagnosed.")
    for s in seeds:
        _seed_section(doc, workdir, s, (maps or {}).get(s["scenario"]), (traces or {}).get((s["scenario"], s["seed"])))
    doc.section("Artifacts")
    doc.links([(f"{k}: {v}", v) for k, v in (res.get("artifacts") or {}).items()] + [("report (Markdown)", "report.md")])
    return doc


def write_diagnostics_report(result: Any, workdir: str | Path, *, maps: Mapping[str, MapDef] | None = None,
                             traces: Mapping[tuple[str, int], Any] | None = None) -> list[Path]:
    """Write figures, replays, ``report.md`` and ``report.html`` for a diagnostics run; returns their paths.

    ``maps``: scenario name -> map, for map backgrounds and for rendering replays (e.g.
    ``{n: matrix.get(n).map for n in matrix.names}``); ``traces``: (scenario, seed) -> episode Trace.
    """
    workdir = Path(workdir)
    return publish(build_diagnostics_document(as_dict(result), workdir, maps, traces), workdir)


