"""A/B comparison of two evaluations: deltas of rates and means with intervals, per-scenario success side by
side, taxonomy counts, and a warning when the two runs are not comparable (other scenarios, seeds, horizon).

Rate deltas use Newcombe's hybrid score interval built from the two Wilson intervals (good at small n and
at 0 % / 100 %, where a normal approximation collapses). Mean deltas combine the two bootstrap intervals
the same way; that treats the runs as independent samples, so for paired runs (same seeds) it is
conservative. Deltas are always B - A.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from foresight.core.render.charts import Estimate, ab_chart
from foresight.core.reports.common import (
    as_dict,
    figure_path,
    fmt,
    mean_text,
    num,
    pct,
    publish,
    rate_est,
    rate_text,
)
from foresight.core.reports.document import Document

RATE_KEYS = ("success", "collision", "collision_pedestrian", "collision_static", "timeout")
MEAN_KEYS = {"min_clearance": "min clearance [m]", "avg_speed": "avg speed [m/s]",
             "time_to_goal_s": "time to goal [s]", "path_efficiency": "path efficiency",
             "near_misses": "near-miss steps", "plan_ms_mean": "planner time [ms]"}
COMPARABLE = ("bundle", "matrix", "seed_source", "horizon")


def _combined(va: float, la: float, ha: float, vb: float, lb: float, hb: float) -> Estimate:
    d = vb - va
    return Estimate(d, d - math.hypot(vb - lb, ha - va), d + math.hypot(hb - vb, va - la))


def rate_delta(a: Mapping[str, Any] | None, b: Mapping[str, Any] | None) -> Estimate:
    """B - A of two serialised Wilson RateEstimates with Newcombe's interval; value None when either is empty."""
    ea, eb = rate_est(a), rate_est(b)
    if ea.value is None or eb.value is None:
        return Estimate(None)
    return _combined(ea.value, _or(ea.low, ea.value), _or(ea.high, ea.value),
                     eb.value, _or(eb.low, eb.value), _or(eb.high, eb.value))


def mean_delta(a: Mapping[str, Any] | None, b: Mapping[str, Any] | None) -> Estimate:
    """B - A of two serialised bootstrap MeanEstimates (half-widths combined in quadrature)."""
    va, vb = num((a or {}).get("mean")), num((b or {}).get("mean"))
    if va is None or vb is None:
        return Estimate(None)
    return _combined(va, _or(num(a.get("low")), va), _or(num(a.get("high")), va),
                     vb, _or(num(b.get("low")), vb), _or(num(b.get("high")), vb))


def _or(x: float | None, default: float) -> float:
    return default if x is None else x


def _delta_text(e: Estimate, scale: float = 1.0, unit: str = "") -> str:
    if e.value is None:
        return "-"
    return f"{scale * e.value:+.2f}{unit} [{scale * (e.low or 0):+.2f}, {scale * (e.high or 0):+.2f}]"


def _overall(res: Mapping[str, Any]) -> Mapping[str, Any]:
    return (res.get("aggregates") or {}).get("overall") or {}


def _scenarios(res: Mapping[str, Any]) -> dict[str, Mapping[str, Any]]:
    return {g["key"]: g for g in (res.get("aggregates") or {}).get("per_scenario") or []}


def _name(res: Mapping[str, Any], fallback: str) -> str:
    p = res.get("planner") or {}
    return str(p.get("variant") or p.get("name") or fallback)


def build_comparison_document(a: Mapping[str, Any], b: Mapping[str, Any], workdir: Path,
                              labels: tuple[str, str]) -> Document:
    doc = Document(f"A/B comparison: {labels[0]} vs {labels[1]}")
    add_comparison(doc, a, b, workdir, labels)
    return doc


def add_comparison(doc: Document, a: Mapping[str, Any], b: Mapping[str, Any], workdir: Path,
                   labels: tuple[str, str], *, level: int = 2, figure: str = "ab_comparison.png") -> None:
    """Append the comparison sections (runs, metric deltas, per-scenario success, taxonomy, verdict) to ``doc``.

    ``a``/``b``: evaluation-like dicts (``planner``, ``episodes``, ``aggregates``, ``taxonomy``).
    """
    la, lb = labels
    doc.section("Runs", level)
    doc.table(["", la, lb], [
        ["planner", _name(a, la), _name(b, lb)],
        ["config hash", str((a.get("planner") or {}).get("config_hash", "-"))[:12],
         str((b.get("planner") or {}).get("config_hash", "-"))[:12]],
        ["model", (a.get("planner") or {}).get("model_id", "-"), (b.get("planner") or {}).get("model_id", "-")],
        ["episodes", a.get("episodes", "-"), b.get("episodes", "-")],
        *[[k, a.get(k, "-"), b.get(k, "-")] for k in COMPARABLE],
    ])
    differ = [k for k in COMPARABLE if a.get(k) != b.get(k)]
    if differ:
        doc.text(f"**Warning**: the runs differ in {', '.join(differ)}; their deltas mix planner and setup effects.")
    oa, ob = _overall(a), _overall(b)
    rates = {k: rate_delta((oa.get("rates") or {}).get(k), (ob.get("rates") or {}).get(k)) for k in RATE_KEYS}
    means = {label: mean_delta((oa.get("means") or {}).get(k), (ob.get("means") or {}).get(k))
             for k, label in MEAN_KEYS.items()}
    sa, sb = _scenarios(a), _scenarios(b)
    names = list(dict.fromkeys([*sa, *sb]))
    path, rel = figure_path(workdir, figure)
    ab_chart(rates, means, names, [rate_est((sa.get(n) or {}).get("rates", {}).get("success")) for n in names],
             [rate_est((sb.get(n) or {}).get("rates", {}).get("success")) for n in names], path, labels=labels,
             title=f"{lb} - {la}")
    doc.section("Metric deltas", level)
    doc.image(rel, f"Deltas {lb} - {la} with 95 % intervals, and per-scenario success side by side")
    doc.table(["metric", la, lb, f"delta {lb} - {la} [95 % interval]"],
              [[k, rate_text((oa.get("rates") or {}).get(k)), rate_text((ob.get("rates") or {}).get(k)),
                _delta_text(rates[k], 100, " pp")] for k in RATE_KEYS]
              + [[label, mean_text((oa.get("means") or {}).get(k)), mean_text((ob.get("means") or {}).get(k)),
                  _delta_text(means[label])] for k, label in MEAN_KEYS.items()])
    doc.section("Per-scenario success", level)
    doc.table(["scenario", la, lb, "delta [pp]"],
              [[n, rate_text((sa.get(n) or {}).get("rates", {}).get("success")),
                rate_text((sb.get(n) or {}).get("rates", {}).get("success")),
                _delta_text(rate_delta((sa.get(n) or {}).get("rates", {}).get("success"),
                                       (sb.get(n) or {}).get("rates", {}).get("success")), 100, " pp")]
               for n in names])
    doc.section("Failure taxonomy", level)
    ta, tb = a.get("taxonomy") or {}, b.get("taxonomy") or {}
    labels_all = [k for k in dict.fromkeys([*ta, *tb]) if ta.get(k, 0) or tb.get(k, 0)]
    if labels_all:
        doc.table(["label", la, lb, "delta"],
                  [[k, ta.get(k, 0), tb.get(k, 0), f"{tb.get(k, 0) - ta.get(k, 0):+d}"] for k in labels_all])
    else:
        doc.note("Neither run had a failed episode.")
    doc.section("Verdict", level)
    sa_rate, sb_rate = (oa.get("rates") or {}).get("success"), (ob.get("rates") or {}).get("success")
    d = rates["success"]
    sig = d.value is not None and d.low is not None and d.high is not None and (d.low > 0 or d.high < 0)
    doc.text(f"Success {pct((sa_rate or {}).get('rate'))} ({la}) vs {pct((sb_rate or {}).get('rate'))} ({lb}): "
             f"delta {_delta_text(d, 100, ' pp')}, "
             + ("the interval excludes 0." if sig else "the interval includes 0 (no clear difference at this sample size).")
             + f" Clearance delta {fmt(means['min clearance [m]'].value, 2, ' m')}.")


def write_comparison_report(a: Any, b: Any, workdir: str | Path, *, labels: tuple[str, str] = ("A", "B"),
                            stem: str = "report") -> list[Path]:
    """Compare two evaluation results (models, dicts or evaluation.json paths); writes figure + report files."""
    workdir = Path(workdir)
    return publish(build_comparison_document(as_dict(a), as_dict(b), workdir, labels), workdir, stem)
