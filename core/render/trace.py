"""Episode picture: the map, the robot's path coloured by time, faded pedestrian tracks, start,
goal and the collision point.

Reads only the Trace contract of docs/architecture.md (``robot`` (T+1, 5), ``ped_ids`` (T+1, N)
with -1 for an empty slot, ``ped_pos`` (T+1, N, 2), ``dt``), so a hand-built trace renders too.
A preallocated trace may say how far it got with an integer ``steps`` attribute; rows beyond it
(or non-finite robot rows) are not drawn.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.collections import LineCollection
from matplotlib.patches import Circle

from foresight.core.maps.model import MapDef
from foresight.core.render.figure import map_axes, save
from foresight.core.render.map_view import draw_map

ROBOT_CMAP = "viridis"
PED_COLOUR = "tab:brown"  #: distinct from the blue ped routes
COLLISION_COLOUR = "red"


def recorded_states(trace: Any) -> int:
    """Number of recorded states (T+1): ``steps + 1`` when the trace says, else the finite robot rows."""
    robot = np.asarray(trace.robot, dtype=float)
    steps = getattr(trace, "steps", None)
    if isinstance(steps, int | np.integer) and 0 <= steps < len(robot):
        return int(steps) + 1
    finite = np.all(np.isfinite(robot[:, :2]), axis=1)
    return int(np.argmin(finite)) if not finite.all() else len(robot)


def ped_segments(ped_ids: np.ndarray, ped_pos: np.ndarray) -> np.ndarray:
    """Track pieces (S, 2, 2) [m] between consecutive states of the same pedestrian in the same slot.

    A respawned pedestrian has a new id, so no segment jumps from its old to its new position.
    """
    ids = np.asarray(ped_ids)
    pos = np.asarray(ped_pos, dtype=float)
    if ids.shape[0] < 2 or ids.shape[1] == 0:
        return np.zeros((0, 2, 2))
    same = (ids[1:] == ids[:-1]) & (ids[1:] >= 0)
    t, slot = np.nonzero(same)
    return np.stack([pos[t, slot], pos[t + 1, slot]], axis=1)


def _draw_robot_path(ax: Axes, xy: np.ndarray, dt: float) -> LineCollection | None:
    if len(xy) < 2:
        return None
    segs = np.stack([xy[:-1], xy[1:]], axis=1)
    lc = LineCollection(segs, cmap=ROBOT_CMAP, linewidths=2.5, zorder=6)
    lc.set_array(np.arange(len(segs)) * dt)
    ax.add_collection(lc)
    return lc


def _draw_peds_at(ax: Axes, trace: Any, t: int, radius: float = 0.4) -> None:
    """Pedestrians as circles [m] at state ``t`` (the collision, else the last state)."""
    ids = np.asarray(trace.ped_ids)
    if t >= len(ids) or ids.shape[1] == 0:
        return
    for xy in np.asarray(trace.ped_pos, dtype=float)[t][ids[t] >= 0]:
        ax.add_patch(Circle(tuple(xy), radius, fc=PED_COLOUR, ec="black", lw=0.5, alpha=0.8, zorder=7))


def _collision_xy(robot_xy: np.ndarray, step: Any, point: Any) -> np.ndarray | None:
    """Where to draw the collision mark; ``core.sim.trace.Trace`` says "none" with step -1 and a NaN point."""
    if point is not None:
        xy = np.asarray(point, dtype=float).reshape(2)
        if np.all(np.isfinite(xy)):
            return xy
    if step is not None and int(step) >= 0 and len(robot_xy):
        return robot_xy[min(int(step), len(robot_xy) - 1)]
    return None


def render_trace(
    trace: Any,
    mapdef: MapDef,
    path: str | Path,
    *,
    title: str | None = None,
    collision_step: int | None = None,
    collision_point: Any = None,
    goal: Any = None,
    goal_tolerance: float | None = None,
    robot_radius: float = 1.0,
    ped_radius: float = 0.4,
) -> Path:
    """Write the episode picture to ``path`` (.png or .svg); returns the path.

    ``collision_step``/``collision_point`` default to the trace's attributes of those names when
    present; ``goal`` [m] to the trace's ``goal``, else its ``goal`` meta; ``goal_tolerance`` [m] (a disc around
    the goal) and ``robot_radius`` [m] (the robot's body, drawn at the collision step or the last state; the
    collision is an x at the contact point) to the trace's meta of those names, which the simulator records. ``ped_radius`` [m] sizes
    the pedestrians drawn at that same state. y points up (``figure.map_axes``).
    """
    n = recorded_states(trace)
    robot_xy = np.asarray(trace.robot, dtype=float)[:n, :2]
    dt = float(trace.dt)
    collision_step = collision_step if collision_step is not None else getattr(trace, "collision_step", None)
    collision_point = (
        collision_point if collision_point is not None else getattr(trace, "collision_point", None)
    )
    goal = goal if goal is not None else getattr(trace, "goal", None)
    meta = getattr(trace, "meta", None) or {}
    goal = goal if goal is not None else meta.get("goal")
    robot_radius = float(meta.get("robot_radius", robot_radius))
    goal_tolerance = goal_tolerance if goal_tolerance is not None else meta.get("goal_tolerance")

    fig, ax = map_axes(mapdef, title=title, extra_width_in=2.6)
    draw_map(ax, mapdef, routes=True, legend=False)
    segs = ped_segments(np.asarray(trace.ped_ids)[:n], np.asarray(trace.ped_pos)[:n])
    if len(segs):
        ax.add_collection(
            LineCollection(segs, colors=PED_COLOUR, linewidths=1.0, alpha=0.5, zorder=5, label="pedestrians")
        )
    shown = n - 1 if collision_step is None or int(collision_step) < 0 else min(int(collision_step), n - 1)
    _draw_peds_at(ax, trace, shown, ped_radius)
    lc = _draw_robot_path(ax, robot_xy, dt)
    if lc is not None:
        fig.colorbar(lc, ax=ax, label="time [s]", fraction=0.04, pad=0.02)
    if len(robot_xy):
        ax.plot(*robot_xy[0], "o", color="tab:green", ms=9, mec="black", zorder=7, label="start")
    if goal is not None:
        gxy = tuple(np.asarray(goal, dtype=float).reshape(2))
        if goal_tolerance:
            ax.add_patch(
                Circle(
                    gxy,
                    goal_tolerance,
                    fc="tab:green",
                    ec="tab:green",
                    alpha=0.18,
                    zorder=4,
                    label=f"goal tolerance ({goal_tolerance:g} m)",
                )
            )
        ax.plot(*gxy, "*", color="tab:red", ms=14, mec="black", zorder=7, label="goal")
    if len(robot_xy):  # the robot's body where the picture's pedestrians are (a contact looks like a contact)
        ax.add_patch(
            Circle(
                tuple(robot_xy[shown]),
                robot_radius,
                fc="tab:blue",
                ec="black",
                alpha=0.35,
                lw=1,
                zorder=7,
                label=f"robot body ({robot_radius:g} m)",
            )
        )
    hit = _collision_xy(robot_xy, collision_step, collision_point)
    if hit is not None:
        ax.plot(*hit, "x", color=COLLISION_COLOUR, ms=14, mew=3, zorder=9, label="collision")
    ax.legend(loc="upper left", bbox_to_anchor=(1.15, 1.0), fontsize=7, frameon=False)
    return save(fig, path)
