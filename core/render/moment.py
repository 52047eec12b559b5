"""Critical-moment picture of a diagnosed episode: where the robot was, what the predictor expected the
nearest pedestrians to do from that step, and what they actually did.

Drawn from the diagnostics trace JSON alone (robot row per step, ``predicted_vs_actual`` of the nearest
pedestrians), so a stored diagnostics run can be pictured without re-running it; the map is optional.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.patches import Circle

from foresight.core.maps.model import MapDef
from foresight.core.render.animation import PREDICTION_COLOUR, ROBOT_COLOUR, as_floats
from foresight.core.render.figure import DPI, map_axes, save
from foresight.core.render.map_view import draw_map
from foresight.core.render.trace import COLLISION_COLOUR, PED_COLOUR

MARGIN = 4.0  #: view margin around the drawn points when no map is given [m]


def _axes(mapdef: MapDef | None, pts: np.ndarray, title: str):
    if mapdef is not None:
        fig, ax = map_axes(mapdef, title=title, extra_width_in=2.0)
        draw_map(ax, mapdef, routes=False, legend=False)
        return fig, ax
    fig = Figure(figsize=(8.0, 6.0), dpi=DPI)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    lo, hi = np.nanmin(pts, axis=0) - MARGIN, np.nanmax(pts, axis=0) + MARGIN
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])  # y up, as every map picture
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)
    return fig, ax


def render_critical_moment(
    robot_xy: Any,
    step: int,
    forecasts: Sequence[Mapping[str, Any]],
    path: str | Path,
    *,
    mapdef: MapDef | None = None,
    title: str = "",
    collision_point: Any = None,
    robot_radius: float = 1.0,
    ped_radius: float = 0.4,
) -> Path:
    """Write the picture; returns ``path``.

    ``robot_xy`` (T+1, 2) [m]; ``step`` the critical state; ``forecasts``: the diagnostics trace's
    ``predicted_vs_actual`` rows at that step (``ped_id``, ``predicted`` (H, 2), ``actual`` (H, 2) with
    ``null`` where the pedestrian was gone).
    """
    xy = as_floats(robot_xy).reshape(-1, 2)
    step = int(min(max(step, 0), len(xy) - 1))
    preds = [(int(f["ped_id"]), as_floats(f.get("predicted") or []).reshape(-1, 2),
              as_floats([a if a is not None else [None, None] for a in f.get("actual") or []]).reshape(-1, 2))
             for f in forecasts]
    pts = np.concatenate([xy] + [p for _, p, _ in preds] + [a for _, _, a in preds])
    fig, ax = _axes(mapdef, pts, title)
    ax.plot(xy[: step + 1, 0], xy[: step + 1, 1], "-", color=ROBOT_COLOUR, lw=2.5, label="robot until the moment")
    ax.plot(xy[step:, 0], xy[step:, 1], ":", color=ROBOT_COLOUR, lw=1.5, label="robot afterwards")
    ax.add_patch(Circle(tuple(xy[step]), robot_radius, fc=ROBOT_COLOUR, ec="black", alpha=0.6, zorder=6))
    for i, (pid, pred, actual) in enumerate(preds):
        first = i == 0
        start = actual[:1] if len(actual) and np.all(np.isfinite(actual[0])) else pred[:1]
        if len(actual):
            ax.plot(actual[:, 0], actual[:, 1], "-", color=PED_COLOUR, lw=1.8, label="actual future" if first else None)
        if len(pred):
            ax.plot(pred[:, 0], pred[:, 1], "--", color=PREDICTION_COLOUR, lw=1.8, marker=".",
                    label="predicted future" if first else None)
            ax.add_collection(LineCollection([np.vstack([start[0], pred[0]])], colors=PREDICTION_COLOUR, lw=1))
        if len(start):
            ax.add_patch(Circle(tuple(start[0]), ped_radius, fc=PED_COLOUR, ec="black", alpha=0.8, zorder=7))
            ax.annotate(str(pid), tuple(start[0]), textcoords="offset points", xytext=(5, 5), fontsize=7)
    if collision_point is not None:
        hit = as_floats(collision_point).reshape(-1)[:2]
        if np.all(np.isfinite(hit)):
            ax.plot(*hit, "x", color=COLLISION_COLOUR, ms=14, mew=3, zorder=9, label="collision")
    if not preds:
        ax.text(0.5, 0.02, "no predictions recorded at this step", transform=ax.transAxes, ha="center", fontsize=8)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7, frameon=False)
    return save(fig, path)
