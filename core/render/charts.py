"""Result charts (PNG): training curves, rate bars with intervals, failure taxonomy, campaign ranking, A/B view.

Charts take plain numbers (lists, mappings, :class:`Estimate`), not stage result models, so that the
reports can feed them from JSON written by any version of a stage, and a test can feed them by hand.
Missing values (``None``) are drawn as empty bars, never as zero-height bars mistaken for a 0 % rate.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from foresight.core.render.figure import DPI, save

SERIES_COLOURS = ("tab:green", "tab:red", "tab:blue", "tab:orange", "tab:purple", "tab:gray")
#: fixed colour per taxonomy label, so that every chart of every run uses the same colours
LABEL_COLOURS = {
    "collision_pedestrian_robot_fault": "#d62728",
    "collision_pedestrian_pedestrian_fault": "#ff9896",
    "collision_static": "#8c564b",
    "out_of_bounds": "#c49c94",
    "timeout_freeze": "#1f77b4",
    "timeout_oscillation": "#9467bd",
    "timeout_slow_progress": "#aec7e8",
    "planner_error": "#7f7f7f",
}


@dataclass(frozen=True)
class Estimate:
    """A value with an optional interval (e.g. a Wilson or bootstrap 95 % interval); None = not available."""

    value: float | None
    low: float | None = None
    high: float | None = None

    @classmethod
    def of(cls, d: Mapping[str, Any] | None, key: str = "rate") -> Estimate:
        """From a serialised RateEstimate (``rate``) or MeanEstimate (``mean``) dict."""
        if not d:
            return cls(None)
        value = d.get(key, d.get("value"))
        return cls(_num(value), _num(d.get("low")), _num(d.get("high")))


def _num(x: Any) -> float | None:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def _figure(width_in: float, height_in: float, ncols: int = 1) -> tuple[Figure, list[Axes]]:
    fig = Figure(figsize=(width_in, height_in), dpi=DPI)
    FigureCanvasAgg(fig)
    axes = [fig.add_subplot(1, ncols, i + 1) for i in range(ncols)]
    return fig, axes


def _errors(est: Sequence[Estimate]) -> tuple[np.ndarray, np.ndarray]:
    """Bar values (NaN for None) and asymmetric error extents (2, n) (0 where the interval is unknown)."""
    vals = np.array([np.nan if e.value is None else e.value for e in est], dtype=float)
    lo = np.array([0.0 if e.low is None or e.value is None else max(e.value - e.low, 0.0) for e in est])
    hi = np.array([0.0 if e.high is None or e.value is None else max(e.high - e.value, 0.0) for e in est])
    return vals, np.vstack([lo, hi])


def _hbars(
    ax: Axes,
    labels: Sequence[str],
    series: Mapping[str, Sequence[Estimate]],
    colours: Sequence[str] = SERIES_COLOURS,
) -> None:
    """Grouped horizontal bars (first label on top) with interval whiskers; "n/a" where a value is missing."""
    n, k = len(labels), max(len(series), 1)
    height = 0.8 / k
    y = np.arange(n)
    for j, (name, est) in enumerate(series.items()):
        vals, err = _errors(est)
        pos = y - 0.4 + height * (j + 0.5)
        ax.barh(
            pos,
            np.nan_to_num(vals),
            height=height,
            xerr=err,
            color=colours[j % len(colours)],
            label=name,
            error_kw={"elinewidth": 1, "capsize": 2, "ecolor": "black"},
        )
        for p, v in zip(pos, vals, strict=True):
            if np.isnan(v):
                ax.text(0.01, p, "n/a", va="center", fontsize=6, color="0.4")
    ax.set_yticks(y, list(labels), fontsize=7)
    ax.set_ylim(n - 0.5, -0.5)  # first label on top
    ax.grid(axis="x", alpha=0.3)


def _rows_height(n: int, per_row: float = 0.32) -> float:
    return min(max(2.4, 1.2 + per_row * n), 30.0)


def rate_bars(
    labels: Sequence[str],
    series: Mapping[str, Sequence[Estimate]],
    path: str | Path,
    *,
    title: str = "",
    xlabel: str = "rate (95 % Wilson interval)",
) -> Path:
    """Per-group rates (e.g. success and collision per scenario) as grouped bars with intervals."""
    fig, (ax,) = _figure(8.0, _rows_height(len(labels) * max(1, len(series)) / 1.6))
    _hbars(ax, labels, series)
    ax.set_xlim(0, 1)
    ax.set_xlabel(xlabel)
    ax.set_title(title, fontsize=10)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7, frameon=False)
    return save(fig, path, tight=True)


def taxonomy_bars(groups: Mapping[str, Mapping[str, int]], path: str | Path, *, title: str = "") -> Path:
    """Failure labels per group (e.g. per family) as stacked bars of episode counts; zero labels are left out."""
    keys = list(groups)
    labels = [
        lab
        for lab in dict.fromkeys(lab for g in groups.values() for lab in g)
        if sum(int(g.get(lab, 0)) for g in groups.values()) > 0
    ]
    fig, (ax,) = _figure(8.5, _rows_height(len(keys)))
    left = np.zeros(len(keys))
    for i, lab in enumerate(labels):
        counts = np.array([int(groups[k].get(lab, 0)) for k in keys], dtype=float)
        ax.barh(
            np.arange(len(keys)),
            counts,
            left=left,
            label=lab,
            color=LABEL_COLOURS.get(lab, SERIES_COLOURS[i % len(SERIES_COLOURS)]),
            edgecolor="white",
        )
        left += counts
    for y, total in enumerate(left):
        ax.text(total, y, f" {int(total)}", va="center", fontsize=7)
    ax.set_yticks(np.arange(len(keys)), keys, fontsize=7)
    ax.set_ylim(len(keys) - 0.5, -0.5)
    ax.set_xlim(0, max(1.0, float(left.max(initial=0.0))) * 1.12)
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel("failed episodes")
    ax.set_title(title, fontsize=10)
    if labels:
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7, frameon=False)
    else:
        ax.text(0.5, 0.5, "no failures", transform=ax.transAxes, ha="center", va="center")
    return save(fig, path, tight=True)


def ranking_chart(
    names: Sequence[str],
    hard: Sequence[Estimate],
    glob: Sequence[Estimate],
    path: str | Path,
    *,
    notes: Sequence[str] | None = None,
    title: str = "",
) -> Path:
    """Campaign cells in rank order (rank 1 on top): hard-suite and global success with intervals.

    ``notes`` (one per cell, e.g. the clearances) are printed to the right of the bars.
    """
    labels = [f"{i}. {n}" for i, n in enumerate(names, start=1)]
    fig, (ax,) = _figure(9.0, _rows_height(len(names) * 1.5))
    _hbars(ax, labels, {"hard-suite success": hard, "global success": glob}, ("tab:red", "tab:blue"))
    ax.set_xlim(0, 1.45 if notes else 1.0)
    ax.set_xticks([0, 0.25, 0.5, 0.75, 1.0])
    for y, note in enumerate(notes or []):
        ax.text(1.03, y, note, va="center", fontsize=7)
    ax.set_xlabel("success rate (95 % Wilson interval)")
    ax.set_title(title, fontsize=10)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7, frameon=False)
    return save(fig, path, tight=True)


def _forest(ax: Axes, deltas: Mapping[str, Estimate], xlabel: str) -> None:
    names = list(deltas)
    vals, err = _errors(list(deltas.values()))
    y = np.arange(len(names))
    ok = ~np.isnan(vals)
    ax.errorbar(vals[ok], y[ok], xerr=err[:, ok], fmt="none", ecolor="black", elinewidth=1, capsize=3)
    ax.scatter(
        vals[ok], y[ok], color="tab:blue", zorder=3
    )  # no good/bad colour: "better" depends on the metric
    for yy in y[~ok]:
        ax.text(0, yy, "n/a", ha="center", va="center", fontsize=7, color="0.4")
    ax.axvline(0, color="0.4", lw=1, ls="--")
    ax.set_yticks(y, names, fontsize=7)
    ax.set_ylim(len(names) - 0.5, -0.5)
    ax.set_xlabel(xlabel, fontsize=8)
    ax.grid(axis="x", alpha=0.3)


def ab_chart(
    rate_deltas: Mapping[str, Estimate],
    mean_deltas: Mapping[str, Estimate],
    scenarios: Sequence[str],
    a: Sequence[Estimate],
    b: Sequence[Estimate],
    path: str | Path,
    *,
    labels: tuple[str, str] = ("A", "B"),
    title: str = "",
) -> Path:
    """A/B view of two runs: rate deltas (B - A), mean deltas (B - A) and per-scenario success side by side."""
    height = max(_rows_height(len(scenarios) * 1.3), 1.0 + 0.45 * (len(rate_deltas) + len(mean_deltas)))
    fig = Figure(figsize=(13.0, height), dpi=DPI)
    FigureCanvasAgg(fig)
    grid = fig.add_gridspec(
        2, 2, width_ratios=(1, 1.3), height_ratios=(max(len(rate_deltas), 1), max(len(mean_deltas), 1))
    )
    ax_rates, ax_means, ax_scen = (
        fig.add_subplot(grid[0, 0]),
        fig.add_subplot(grid[1, 0]),
        fig.add_subplot(grid[:, 1]),
    )
    _forest(ax_rates, rate_deltas, f"rate delta {labels[1]} - {labels[0]} (95 % interval)")
    _forest(
        ax_means, mean_deltas, f"mean delta {labels[1]} - {labels[0]} (approx. 95 % interval; units per row)"
    )
    _hbars(ax_scen, scenarios, {labels[0]: a, labels[1]: b}, ("tab:gray", "tab:blue"))
    ax_scen.set_xlim(0, 1)
    ax_scen.set_xlabel("success rate per scenario (95 % Wilson interval)")
    ax_scen.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7, frameon=False)
    if title:
        fig.suptitle(title, fontsize=10)
    return save(fig, path, tight=True)


def _series(history: Sequence[Mapping[str, Any]], key: str) -> tuple[np.ndarray, np.ndarray]:
    pts = [(r["epoch"], _num(r.get(key))) for r in history if _num(r.get(key)) is not None]
    return np.array([p[0] for p in pts], dtype=float), np.array([p[1] for p in pts], dtype=float)


def _curve_panel(
    ax: Axes,
    history: Sequence[Mapping[str, Any]],
    keys: Mapping[str, str],
    ylabel: str,
    best_epoch: int | None,
) -> None:
    styles = {"train": ("tab:blue", "-"), "val": ("tab:orange", "-"), "cv": ("0.3", "--")}
    for key, name in keys.items():
        x, y = _series(history, key)
        if x.size:
            colour, ls = styles.get(key.split("_")[0], ("tab:green", "-"))
            ax.plot(x, y, ls, color=colour, marker="o" if x.size < 30 else None, ms=3, label=name)
    if best_epoch is not None:
        ax.axvline(best_epoch, color="tab:green", lw=1, ls=":", label=f"selected (epoch {best_epoch})")
    ax.set_xlabel("epoch")
    ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)


def training_curves(
    history: Sequence[Mapping[str, Any]], path: str | Path, *, best_epoch: int | None = None, title: str = ""
) -> Path:
    """Loss, ADE and FDE per epoch against constant velocity; proxy success per epoch when recorded.

    ``history``: the training summary's per-epoch records (``epoch``, ``train_loss``, ``val_loss``,
    ``train_ade``, ``val_ade``, ``cv_val_ade``, ... and optionally ``proxy: {success, clearance}``).
    """
    proxy = [{"epoch": r["epoch"], **r["proxy"]} for r in history if isinstance(r.get("proxy"), Mapping)]
    fig, axes = _figure(4.2 * (4 if proxy else 3), 3.6, 4 if proxy else 3)
    _curve_panel(
        axes[0], history, {"train_loss": "train", "val_loss": "validation"}, "loss (SmoothL1)", best_epoch
    )
    _curve_panel(
        axes[1],
        history,
        {"train_ade": "train", "val_ade": "validation", "cv_val_ade": "constant velocity"},
        "ADE [m]",
        best_epoch,
    )
    _curve_panel(
        axes[2],
        history,
        {"train_fde": "train", "val_fde": "validation", "cv_val_fde": "constant velocity"},
        "FDE [m]",
        best_epoch,
    )
    if proxy:
        _curve_panel(axes[3], proxy, {"success": "proxy success"}, "proxy success rate", best_epoch)
        axes[3].set_ylim(-0.02, 1.02)
        x, clr = _series(proxy, "clearance")
        if x.size:
            twin = axes[3].twinx()
            twin.plot(x, clr, "s--", color="tab:purple", ms=3, label="proxy clearance")
            twin.set_ylabel("proxy clearance [m]", fontsize=8)
            twin.legend(loc="lower right", fontsize=7)
    if title:
        fig.suptitle(title, fontsize=10)
    return save(fig, path, tight=True)
