"""Campaign metrics against planner-grid parameters: which resolved-config keys the grid varied, and an SVG
line chart per parameter and metric (success, collision), one line per checkpoint and suite with 95 % intervals.

The varied parameters are read off the cells' fully resolved planner configs (keys whose values differ between
cells), not off the grid file, so a grid given inline, as a file or through reference parameters plots the same.
A grid whose variants differ in no planner key (or only in text values) is plotted against the variant name.
SVG text is built here (no browser library, no CDN) and escaped; the dashboard inlines it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from html import escape
from typing import Any

from foresight.core.evaluation.aggregate import SuiteSummary

SUITES = ("global", "hard")
METRICS = ("success", "collision")
PALETTE = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf")
VARIANT_AXIS = "variant"  #: the x axis when no planner key varies numerically


@dataclass(frozen=True)
class GridCell:
    """One campaign cell: its checkpoint, variant, resolved planner config and suite summaries."""

    checkpoint: str
    variant: str
    config: dict[str, Any]
    suites: dict[str, SuiteSummary]


@dataclass
class Point:
    x: float
    rate: float | None
    low: float | None
    high: float | None
    variant: str
    n: int


@dataclass
class Series:
    checkpoint: str
    suite: str
    points: list[Point] = field(default_factory=list)


@dataclass
class ParameterPlot:
    """One varied parameter: its values' axis (numeric, or ``ticks`` for named positions) and per metric the
    series (checkpoint x suite)."""

    parameter: str
    ticks: list[tuple[float, str]]
    series: dict[str, list[Series]]


def flatten(config: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """``{"a": {"b": 1}}`` -> ``{"a.b": 1}`` (lists stay values)."""
    out: dict[str, Any] = {}
    for key, value in config.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            out.update(flatten(value, name + "."))
        else:
            out[name] = value
    return out


def _number(value: Any) -> float | None:
    if isinstance(value, bool):
        return float(value)
    return float(value) if isinstance(value, (int, float)) else None


def varied_parameters(cells: list[GridCell]) -> list[str]:
    """Resolved-config keys with more than one value among the cells, numeric (or boolean) in every cell."""
    flat = [flatten(c.config) for c in cells]
    keys = sorted({k for f in flat for k in f})
    out = []
    for key in keys:
        values = [f.get(key) for f in flat]
        if all(_number(v) is not None for v in values) and len({_number(v) for v in values}) > 1:
            out.append(key)
    return out


def parameter_plots(cells: list[GridCell]) -> list[ParameterPlot]:
    """A plot per varied parameter (or one against the variant name when none varies numerically)."""
    params = varied_parameters(cells)
    plots = []
    names = list(dict.fromkeys(c.variant for c in cells))
    for param in params or [VARIANT_AXIS]:
        if param == VARIANT_AXIS:  # named positions 0, 1, ... in first-seen order
            x_at = {id(c): float(names.index(c.variant)) for c in cells}
            ticks = [(float(i), n) for i, n in enumerate(names)]
        else:
            x_at = {id(c): _number(flatten(c.config)[param]) for c in cells}
            ticks = []
        series: dict[str, list[Series]] = {}
        for metric in METRICS:
            lines: dict[tuple[str, str], Series] = {}
            for cell in cells:
                for suite in SUITES:
                    summary = cell.suites.get(suite)
                    if summary is None:
                        continue
                    est = getattr(summary, metric)
                    line = lines.setdefault((cell.checkpoint, suite), Series(cell.checkpoint, suite))
                    line.points.append(
                        Point(x_at[id(cell)], est.rate, est.low, est.high, cell.variant, est.n)
                    )
            for line in lines.values():
                line.points.sort(key=lambda p: p.x)
            series[metric] = list(lines.values())
        plots.append(ParameterPlot(param, ticks, series))
    return plots


# ----------------------------------------------------------------------------------------------- SVG

W, H = 460, 280  #: [px] chart size
LEFT, RIGHT, TOP, BOTTOM = 52, 150, 28, 46  #: [px] margins (the legend sits on the right)


def _fmt(x: float) -> str:
    return f"{x:.4g}"


def chart_svg(plot: ParameterPlot, metric: str) -> str:
    """One chart: ``metric`` rate (0-100 %) against the parameter, a line per checkpoint x suite (global solid,
    hard dashed), 95 % interval bars, a tooltip per point (variant, value, rate, n)."""
    lines = plot.series.get(metric, [])
    xs = [p.x for s in lines for p in s.points]
    lo, hi = (min(xs), max(xs)) if xs else (0.0, 1.0)
    pad = (hi - lo) * 0.08 or 0.5
    lo, hi = lo - pad, hi + pad
    pw, ph = W - LEFT - RIGHT, H - TOP - BOTTOM
    # the legend's room from its longest label (10 px text: about 6 px a character) and its number of rows, so
    # long checkpoint names and many series are drawn whole rather than cut at the picture's edge
    labels = [f"{s.checkpoint} · {s.suite}" for s in lines]
    width = LEFT + pw + max(RIGHT, 44 + 6 * max((len(t) for t in labels), default=0))
    height = max(H, TOP + 14 * len(lines) + 16)

    def px(x: float) -> float:
        return LEFT + (x - lo) / (hi - lo) * pw

    def py(y: float) -> float:
        return TOP + (1.0 - y) * ph

    title = f"{metric} rate vs {plot.parameter}"
    out = [
        f'<svg xmlns="http://www.w3.org/2000/svg" class="grid-chart" data-parameter="{escape(plot.parameter)}" '
        f'data-metric="{metric}" width="{width}" height="{height}" viewBox="0 0 {width} {height}" role="img" '
        f'aria-label="{escape(title)}">',
        f'<text x="{LEFT}" y="16" font-size="13" font-weight="bold">{escape(title)}</text>',
        f'<rect x="{LEFT}" y="{TOP}" width="{pw}" height="{ph}" fill="none" stroke="#999"/>',
    ]
    for y in (0.0, 0.25, 0.5, 0.75, 1.0):
        out.append(
            f'<line x1="{LEFT}" x2="{LEFT + pw}" y1="{py(y):.1f}" y2="{py(y):.1f}" stroke="#ddd"/>'
            f'<text x="{LEFT - 6}" y="{py(y) + 4:.1f}" font-size="10" text-anchor="end">{100 * y:.0f} %</text>'
        )
    ticks = plot.ticks or [(x, _fmt(x)) for x in sorted(set(xs))]
    for x, label in ticks:
        out.append(
            f'<line x1="{px(x):.1f}" x2="{px(x):.1f}" y1="{TOP + ph}" y2="{TOP + ph + 4}" stroke="#666"/>'
            f'<text x="{px(x):.1f}" y="{TOP + ph + 16}" font-size="10" text-anchor="middle">{escape(label)}</text>'
        )
    out.append(
        f'<text x="{LEFT + pw / 2}" y="{H - 8}" font-size="11" text-anchor="middle">{escape(plot.parameter)}</text>'
    )
    checkpoints = list(dict.fromkeys(s.checkpoint for s in lines))
    for i, s in enumerate(lines):
        colour = PALETTE[checkpoints.index(s.checkpoint) % len(PALETTE)]
        dash = ' stroke-dasharray="5 3"' if s.suite == "hard" else ""
        known = [p for p in s.points if p.rate is not None]
        if len(known) > 1:
            path = " ".join(f"{px(p.x):.1f},{py(p.rate):.1f}" for p in known)
            out.append(
                f'<polyline class="series" points="{path}" fill="none" stroke="{colour}" stroke-width="2"{dash}/>'
            )
        for p in known:
            if p.low is not None and p.high is not None:
                out.append(
                    f'<line x1="{px(p.x):.1f}" x2="{px(p.x):.1f}" y1="{py(p.low):.1f}" y2="{py(p.high):.1f}" '
                    f'stroke="{colour}" stroke-opacity="0.5"/>'
                )
            tip = (
                f"{p.variant} @ {s.checkpoint}, {s.suite} suite: {plot.parameter} = {_fmt(p.x) if not plot.ticks else p.variant}, "
                f"{metric} {100 * p.rate:.1f} % [{100 * (p.low or 0):.1f}, {100 * (p.high or 0):.1f}] of {p.n}"
            )
            shape = "rect" if s.suite == "hard" else "circle"
            mark = (
                f'<rect x="{px(p.x) - 3.5:.1f}" y="{py(p.rate) - 3.5:.1f}" width="7" height="7"'
                if shape == "rect"
                else f'<circle cx="{px(p.x):.1f}" cy="{py(p.rate):.1f}" r="4"'
            )
            out.append(f'{mark} class="point" fill="{colour}"><title>{escape(tip)}</title></{shape}>')
        ly = TOP + 14 * i + 6
        out.append(
            f'<line x1="{LEFT + pw + 10}" x2="{LEFT + pw + 30}" y1="{ly}" y2="{ly}" stroke="{colour}" stroke-width="2"{dash}/>'
            f'<text x="{LEFT + pw + 34}" y="{ly + 4}" font-size="10">{escape(s.checkpoint)} · {s.suite}</text>'
        )
    out.append("</svg>")
    return "".join(out)
