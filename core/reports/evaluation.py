"""Evaluation report: headline rates, gate, integrity, per-scenario and per-family bars with intervals,
failure taxonomy per family, failed episodes and mean metrics, as Markdown + HTML with PNG figures.

Input: the ``evaluate`` stage's result (``EvaluationResult``, its dict, or ``evaluation.json``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from foresight.core.evaluation.aggregate import GroupStats
from foresight.core.evaluation.evaluation_result import EvaluationResult, PlannerProvenance
from foresight.core.evaluation.stats import RateEstimate
from foresight.core.render.charts import rate_bars, taxonomy_bars
from foresight.core.reports.common import (
    figure_path,
    fmt,
    gate_rows,
    mean_text,
    pct,
    publish,
    rate_est,
    rate_text,
    read,
    verdict,
)
from foresight.core.reports.document import Document, Link

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


def planner_label(planner: PlannerProvenance) -> str:
    return planner.variant or planner.name


def _summary(doc: Document, res: EvaluationResult) -> None:
    rates = res.aggregates.overall.rates
    planner = res.planner
    doc.section("Summary")
    doc.text(
        f"Status **{res.status}** (exit code {res.exit_code}): "
        f"{res.episodes} episodes, success {pct(res.success_rate)}, "
        f"collision {pct(res.collision_rate)}."
    )
    doc.table(
        ["quantity", "value"],
        [
            ["success rate (95 % Wilson)", rate_text(rates["success"])],
            ["collision rate", rate_text(rates["collision"])],
            ["pedestrian collisions", rate_text(rates["collision_pedestrian"])],
            ["static collisions", rate_text(rates["collision_static"])],
            ["timeouts", rate_text(rates["timeout"])],
            ["errors", rate_text(rates["error"])],
            *_unsolvable_rows(rates),
            ["planner", f"`{planner_label(planner)}` (config `{planner.config_hash[:12]}`)"],
            ["model", f"`{planner.model_id}` (checkpoint `{planner.checkpoint_sha256[:12]}`)"],
            ["scenarios", f"{res.bundle}: {res.matrix}, seeds {res.seed_source}, horizon {res.horizon}"],
            ["code version", f"`{res.code_version}`"],
            ["run", f"{res.workers} workers, {fmt(res.wall_s, 1, ' s')}"],
        ],
    )


def _unsolvable_rows(rates: dict[str, RateEstimate]) -> list[list[str]]:
    """Failures no robot could have turned into a success (``taxonomy.reachable`` False), and the success rate on
    the rest; none for results recorded before the check, or without such episodes."""
    if "unsolvable" not in rates or not rates["unsolvable"].count:
        return []
    bad, ok = rates["unsolvable"], rates["success"]
    solvable = ok.n - bad.count
    share = f" ({pct(ok.count / solvable)})" if solvable else ""
    return [
        ["unsolvable: no robot could reach the goal in time", rate_text(bad)],
        ["success on the solvable episodes", f"{ok.count}/{solvable}{share}"],
    ]


def _gate_and_integrity(doc: Document, res: EvaluationResult) -> None:
    doc.section("Quality gate")
    doc.text(f"Evaluation gate: **{verdict(res.gate.passed)}**")
    doc.table(["check", "result", "value", "threshold", "detail"], gate_rows(res.gate.checks))
    integ = res.integrity
    doc.section("Integrity")
    doc.text(
        f"Integrity checks ({', '.join(integ.checks) or '-'}): "
        f"**{'ok' if integ.ok else 'FAILED'}**, {len(integ.violations)} violations."
    )
    if integ.violations:
        doc.table(
            ["check", "scenario", "seed", "message"],
            [
                [v.check, v.scenario or "-", "-" if v.seed is None else v.seed, v.message]
                for v in integ.violations
            ],
        )


def _rate_section(doc: Document, workdir: Path, groups: list[GroupStats], title: str, name: str) -> None:
    doc.section(title)
    if not groups:
        doc.note("No groups at this level.")
        return
    path, rel = figure_path(workdir, name)
    rate_bars(
        [f"{g.key} (n={g.episodes})" for g in groups],
        {
            "success": [rate_est(g.rates["success"]) for g in groups],
            "collision": [rate_est(g.rates["collision"]) for g in groups],
        },
        path,
        title=title,
    )
    doc.image(rel, f"{title}: success and collision rates with 95 % Wilson intervals")
    doc.table(
        [
            "group",
            "episodes",
            "success",
            "collision",
            "timeout",
            "Δ success vs global",
            "min clearance [m]",
            "failed seeds",
        ],
        [
            [
                g.key,
                g.episodes,
                rate_text(g.rates["success"]),
                rate_text(g.rates["collision"]),
                rate_text(g.rates["timeout"]),
                _delta_pp(g.delta_to_global["success_rate"]),
                mean_text(g.means["min_clearance"]),
                ", ".join(str(f.seed) for f in g.failed) or "-",
            ]
            for g in groups
        ],
    )


def _delta_pp(x: Any) -> str:
    return "-" if x is None else f"{100 * float(x):+.1f} pp"


def _taxonomy(doc: Document, workdir: Path, res: EvaluationResult) -> None:
    doc.section("Failure taxonomy")
    total = res.taxonomy
    families = {g.key: g.taxonomy for g in res.aggregates.per_family}
    if sum(total.values()) == 0:
        doc.note("No failed episodes: nothing to classify.")
    else:
        path, rel = figure_path(workdir, "taxonomy_per_family.png")
        taxonomy_bars(families or {"all": total}, path, title="Failure mechanisms per family")
        doc.image(rel, "Failed episodes per family by primary taxonomy label")
        doc.table(["label", "episodes"], [[k, v] for k, v in total.items() if v])
    cfg = res.taxonomy_config.model_dump(mode="json")
    doc.text("Taxonomy thresholds: " + ", ".join(f"{k} = {v}" for k, v in cfg.items()) + ".")


PLAYERS = "player"  #: the report's folder of episode player pages (the dashboard redirects it to its player)


def player_path(scenario: str, seed: int) -> str:
    """Where a report links an episode's player: ``player/<scenario>__<seed>.html`` beside the report (written for
    in-process runs' failed episodes; served by the dashboard as a redirect to its own player)."""
    from foresight.core.render.episode_trace import episode_stem

    return f"{PLAYERS}/{episode_stem(scenario, seed)}.html"


def _failed(doc: Document, res: EvaluationResult) -> None:
    doc.section("Failed episodes")
    failed = [f for g in res.aggregates.per_scenario for f in g.failed] or res.aggregates.overall.failed
    if failed:
        doc.table(
            ["scenario", "seed", "outcome", "label", "episode"],
            [
                [
                    f.scenario,
                    f.seed,
                    f.outcome,
                    f.label or "-",
                    Link("watch", player_path(f.scenario, f.seed)),
                ]
                for f in failed
            ],
        )
        doc.text(
            f"Which could a robot with these limits have solved? `foresight scenarios witness --matrix {res.matrix} "
            "--episodes episodes.jsonl --players witnesses` (run in this folder, with the matrix's path) searches "
            "plans along each failed episode's route under this evaluation's conditions, and shows each witness "
            "beside this run."
        )
    else:
        doc.note("Every episode succeeded.")


def _metrics(doc: Document, res: EvaluationResult) -> None:
    doc.section("Metrics")
    means = res.aggregates.overall.means
    rows = [
        [label, mean_text(means[key], digits)] for key, (label, digits) in MEAN_ROWS.items() if key in means
    ]
    rows += [[key, mean_text(m)] for key, m in means.items() if key not in MEAN_ROWS]
    if rows:
        doc.text("Means over episodes with 95 % bootstrap intervals (episodes without a value are excluded).")
        doc.table(["metric", "mean [95 % interval] (n)"], rows)
    else:
        doc.note("No metric aggregates in this result.")


def build_evaluation_document(res: EvaluationResult, workdir: Path, title: str | None = None) -> Document:
    doc = Document(title or f"Evaluation: {planner_label(res.planner)}")
    _summary(doc, res)
    _gate_and_integrity(doc, res)
    _rate_section(
        doc,
        workdir,
        res.aggregates.per_scenario,
        "Success and collisions per scenario",
        "success_per_scenario.png",
    )
    _rate_section(doc, workdir, res.aggregates.per_family, "Per family", "success_per_family.png")
    dens = res.aggregates.per_family_density
    doc.section("Per family and density")
    if dens:
        doc.table(
            ["family/density", "episodes", "success", "collision", "Δ success vs global"],
            [
                [
                    g.key,
                    g.episodes,
                    rate_text(g.rates["success"]),
                    rate_text(g.rates["collision"]),
                    _delta_pp(g.delta_to_global["success_rate"]),
                ]
                for g in dens
            ],
        )
    else:
        doc.note("No family x density groups.")
    _taxonomy(doc, workdir, res)
    _failed(doc, res)
    _metrics(doc, res)
    doc.section("Artifacts")
    doc.links([(f"{k}: {v}", v) for k, v in res.artifacts.items()] + [("report (Markdown)", "report.md")])
    return doc


def write_evaluation_report(result: Any, workdir: str | Path, *, title: str | None = None) -> list[Path]:
    """Write figures, ``report.md`` and ``report.html`` for an evaluation under ``workdir``; returns their paths.

    ``result``: an :class:`EvaluationResult`, its JSON dict or ``evaluation.json``.
    """
    workdir = Path(workdir)
    return publish(build_evaluation_document(read(EvaluationResult, result), workdir, title), workdir)
