"""A campaign's text report (``campaign_report.md``): the ranked cells, paired deltas vs the baseline, the gate."""

from __future__ import annotations

from foresight.core.evaluation.campaign_result import CampaignResult
from foresight.core.evaluation.delta import Delta
from foresight.core.evaluation.stats import ALPHA, MIN_PAIRS


def _pct(x: float | None) -> str:
    return "-" if x is None else f"{100 * x:.1f}%"


def _m(x: float | None) -> str:
    return "-" if x is None else f"{x:.2f}"


def _paired_text(d: Delta, scale: float = 1.0, unit: str = "") -> str:
    if d.delta is None:
        return "-"
    return f"{scale * d.delta:+.2f}{unit} [{scale * (d.low or 0):+.2f}, {scale * (d.high or 0):+.2f}]"


def _p_text(d: Delta) -> str:
    if d.p_value is None:
        return "-"
    disc = f" ({d.discordant[0]}/{d.discordant[1]})" if d.discordant else ""
    return f"{d.p_value:.3g}{disc}{' *' if d.significant else ''}"


def report(res: CampaignResult) -> str:
    lines = ["# Planner campaign", ""]
    if res.best:
        b = res.best
        lines += [
            f"Best: **{b.variant}** with checkpoint `{b.checkpoint}` (config {b.planner.config_hash[:12]}): "
            f"hard success {_pct(b.hard.success.rate)}, global success {_pct(b.global_.success.rate)}.",
            "",
        ]
        if res.best_vs_reference:
            lines += [
                "Best vs reference cell, resolved config keys (best, reference): "
                + "; ".join(f"`{k}` {v[0]} vs {v[1]}" for k, v in res.best_vs_reference.items()),
                "",
            ]
    lines += [
        f"Hard suite {res.hard_episodes} episodes ({res.seed_manifest}), global suite {res.global_episodes} "
        f"episodes ({res.matrix}), horizon {res.horizon}. Cells run {res.cells_run}, resumed {res.cells_resumed}.",
        "",
        "| rank | variant | checkpoint | hard success | global success | hard clearance [m] | "
        "global clearance [m] | global speed [m/s] | global collisions | integrity |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for i, c in enumerate(res.ranked, start=1):
        lines.append(
            f"| {i} | {c.variant} | {c.checkpoint} | {_pct(c.hard.success.rate)} | "
            f"{_pct(c.global_.success.rate)} | {_m(c.hard.mean_min_clearance.mean)} | "
            f"{_m(c.global_.mean_min_clearance.mean)} | {_m(c.global_.mean_avg_speed.mean)} | "
            f"{_pct(c.global_.collision.rate)} | {'ok' if c.integrity.ok else 'VIOLATIONS'} |"
        )
    lines.append("")
    paired = [c for c in res.ranked if c.vs_baseline]
    if paired:
        lines += [
            f"Paired against the baseline cell of the same checkpoint (same episodes; McNemar exact for success, "
            f"Wilcoxon signed-rank for clearance; * = p < {ALPHA} with at least {MIN_PAIRS} pairs):",
            "",
            "| variant | checkpoint | suite | success delta [95 %] | McNemar p (discordant base/variant) | "
            "clearance delta [m] | Wilcoxon p |",
            "|---|---|---|---|---|---|---|",
        ]
        for c in paired:
            for suite, d in (c.vs_baseline or {}).items():
                if d:
                    lines.append(
                        f"| {c.variant} | {c.checkpoint} | {suite} | {_paired_text(d['success'], 100, ' pp')} | "
                        f"{_p_text(d['success'])} | {_paired_text(d['min_clearance'])} | "
                        f"{_p_text(d['min_clearance'])} |"
                    )
        lines.append("")
    if res.gate is None:
        lines.append("No closed-loop gate configured.")
    else:
        g = res.gate
        lines += [f"Closed-loop gate vs `{g.baseline}`: **{'passed' if g.passed else 'FAILED'}**", ""]
        lines += [
            f"- {c.name}: {'ok' if c.passed else 'FAIL'} (value {_m(c.value)}, threshold {_m(c.threshold)})"
            for c in g.checks
        ]
        delta = ", ".join(f"{k} {v:+d}" for k, v in g.hard_taxonomy.delta.items() if v)
        lines.append(f"- hard-suite taxonomy delta vs baseline: {delta or 'none'}")
    return "\n".join(lines) + "\n"
