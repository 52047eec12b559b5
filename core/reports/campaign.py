"""Campaign report: cells ranked in the reference order with hard and global success (intervals), clearances,
hard-suite failure mechanisms per cell, and the closed-loop gate against the baseline variant.

Input: the ``campaign`` stage's result (``CampaignResult``, its dict or ``campaign_summary.json``).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from foresight.core.render.charts import ranking_chart, taxonomy_bars
from foresight.core.reports.common import (
    as_dict,
    existing,
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
from foresight.core.reports.compare import add_comparison
from foresight.core.reports.document import Document


def glob_suite(cell: Mapping[str, Any]) -> Mapping[str, Any]:
    """The global suite of a serialised cell (``global`` by alias, ``global_`` by field name)."""
    return cell.get("global") or cell.get("global_") or {}


def cell_name(cell: Mapping[str, Any]) -> str:
    ck = cell.get("checkpoint")
    return f"{cell.get('variant', '?')} @ {ck}" if ck else str(cell.get("variant", "?"))


def _clearances(cell: Mapping[str, Any]) -> str:
    return (f"clr {fmt((cell.get('hard') or {}).get('mean_min_clearance', {}).get('mean'))} / "
            f"{fmt(glob_suite(cell).get('mean_min_clearance', {}).get('mean'))} m")


def _ranking(doc: Document, workdir: Path, cells: list[Mapping[str, Any]]) -> None:
    doc.section("Ranking")
    doc.text("Order: descending lexicographic on (hard success, global success, hard clearance, global clearance, "
             "global average speed); cells with integrity violations rank last.")
    if not cells:
        doc.note("No cells were run.")
        return
    path, rel = figure_path(workdir, "campaign_ranking.png")
    ranking_chart([cell_name(c) for c in cells], [rate_est((c.get("hard") or {}).get("success")) for c in cells],
                  [rate_est(glob_suite(c).get("success")) for c in cells], path,
                  notes=[_clearances(c) + " (hard / global)" for c in cells], title="Campaign ranking")
    doc.image(rel, "Cells in rank order: hard-suite and global success with 95 % Wilson intervals")
    doc.table(["rank", "variant", "checkpoint", "hard success", "global success", "hard clearance [m]",
               "global clearance [m]", "global speed [m/s]", "global collisions", "integrity"],
              [[i, c.get("variant"), c.get("checkpoint"), rate_text((c.get("hard") or {}).get("success")),
                rate_text(glob_suite(c).get("success")), mean_text((c.get("hard") or {}).get("mean_min_clearance")),
                mean_text(glob_suite(c).get("mean_min_clearance")), mean_text(glob_suite(c).get("mean_avg_speed")),
                rate_text(glob_suite(c).get("collision")), "ok" if (c.get("integrity") or {}).get("ok") else "VIOLATIONS"]
               for i, c in enumerate(cells, start=1)])


def _taxonomy(doc: Document, workdir: Path, cells: list[Mapping[str, Any]]) -> None:
    doc.section("Hard-suite failure taxonomy")
    groups = {cell_name(c): (c.get("hard") or {}).get("taxonomy") or {} for c in cells}
    if not any(sum(g.values()) for g in groups.values()):
        doc.note("No cell failed a hard-suite episode.")
        return
    path, rel = figure_path(workdir, "campaign_taxonomy.png")
    taxonomy_bars(groups, path, title="Hard-suite failure mechanisms per cell")
    doc.image(rel, "Failed hard-suite episodes per cell by primary taxonomy label")
    labels = [k for k in dict.fromkeys(k for g in groups.values() for k in g) if any(g.get(k) for g in groups.values())]
    doc.table(["cell", *labels], [[name, *[g.get(k, 0) for k in labels]] for name, g in groups.items()])


def _gate(doc: Document, res: Mapping[str, Any], cells: list[Mapping[str, Any]]) -> None:
    doc.section("Closed-loop gate")
    gate = res.get("gate")
    if not gate:
        doc.note("No closed-loop gate configured for this campaign.")
        return
    doc.text(f"Candidate `{gate.get('candidate')}` against baseline `{gate.get('baseline')}`: "
             f"**{verdict(gate.get('passed'))}** (deltas are candidate - baseline).")
    doc.table(["check", "result", "value", "threshold", "detail"], gate_rows(gate.get("checks") or []))
    by_key = {c.get("key"): c for c in cells}
    cand, base = by_key.get(gate.get("candidate")), by_key.get(gate.get("baseline"))
    if cand and base:
        doc.table(["suite", "candidate success", "baseline success", "candidate clearance [m]", "baseline clearance [m]"],
                  [[suite, rate_text(get(cand).get("success")), rate_text(get(base).get("success")),
                    mean_text(get(cand).get("mean_min_clearance")), mean_text(get(base).get("mean_min_clearance"))]
                   for suite, get in (("hard", lambda c: c.get("hard") or {}), ("global", glob_suite))])
    tax = gate.get("hard_taxonomy") or {}
    rows = [[k, (tax.get("candidate") or {}).get(k, 0), (tax.get("baseline") or {}).get(k, 0), f"{d:+d}"]
            for k, d in (tax.get("delta") or {}).items()
            if d or (tax.get("candidate") or {}).get(k) or (tax.get("baseline") or {}).get(k)]
    if rows:
        doc.table(["hard-suite label", "candidate", "baseline", "delta"], rows)
    if tax.get("new_labels"):
        doc.text(f"New failure mechanisms on the hard suite: {', '.join(tax['new_labels'])}.")


def _ab_pair(res: Mapping[str, Any], cells: list[Mapping[str, Any]]) -> tuple[Mapping, Mapping] | None:
    """(A, B) = (gate baseline, gate candidate), else (rank 2, rank 1); None with fewer than two cells."""
    by_key = {c.get("key"): c for c in cells}
    gate = res.get("gate") or {}
    base, cand = by_key.get(gate.get("baseline")), by_key.get(gate.get("candidate"))
    if base is not None and cand is not None and base is not cand:
        return base, cand
    return (cells[1], cells[0]) if len(cells) >= 2 else None


def cell_run(workdir: Path, cell: Mapping[str, Any], bootstrap_samples: int = 500) -> dict[str, Any] | None:
    """An evaluation-like dict of a cell's episodes (hard and global suites together), from its episodes file."""
    if not existing(workdir, cell.get("episodes_file")):
        return None
    from foresight.core.evaluation.aggregate import BootstrapConfig, aggregate
    from foresight.core.evaluation.runner import read_records

    records = read_records(workdir / cell["episodes_file"])
    aggs = aggregate(records, BootstrapConfig(samples=bootstrap_samples))
    return {"planner": cell.get("planner") or {}, "episodes": len(records), "taxonomy": aggs.overall.taxonomy,
            "aggregates": aggs.model_dump(mode="json")}


def _ab(doc: Document, workdir: Path, res: Mapping[str, Any], cells: list[Mapping[str, Any]]) -> None:
    pair = _ab_pair(res, cells)
    doc.section("A/B: " + (f"{cell_name(pair[1])} vs {cell_name(pair[0])}" if pair else "best vs baseline"))
    if pair is None:
        doc.note("A single cell: nothing to compare.")
        return
    runs = [cell_run(workdir, c) for c in pair]
    if runs[0] is None or runs[1] is None:
        doc.note("The cells' episode files are not in this folder: no per-scenario comparison.")
        return
    doc.text("Every episode of each cell (hard and global suites together); deltas are "
             f"{cell_name(pair[1])} - {cell_name(pair[0])}.")
    add_comparison(doc, runs[0], runs[1], workdir, (cell_name(pair[0]), cell_name(pair[1])), level=3,
                   figure="campaign_ab.png")


def build_campaign_document(res: Mapping[str, Any], workdir: Path) -> Document:
    cells = list(res.get("ranked") or [])
    doc = Document("Planner campaign")
    doc.section("Summary")
    best = res.get("best")
    doc.text(f"Status **{res.get('status', '?')}** (exit code {res.get('exit_code', '?')}); {len(cells)} cells "
             f"(run {res.get('cells_run', '?')}, resumed {res.get('cells_resumed', '?')}); hard suite "
             f"{res.get('hard_episodes', '?')} episodes ({res.get('seed_manifest', '?')}), global suite "
             f"{res.get('global_episodes', '?')} episodes ({res.get('matrix', '?')}), horizon {res.get('horizon', '?')}, "
             f"grid {res.get('grid', '?')}, code `{res.get('code_version', '?')}`, {fmt(res.get('wall_s'), 1, ' s')}.")
    if best:
        doc.text(f"Best: **{cell_name(best)}** (config `{str((best.get('planner') or {}).get('config_hash', '?'))[:12]}`): "
                 f"hard success {pct((best.get('hard') or {}).get('success', {}).get('rate'))}, global success "
                 f"{pct(glob_suite(best).get('success', {}).get('rate'))}, clearance "
                 f"{fmt((best.get('hard') or {}).get('mean_min_clearance', {}).get('mean'))} m (hard) / "
                 f"{fmt(glob_suite(best).get('mean_min_clearance', {}).get('mean'))} m (global).")
    else:
        doc.note("No best cell.")
    _ranking(doc, workdir, cells)
    _taxonomy(doc, workdir, cells)
    _gate(doc, res, cells)
    _ab(doc, workdir, res, cells)
    doc.section("Artifacts")
    links = [(f"{k}: {v}", v) for k, v in (res.get("artifacts") or {}).items()]
    links += [(f"episodes of {cell_name(c)}", c["episodes_file"]) for c in cells if c.get("episodes_file")]
    doc.links(links + [("report (Markdown)", "report.md")])
    return doc


def write_campaign_report(result: Any, workdir: str | Path) -> list[Path]:
    """Write figures, ``report.md`` and ``report.html`` for a campaign under ``workdir``; returns their paths."""
    workdir = Path(workdir)
    return publish(build_campaign_document(as_dict(result), workdir), workdir)
