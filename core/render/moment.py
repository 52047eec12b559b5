"""Critical-moment picture of a diagnosed episode: where the robot was, heading where and planning what, what
the predictor expected the nearest pedestrians to do from that step, and what they actually did.

Drawn from the diagnostics trace JSON (robot row per step, ``predicted_vs_actual`` of the nearest pedestrians)
and, when the episode's full trace is at hand, the pedestrians at that step with their velocities; so a planner
without a predictor (no forecasts recorded) still gets the scene it faced, not an empty picture. The map is
optional.
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
PLAN_S = 2.0  #: [s] how far the commanded motion is rolled out when the planner logged no plan
PLAN_COLOUR = (
    "#9467bd"  #: purple: apart from the robot's green, the pedestrians' brown and the forecasts' colour
)
VELOCITY_S = 1.0  #: [s] length of a pedestrian's velocity arrow (where it would be in this time)


def rollout(
    pose: Sequence[float], command: Sequence[float], dt: float, seconds: float = PLAN_S
) -> np.ndarray:
    """(K+1, 2) positions of a unicycle at ``pose`` (x, y, heading) holding ``command`` (v, omega) for
    ``seconds``: the motion the planner chose at that step, drawn when it logged no plan of its own."""
    x, y, th = (float(v) for v in pose[:3])
    v, om = (float(c) for c in command[:2])
    out = [(x, y)]
    for _ in range(max(1, round(seconds / dt))):
        x, y, th = x + v * np.cos(th) * dt, y + v * np.sin(th) * dt, th + om * dt
        out.append((x, y))
    return np.asarray(out)


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
    heading: float | None = None,
    plan: Any = None,
    pedestrians: Sequence[tuple[int, Any, Any]] = (),
) -> Path:
    """Write the picture; returns ``path``.

    ``robot_xy`` (T+1, 2) [m]; ``step`` the critical state; ``forecasts``: the diagnostics trace's
    ``predicted_vs_actual`` rows at that step (``ped_id``, ``predicted`` (H, 2), ``actual`` (H, 2) with
    ``null`` where the pedestrian was gone). ``heading`` [rad] of the robot at ``step``; ``plan`` (K, 2) the
    path it planned (or its command rolled out, :func:`rollout`); ``pedestrians`` ``(id, (x, y), (vx, vy))`` at
    ``step``, drawn with their ids and a VELOCITY_S velocity arrow.
    """
    xy = as_floats(robot_xy).reshape(-1, 2)
    step = int(min(max(step, 0), len(xy) - 1))
    preds = [
        (
            int(f["ped_id"]),
            as_floats(f.get("predicted") or []).reshape(-1, 2),
            as_floats([a if a is not None else [None, None] for a in f.get("actual") or []]).reshape(-1, 2),
        )
        for f in forecasts
    ]
    plan_xy = as_floats(plan).reshape(-1, 2) if plan is not None else np.empty((0, 2))
    peds = [(int(i), as_floats(p).reshape(2), as_floats(v).reshape(2)) for i, p, v in pedestrians]
    pts = np.concatenate(
        [xy, plan_xy] + [p for _, p, _ in preds] + [a for _, _, a in preds] + [p[None] for _, p, _ in peds]
    )
    fig, ax = _axes(mapdef, pts, title)
    ax.plot(
        xy[: step + 1, 0], xy[: step + 1, 1], "-", color=ROBOT_COLOUR, lw=2.5, label="robot until the moment"
    )
    ax.plot(xy[step:, 0], xy[step:, 1], ":", color=ROBOT_COLOUR, lw=1.5, label="robot afterwards")
    ax.add_patch(Circle(tuple(xy[step]), robot_radius, fc=ROBOT_COLOUR, ec="black", alpha=0.6, zorder=6))
    if heading is not None and np.isfinite(heading):
        tip = xy[step] + 1.6 * robot_radius * np.array([np.cos(heading), np.sin(heading)])
        ax.annotate(
            "",
            tuple(tip),
            tuple(xy[step]),
            zorder=8,
            arrowprops={"arrowstyle": "-|>", "color": "black", "lw": 1.8},
        )
    if len(plan_xy) > 1:
        ax.plot(
            plan_xy[:, 0],
            plan_xy[:, 1],
            "-",
            color=PLAN_COLOUR,
            lw=2.5,
            alpha=0.9,
            zorder=7,
            label="robot's plan at the moment",
        )
    forecast_ids = {pid for pid, _, _ in preds}
    for i, (pid, pos, vel) in enumerate(p for p in peds if p[0] not in forecast_ids):
        ax.add_patch(
            Circle(
                tuple(pos),
                ped_radius,
                fc=PED_COLOUR,
                ec="black",
                alpha=0.8,
                zorder=7,
                label="pedestrian (velocity: 1 s)" if i == 0 else None,
            )
        )
        if np.all(np.isfinite(vel)) and np.hypot(*vel) > 1e-3:
            ax.annotate(
                "",
                tuple(pos + VELOCITY_S * vel),
                tuple(pos),
                arrowprops={"arrowstyle": "->", "color": PED_COLOUR, "lw": 1.2},
            )
        ax.annotate(str(pid), tuple(pos), textcoords="offset points", xytext=(5, 5), fontsize=7)
    for i, (pid, pred, actual) in enumerate(preds):
        first = i == 0
        start = actual[:1] if len(actual) and np.all(np.isfinite(actual[0])) else pred[:1]
        if len(actual):
            ax.plot(
                actual[:, 0],
                actual[:, 1],
                "-",
                color=PED_COLOUR,
                lw=1.8,
                label="actual future" if first else None,
            )
        if len(pred):
            ax.plot(
                pred[:, 0],
                pred[:, 1],
                "--",
                color=PREDICTION_COLOUR,
                lw=1.8,
                marker=".",
                label="predicted future" if first else None,
            )
            ax.add_collection(
                LineCollection([np.vstack([start[0], pred[0]])], colors=PREDICTION_COLOUR, lw=1)
            )
        if len(start):
            ax.add_patch(Circle(tuple(start[0]), ped_radius, fc=PED_COLOUR, ec="black", alpha=0.8, zorder=7))
            ax.annotate(str(pid), tuple(start[0]), textcoords="offset points", xytext=(5, 5), fontsize=7)
    if collision_point is not None:
        hit = as_floats(collision_point).reshape(-1)[:2]
        if np.all(np.isfinite(hit)):
            ax.plot(*hit, "x", color=COLLISION_COLOUR, ms=14, mew=3, zorder=9, label="collision")
    if not preds:
        ax.text(
            0.5,
            0.02,
            "no forecasts recorded (planner without a predictor)",
            transform=ax.transAxes,
            ha="center",
            fontsize=8,
        )
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7, frameon=False)
    return save(fig, path)
