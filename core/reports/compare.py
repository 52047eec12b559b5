"""A/B comparison of two evaluations: deltas of rates and means with intervals, per-scenario success side by
side, taxonomy counts, and a warning when the two runs are not comparable (other scenarios, seeds, horizon).

Rate deltas use Newcombe's hybrid score interval built from the two Wilson intervals (good at small n and
at 0 % / 100 %, where a normal approximation collapses). Mean deltas combine the two bootstrap intervals
the same way; that treats the runs as independent samples (labelled unpaired), so for paired runs (same
seeds) it is conservative: when the caller has both runs' records (campaign cells) the verdict uses the
paired tests instead (McNemar exact, Wilcoxon signed-rank; ``core.evaluation.delta.paired_deltas``).
Deltas are always B - A.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from pydantic import BaseModel

from foresight.core.evaluation.aggregate import Aggregates, GroupStats
from foresight.core.evaluation.delta import BINARY, Delta
from foresight.core.evaluation.evaluation_result import PlannerProvenance
from foresight.core.evaluation.stats import ALPHA, MIN_PAIRS, MeanEstimate, RateEstimate
from foresight.core.render.charts import Estimate, ab_chart
from foresight.core.reports.common import (
    figure_path,
    fmt,
    mean_est,
    mean_text,
    pct,
    publish,
    rate_est,
    rate_text,
    read,
)
from foresight.core.reports.document import Document

RATE_KEYS = ("success", "collision", "collision_pedestrian", "collision_static", "timeout")
MEAN_KEYS = {
    "min_clearance": "min clearance [m]",
    "avg_speed": "avg speed [m/s]",
    "time_to_goal_s": "time to goal [s]",
    "path_efficiency": "path efficiency",
    "near_misses": "near-miss steps",
    "plan_ms_mean": "planner time [ms]",
}


class ComparedRun(BaseModel):
    """What a comparison reads of a run: an EvaluationResult, or a campaign cell's episodes (no setup fields)."""

    planner: PlannerProvenance
    episodes: int
    taxonomy: dict[str, int]
    aggregates: Aggregates
    bundle: str | None = None
    matrix: str | None = None
    seed_source: str | None = None
    horizon: str | None = None

    def setup(self) -> dict[str, str | None]:
        """The fields two runs must share for their deltas to be planner effects."""
        return {
            "bundle": self.bundle,
            "matrix": self.matrix,
            "seed_source": self.seed_source,
            "horizon": self.horizon,
        }


def _combined(va: float, la: float, ha: float, vb: float, lb: float, hb: float) -> Estimate:
    d = vb - va
    return Estimate(d, d - math.hypot(vb - lb, ha - va), d + math.hypot(hb - vb, va - la))


def _delta(ea: Estimate, eb: Estimate) -> Estimate:
    if ea.value is None or eb.value is None:
        return Estimate(None)
    return _combined(
        ea.value,
        _or(ea.low, ea.value),
        _or(ea.high, ea.value),
        eb.value,
        _or(eb.low, eb.value),
        _or(eb.high, eb.value),
    )


def rate_delta(a: RateEstimate | None, b: RateEstimate | None) -> Estimate:
    """B - A of two Wilson RateEstimates with Newcombe's interval; value None when either is empty."""
    return _delta(rate_est(a), rate_est(b))


def mean_delta(a: MeanEstimate | None, b: MeanEstimate | None) -> Estimate:
    """B - A of two bootstrap MeanEstimates (half-widths combined in quadrature)."""
    return _delta(mean_est(a), mean_est(b))


def _or(x: float | None, default: float) -> float:
    return default if x is None else x


def _delta_text(e: Estimate, scale: float = 1.0, unit: str = "") -> str:
    if e.value is None:
        return "-"
    return f"{scale * e.value:+.2f}{unit} [{scale * (e.low or 0):+.2f}, {scale * (e.high or 0):+.2f}]"


def _success(group: GroupStats | None) -> RateEstimate | None:
    return None if group is None else group.rates["success"]


def build_comparison_document(
    a: ComparedRun, b: ComparedRun, workdir: Path, labels: tuple[str, str]
) -> Document:
    doc = Document(f"A/B comparison: {labels[0]} vs {labels[1]}")
    add_comparison(doc, a, b, workdir, labels)
    return doc


def add_comparison(
    doc: Document,
    a: ComparedRun,
    b: ComparedRun,
    workdir: Path,
    labels: tuple[str, str],
    *,
    level: int = 2,
    figure: str = "ab_comparison.png",
    paired: Mapping[str, Delta] | None = None,
) -> None:
    """Append the comparison sections (runs, metric deltas, per-scenario success, taxonomy, verdict) to ``doc``;
    ``paired``: the runs' paired deltas when they ran the same episodes."""
    la, lb = labels
    setup_a, setup_b = a.setup(), b.setup()
    doc.section("Runs", level)
    doc.table(
        ["", la, lb],
        [
            ["planner", a.planner.variant or a.planner.name, b.planner.variant or b.planner.name],
            ["config hash", a.planner.config_hash[:12], b.planner.config_hash[:12]],
            ["model", a.planner.model_id, b.planner.model_id],
            ["episodes", a.episodes, b.episodes],
            *[[k, setup_a[k] or "-", setup_b[k] or "-"] for k in setup_a],
        ],
    )
    differ = [k for k in setup_a if setup_a[k] != setup_b[k]]
    if differ:
        doc.text(
            f"**Warning**: the runs differ in {', '.join(differ)}; their deltas mix planner and setup effects."
        )
    oa, ob = a.aggregates.overall, b.aggregates.overall
    rates = {k: rate_delta(oa.rates[k], ob.rates[k]) for k in RATE_KEYS}
    means = {label: mean_delta(oa.means[k], ob.means[k]) for k, label in MEAN_KEYS.items()}
    sa = {g.key: g for g in a.aggregates.per_scenario}
    sb = {g.key: g for g in b.aggregates.per_scenario}
    names = list(dict.fromkeys([*sa, *sb]))
    path, rel = figure_path(workdir, figure)
    ab_chart(
        rates,
        means,
        names,
        [rate_est(_success(sa.get(n))) for n in names],
        [rate_est(_success(sb.get(n))) for n in names],
        path,
        labels=labels,
        title=f"{lb} - {la}",
    )
    doc.section("Metric deltas", level)
    doc.image(rel, f"Deltas {lb} - {la} with 95 % intervals, and per-scenario success side by side")
    doc.table(
        ["metric", la, lb, f"delta {lb} - {la} [95 % interval, unpaired]"],
        [
            [k, rate_text(oa.rates[k]), rate_text(ob.rates[k]), _delta_text(rates[k], 100, " pp")]
            for k in RATE_KEYS
        ]
        + [
            [label, mean_text(oa.means[k]), mean_text(ob.means[k]), _delta_text(means[label])]
            for k, label in MEAN_KEYS.items()
        ],
    )
    doc.section("Per-scenario success", level)
    doc.table(
        ["scenario", la, lb, "delta [pp]"],
        [
            [
                n,
                rate_text(_success(sa.get(n))),
                rate_text(_success(sb.get(n))),
                _delta_text(rate_delta(_success(sa.get(n)), _success(sb.get(n))), 100, " pp"),
            ]
            for n in names
        ],
    )
    doc.section("Failure taxonomy", level)
    ta, tb = a.taxonomy, b.taxonomy
    labels_all = [k for k in dict.fromkeys([*ta, *tb]) if ta.get(k, 0) or tb.get(k, 0)]
    if labels_all:
        doc.table(
            ["label", la, lb, "delta"],
            [[k, ta.get(k, 0), tb.get(k, 0), f"{tb.get(k, 0) - ta.get(k, 0):+d}"] for k in labels_all],
        )
    else:
        doc.note("Neither run had a failed episode.")
    if paired:
        doc.table(
            ["metric (paired)", "pairs", f"delta {lb} - {la} [95 % paired bootstrap]", "test", "p"],
            [
                [
                    k,
                    d.n_pairs,
                    _delta_text(Estimate(d.delta, d.low, d.high), 100 if k in BINARY else 1),
                    d.test or "-",
                    fmt(d.p_value, 3) + (" *" if d.significant else ""),
                ]
                for k, d in paired.items()
            ],
        )
    doc.section("Verdict", level)
    ps = (paired or {}).get("success")
    if ps is not None and ps.p_value is not None:
        disc = ps.discordant or (0, 0)
        verdict_text = (
            "a significant difference"
            if ps.significant
            else f"no significant difference (p < {ALPHA} with at least {MIN_PAIRS} pairs needed)"
        )
        doc.text(
            f"Success {pct(oa.rates['success'].rate)} ({la}) vs {pct(ob.rates['success'].rate)} ({lb}), paired on "
            f"{ps.n_pairs} episodes: delta {_delta_text(Estimate(ps.delta, ps.low, ps.high), 100, ' pp')}; "
            f"{disc[1]} succeed only with {lb}, {disc[0]} only with {la}; McNemar exact "
            f"p = {fmt(ps.p_value, 3)}: {verdict_text}. Clearance delta "
            f"{fmt(means['min clearance [m]'].value, 2, ' m')}."
        )
        return
    d = rates["success"]
    sig = d.value is not None and d.low is not None and d.high is not None and (d.low > 0 or d.high < 0)
    doc.text(
        f"Success {pct(oa.rates['success'].rate)} ({la}) vs {pct(ob.rates['success'].rate)} ({lb}): "
        f"delta {_delta_text(d, 100, ' pp')}, "
        + (
            "the interval excludes 0 (unpaired)."
            if sig
            else "the interval includes 0 (unpaired; no clear difference at this sample size)."
        )
        + f" Clearance delta {fmt(means['min clearance [m]'].value, 2, ' m')}."
    )


def write_comparison_report(
    a: Any, b: Any, workdir: str | Path, *, labels: tuple[str, str] = ("A", "B"), stem: str = "report"
) -> list[Path]:
    """Compare two evaluation results (models, dicts or evaluation.json paths); writes figure + report files."""
    workdir = Path(workdir)
    doc = build_comparison_document(read(ComparedRun, a), read(ComparedRun, b), workdir, labels)
    return publish(doc, workdir, stem)
