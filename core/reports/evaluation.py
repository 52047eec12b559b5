"""Evaluation report: headline rates, gate, integrity, per-scenario and per-family bars with intervals,
failure taxonomy per family, failed episodes and mean metrics, as Markdown + HTML with PNG figures.

Input: the ``evaluate`` stage's result (``EvaluationResult``, its dict, or ``evaluation.json``).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from foresight.core.render.charts import rate_bars, taxonomy_bars
from foresight.core.reports.common import (
    as_dict,
    figure_path,
    fmt,
    gate_rows,
    mean_text,
    pct,
    publish,
    rate_est,
    rate_text,
    verdict,
)
from foresight.core.reports.document import Document

MEAN_ROWS = {  #: aggregate mean name -> (row label, digits)
    "min_clearance": ("min clearance (surface gap) [m]", 2),
    "min_distance": ("min centre distance [m]", 2),
    "avg_speed": ("average speed [m/s]", 2),
    "path_efficiency": ("path efficiency (successes)", 2),
    "time_to_goal_s": ("time to goal (successes) [s]", 1),
    "near_misses": ("near-miss steps", 1),
    "jerk_mean": ("mean jerk [m/s^3]", 2),
    "plan_ms_mean": ("planner time per step, mean [ms]", 2),
    "plan_ms_p95": ("planner time per step, p95 [ms]", 2),
}


def _groups(res: Mapping[str, Any], level: str) -> list[dict[str, Any]]:
    return list((res.get("aggregates") or {}).get(level) or [])


def _summary(doc: Document, res: Mapping[str, Any]) -> None:
    overall = (res.get("aggregates") or {}).get("overall") or {}
    rates = overall.get("rates") or {}
    planner = res.get("planner") or {}
    doc.section("Summary")
    doc.text(f"Status **{res.get('status', '?')}** (exit code {res.get('exit_code', '?')}): "
             f"{res.get('episodes', '?')} episodes, success {pct(res.get('success_rate'))}, "
             f"collision {pct(res.get('collision_rate'))}.")
    doc.table(["quantity", "value"], [
        ["success rate (95 % Wilson)", rate_text(rates.get("success"))],
        ["collision rate", rate_text(rates.get("collision"))],
        ["pedestrian collisions", rate_text(rates.get("collision_pedestrian"))],
        ["static collisions", rate_text(rates.get("collision_static"))],
        ["timeouts", rate_text(rates.get("timeout"))],
        ["errors", rate_text(rates.get("error"))],
        ["planner", f"`{planner.get('variant') or planner.get('name', '?')}` (config "
                    f"`{str(planner.get('config_hash', '?'))[:12]}`)"],
        ["model", f"`{planner.get('model_id', '?')}` (checkpoint `{str(planner.get('checkpoint_sha256', '?'))[:12]}`)"],
        ["scenarios", f"{res.get('bundle', '?')}: {res.get('matrix', '?')}, seeds {res.get('seed_source', '?')}, "
                      f"horizon {res.get('horizon', '?')}"],
        ["code version", f"`{res.get('code_version', '?')}`"],
        ["run", f"{res.get('workers', '?')} workers, {fmt(res.get('wall_s'), 1, ' s')}"],
    ])


def _gate_and_integrity(doc: Document, res: Mapping[str, Any]) -> None:
    gate = res.get("gate") or {}
    doc.section("Quality gate")
    if gate:
        doc.text(f"Evaluation gate: **{verdict(gate.get('passed'))}**")
        doc.table(["check", "result", "value", "threshold", "detail"], gate_rows(gate.get("checks") or []))
    else:
        doc.note("No gate result in this evaluation.")
    integ = res.get("integrity") or {}
    doc.section("Integrity")
    violations = integ.get("violations") or []
    doc.text(f"Integrity checks ({', '.join(integ.get('checks') or []) or '-'}): "
             f"**{'ok' if integ.get('ok') else 'FAILED'}**, {len(violations)} violations.")
    if violations:
        doc.table(["check", "scenario", "seed", "message"],
                  [[v.get("check"), v.get("scenario") or "-", v.get("seed", "-"), v.get("message", "")]
                   for v in violations])


def _rate_section(doc: Document, workdir: Path, groups: list[dict[str, Any]], title: str, name: str) -> None:
    doc.section(title)
    if not groups:
        doc.note("No groups at this level.")
        return
    path, rel = figure_path(workdir, name)
    rate_bars([f"{g['key']} (n={g.get('episodes', '?')})" for g in groups],
              {"success": [rate_est(g["rates"].get("success")) for g in groups],
               "collision": [rate_est(g["rates"].get("collision")) for g in groups]},
              path, title=title)
    doc.image(rel, f"{title}: success and collision rates with 95 % Wilson intervals")
    doc.table(["group", "episodes", "success", "collision", "timeout", "Δ success vs global", "min clearance [m]",
               "failed seeds"],
              [[g["key"], g.get("episodes", "-"), rate_text(g["rates"].get("success")),
                rate_text(g["rates"].get("collision")), rate_text(g["rates"].get("timeout")),
                _delta_pp((g.get("delta_to_global") or {}).get("success_rate")),
                mean_text((g.get("means") or {}).get("min_clearance")),
                ", ".join(str(f["seed"]) for f in g.get("failed") or []) or "-"] for g in groups])


def _delta_pp(x: Any) -> str:
    return "-" if x is None else f"{100 * float(x):+.1f} pp"


def _taxonomy(doc: Document, workdir: Path, res: Mapping[str, Any]) -> None:
    doc.section("Failure taxonomy")
    total = {k: int(v) for k, v in (res.get("taxonomy") or {}).items()}
    families = {g["key"]: g.get("taxonomy") or {} for g in _groups(res, "per_family")}
    if sum(total.values()) == 0:
        doc.note("No failed episodes: nothing to classify.")
    else:
        path, rel = figure_path(workdir, "taxonomy_per_family.png")
        taxonomy_bars(families or {"all": total}, path, title="Failure mechanisms per family")
        doc.image(rel, "Failed episodes per family by primary taxonomy label")
        doc.table(["label", "episodes"], [[k, v] for k, v in total.items() if v])
    cfg = res.get("taxonomy_config") or {}
    if cfg:
        doc.text("Taxonomy thresholds: " + ", ".join(f"{k} = {v}" for k, v in cfg.items()) + ".")


def _failed(doc: Document, res: Mapping[str, Any]) -> None:
    doc.section("Failed episodes")
    failed = [f for g in _groups(res, "per_scenario") for f in g.get("failed") or []]
    if not failed:
        failed = list(((res.get("aggregates") or {}).get("overall") or {}).get("failed") or [])
    if failed:
        doc.table(["scenario", "seed", "outcome", "label"],
                  [[f["scenario"], f["seed"], f["outcome"], f.get("label") or "-"] for f in failed])
    else:
        doc.note("Every episode succeeded.")


def _metrics(doc: Document, res: Mapping[str, Any]) -> None:
    doc.section("Metrics")
    means = (((res.get("aggregates") or {}).get("overall")) or {}).get("means") or {}
    rows = [[label, mean_text(means.get(key), digits)] for key, (label, digits) in MEAN_ROWS.items() if key in means]
    rows += [[key, mean_text(m)] for key, m in means.items() if key not in MEAN_ROWS]
    if rows:
        doc.text("Means over episodes with 95 % bootstrap intervals (episodes without a value are excluded).")
        doc.table(["metric", "mean [95 % interval] (n)"], rows)
    else:
        doc.note("No metric aggregates in this result.")


def build_evaluation_document(res: Mapping[str, Any], workdir: Path, title: str | None = None) -> Document:
    planner = res.get("planner") or {}
    doc = Document(title or f"Evaluation: {planner.get('variant') or planner.get('name', 'planner')}")
    _summary(doc, res)
    _gate_and_integrity(doc, res)
    _rate_section(doc, workdir, _groups(res, "per_scenario"), "Success and collisions per scenario",
                  "success_per_scenario.png")
    _rate_section(doc, workdir, _groups(res, "per_family"), "Per family", "success_per_family.png")
    dens = _groups(res, "per_family_density")
    doc.section("Per family and density")
    if dens:
        doc.table(["family/density", "episodes", "success", "collision", "Δ success vs global"],
                  [[g["key"], g.get("episodes", "-"), rate_text(g["rates"].get("success")),
                    rate_text(g["rates"].get("collision")),
                    _delta_pp((g.get("delta_to_global") or {}).get("success_rate"))] for g in dens])
    else:
        doc.note("No family x density groups.")
    _taxonomy(doc, workdir, res)
    _failed(doc, res)
    _metrics(doc, res)
    doc.section("Artifacts")
    arts = dict(res.get("artifacts") or {})
    doc.links([(f"{k}: {v}", v) for k, v in arts.items()] + [("report (Markdown)", "report.md")])
    return doc


def write_evaluation_report(result: Any, workdir: str | Path, *, title: str | None = None) -> list[Path]:
    """Write figures, ``report.md`` and ``report.html`` for an evaluation under ``workdir``; returns their paths."""
    workdir = Path(workdir)
    res = as_dict(result)
    return publish(build_evaluation_document(res, workdir, title), workdir)
