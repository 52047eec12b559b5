"""Campaign report: cells ranked in the reference order with hard and global success (intervals), clearances,
hard-suite failure mechanisms per cell, and the closed-loop gate against the baseline variant.

Input: the ``campaign`` stage's result (``CampaignResult``, its dict or ``campaign_summary.json``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from foresight.core.evaluation.aggregate import SuiteSummary
from foresight.core.evaluation.campaign_result import CampaignResult, CellResult
from foresight.core.evaluation.compare import SHOWN_CHANGES
from foresight.core.evaluation.delta import Delta
from foresight.core.evaluation.stats import ALPHA, MIN_PAIRS
from foresight.core.render.charts import ranking_chart, taxonomy_bars
from foresight.core.reports.common import (
    existing,
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
from foresight.core.reports.compare import ComparedRun, add_comparison
from foresight.core.reports.document import Document


def cell_name(cell: CellResult) -> str:
    return f"{cell.variant} @ {cell.checkpoint}" if cell.checkpoint else cell.variant


def _clearances(cell: CellResult) -> str:
    return f"clr {fmt(cell.hard.mean_min_clearance.mean)} / {fmt(cell.global_.mean_min_clearance.mean)} m"


def ranking_figure(workdir: Path, name: str, cells: list[CellResult], **kw: Any) -> str:
    """The ranking chart of ``cells`` (hard and global success per cell); returns its relative path."""
    path, rel = figure_path(workdir, name)
    ranking_chart(
        [cell_name(c) for c in cells],
        [rate_est(c.hard.success) for c in cells],
        [rate_est(c.global_.success) for c in cells],
        path,
        **kw,
    )
    return rel


def _ranking(doc: Document, workdir: Path, cells: list[CellResult]) -> None:
    doc.section("Ranking")
    doc.text(
        "Order: descending lexicographic on (hard success, global success, hard clearance, global clearance, "
        "global average speed); cells with integrity violations rank last."
    )
    if not cells:
        doc.note("No cells were run.")
        return
    rel = ranking_figure(
        workdir,
        "campaign_ranking.png",
        cells,
        notes=[_clearances(c) + " (hard / global)" for c in cells],
        title="Campaign ranking",
    )
    doc.image(rel, "Cells in rank order: hard-suite and global success with 95 % Wilson intervals")
    doc.table(
        [
            "rank",
            "variant",
            "checkpoint",
            "hard success",
            "global success",
            "hard clearance [m]",
            "global clearance [m]",
            "global speed [m/s]",
            "global collisions",
            "integrity",
        ],
        [
            [
                i,
                c.variant,
                c.checkpoint,
                rate_text(c.hard.success),
                rate_text(c.global_.success),
                mean_text(c.hard.mean_min_clearance),
                mean_text(c.global_.mean_min_clearance),
                mean_text(c.global_.mean_avg_speed),
                rate_text(c.global_.collision),
                "ok" if c.integrity.ok else "VIOLATIONS",
            ]
            for i, c in enumerate(cells, start=1)
        ],
    )
    _paired(doc, cells)


def _p(d: Delta) -> str:
    if d.p_value is None:
        return "-"
    disc = f" ({d.discordant[0]}/{d.discordant[1]})" if d.discordant else ""
    return f"{d.p_value:.3g}{disc}{' *' if d.significant else ''}"


def _paired(doc: Document, cells: list[CellResult]) -> None:
    def delta(d: Delta, scale: float, unit: str) -> str:
        return "-" if d.delta is None else f"{scale * d.delta:+.{1 if scale > 1 else 2}f}{unit}"

    rows = [
        [
            cell_name(c),
            suite,
            delta(d["success"], 100, " pp"),
            _p(d["success"]),
            delta(d["min_clearance"], 1, " m"),
            _p(d["min_clearance"]),
        ]
        for c in cells
        for suite, d in (c.vs_baseline or {}).items()
        if d
    ]
    if not rows:
        return
    doc.section("Paired against the baseline variant", 3)
    doc.text(
        f"Each cell against the baseline variant's cell of the same checkpoint, on the same (scenario, seed) "
        f"episodes: success by McNemar's exact test (discordant pairs baseline-only / variant-only), clearance by "
        f"the Wilcoxon signed-rank test; * = p < {ALPHA} with at least {MIN_PAIRS} pairs."
    )
    doc.table(["cell", "suite", "success delta", "McNemar p", "clearance delta", "Wilcoxon p"], rows)
    changed = [
        (cell_name(c), suite, ep)
        for c in cells
        for suite, eps in (c.changed_vs_baseline or {}).items()
        for ep in eps
    ]
    if changed:
        doc.text(
            "The episodes that ended otherwise than in the baseline cell (baseline -> cell), the discordant "
            f"pairs by name (the first {SHOWN_CHANGES}; the cell files list them all):"
        )
        doc.table(
            ["cell", "suite", "scenario", "seed", "baseline", "cell"],
            [[name, suite, e.scenario, e.seed, e.a, e.b] for name, suite, e in changed[:SHOWN_CHANGES]],
        )
        c = next((c for c in cells if c.changed_vs_baseline and c.run_dir and c.baseline), None)
        if (
            c is not None
        ):  # each cell's run folder holds its episodes and their traces: one command plays them
            doc.text(
                f"Watch them side by side: `foresight compare --local baseline=cells/{c.baseline} "
                f"cell={c.run_dir} --players pages` (in the campaign's folder) writes a player page for each "
                f"episode of that cell, and the same for any other cell; on the service, the dashboard's compare "
                f"page of two cells links them."
            )


def _taxonomy(doc: Document, workdir: Path, cells: list[CellResult]) -> None:
    doc.section("Hard-suite failure taxonomy")
    groups = {cell_name(c): c.hard.taxonomy for c in cells}
    if not any(sum(g.values()) for g in groups.values()):
        doc.note("No cell failed a hard-suite episode.")
        return
    path, rel = figure_path(workdir, "campaign_taxonomy.png")
    taxonomy_bars(groups, path, title="Hard-suite failure mechanisms per cell")
    doc.image(rel, "Failed hard-suite episodes per cell by primary taxonomy label")
    labels = [
        k
        for k in dict.fromkeys(k for g in groups.values() for k in g)
        if any(g.get(k) for g in groups.values())
    ]
    doc.table(["cell", *labels], [[name, *[g.get(k, 0) for k in labels]] for name, g in groups.items()])


def _suites(cell: CellResult) -> dict[str, SuiteSummary]:
    return {"hard": cell.hard, "global": cell.global_}


def _gate(doc: Document, res: CampaignResult, cells: list[CellResult]) -> None:
    doc.section("Closed-loop gate")
    gate = res.gate
    if gate is None:
        doc.note("No closed-loop gate configured for this campaign.")
        return
    doc.text(
        f"Candidate `{gate.candidate}` against baseline `{gate.baseline}`: "
        f"**{verdict(gate.passed)}** (deltas are candidate - baseline)."
    )
    doc.table(["check", "result", "value", "threshold", "detail"], gate_rows(gate.checks))
    by_key = {c.key: c for c in cells}
    if gate.candidate in by_key and gate.baseline in by_key:
        cand, base = _suites(by_key[gate.candidate]), _suites(by_key[gate.baseline])
        doc.table(
            [
                "suite",
                "candidate success",
                "baseline success",
                "candidate clearance [m]",
                "baseline clearance [m]",
            ],
            [
                [
                    suite,
                    rate_text(cand[suite].success),
                    rate_text(base[suite].success),
                    mean_text(cand[suite].mean_min_clearance),
                    mean_text(base[suite].mean_min_clearance),
                ]
                for suite in ("hard", "global")
            ],
        )
    tax = gate.hard_taxonomy
    rows = [
        [k, tax.candidate.get(k, 0), tax.baseline.get(k, 0), f"{d:+d}"]
        for k, d in tax.delta.items()
        if d or tax.candidate.get(k) or tax.baseline.get(k)
    ]
    if rows:
        doc.table(["hard-suite label", "candidate", "baseline", "delta"], rows)
    if tax.new_labels:
        doc.text(f"New failure mechanisms on the hard suite: {', '.join(tax.new_labels)}.")


def _ab_pair(res: CampaignResult, cells: list[CellResult]) -> tuple[CellResult, CellResult] | None:
    """(A, B) = (gate baseline, gate candidate), else (rank 2, rank 1); None with fewer than two cells."""
    by_key = {c.key: c for c in cells}
    if (
        res.gate is not None
        and res.gate.baseline in by_key
        and res.gate.candidate in by_key
        and res.gate.baseline != res.gate.candidate
    ):
        return by_key[res.gate.baseline], by_key[res.gate.candidate]
    return (cells[1], cells[0]) if len(cells) >= 2 else None


def cell_run(
    workdir: Path, cell: CellResult, bootstrap_samples: int = 500
) -> tuple[ComparedRun, list] | None:
    """A cell's episodes (hard and global suites together) as a comparable run, with its records, from its
    episodes file."""
    if not existing(workdir, cell.episodes_file):
        return None
    from foresight.core.evaluation.aggregate import BootstrapConfig, aggregate
    from foresight.core.evaluation.runner import read_records

    records = read_records(workdir / cell.episodes_file)
    aggs = aggregate(records, BootstrapConfig(samples=bootstrap_samples))
    run = ComparedRun(
        planner=cell.planner, episodes=len(records), taxonomy=aggs.overall.taxonomy, aggregates=aggs
    )
    return run, records


def _ab(doc: Document, workdir: Path, res: CampaignResult, cells: list[CellResult]) -> None:
    from foresight.core.evaluation.delta import paired_deltas

    pair = _ab_pair(res, cells)
    doc.section("A/B: " + (f"{cell_name(pair[1])} vs {cell_name(pair[0])}" if pair else "best vs baseline"))
    if pair is None:
        doc.note("A single cell: nothing to compare.")
        return
    a, b = cell_run(workdir, pair[0]), cell_run(workdir, pair[1])
    if a is None or b is None:
        doc.note("The cells' episode files are not in this folder: no per-scenario comparison.")
        return
    doc.text(
        "Every episode of each cell (hard and global suites together); deltas are "
        f"{cell_name(pair[1])} - {cell_name(pair[0])}."
    )
    add_comparison(
        doc,
        a[0],
        b[0],
        workdir,
        (cell_name(pair[0]), cell_name(pair[1])),
        level=3,
        figure="campaign_ab.png",
        paired=paired_deltas(a[1], b[1]),
    )


def build_campaign_document(res: CampaignResult, workdir: Path) -> Document:
    cells = res.ranked
    doc = Document("Planner campaign")
    doc.section("Summary")
    best = res.best
    doc.text(
        f"Status **{res.status}** (exit code {res.exit_code}); {len(cells)} cells "
        f"(run {res.cells_run}, resumed {res.cells_resumed}); hard suite "
        f"{res.hard_episodes} episodes ({res.seed_manifest}), global suite "
        f"{res.global_episodes} episodes ({res.matrix}), horizon {res.horizon}, "
        f"grid {res.grid}, code `{res.code_version}`, {fmt(res.wall_s, 1, ' s')}."
    )
    if best:
        doc.text(
            f"Best: **{cell_name(best)}** (config `{best.planner.config_hash[:12]}`): "
            f"hard success {pct(best.hard.success.rate)}, global success {pct(best.global_.success.rate)}, "
            f"clearance {fmt(best.hard.mean_min_clearance.mean)} m (hard) / "
            f"{fmt(best.global_.mean_min_clearance.mean)} m (global)."
        )
    else:
        doc.note("No best cell.")
    _ranking(doc, workdir, cells)
    _taxonomy(doc, workdir, cells)
    _gate(doc, res, cells)
    _ab(doc, workdir, res, cells)
    doc.section("Artifacts")
    links = [(f"{k}: {v}", v) for k, v in res.artifacts.items()]
    links += [(f"episodes of {cell_name(c)}", c.episodes_file) for c in cells if c.episodes_file]
    doc.links(links + [("report (Markdown)", "report.md")])
    return doc


def write_campaign_report(result: Any, workdir: str | Path) -> list[Path]:
    """Write figures, ``report.md`` and ``report.html`` for a campaign under ``workdir``; returns their paths.

    ``result``: a :class:`CampaignResult`, its JSON dict or ``campaign_summary.json``.
    """
    workdir = Path(workdir)
    return publish(build_campaign_document(read(CampaignResult, result), workdir), workdir)
