"""Map preview: bounds, obstacles, zones coloured by kind, routes with direction arrows, single peds."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.patches import Polygon, Rectangle

from foresight.core.maps.model import MapDef, Route, Zone
from foresight.core.render.figure import map_axes, save

ZONE_STYLE = {  #: field -> (face colour, legend label)
    "robot_spawn_zones": ("tab:green", "robot spawn"),
    "robot_goal_zones": ("tab:red", "robot goal"),
    "ped_spawn_zones": ("tab:blue", "ped spawn"),
    "ped_goal_zones": ("tab:purple", "ped goal"),
    "ped_crowded_zones": ("gold", "crowded zone"),
}
OBSTACLE_COLOUR = "0.35"
ROBOT_ROUTE_COLOUR = "black"
PED_ROUTE_COLOUR = "tab:blue"
SINGLE_PED_COLOUR = "tab:orange"
POI_COLOUR = "tab:purple"


def zone_polygon(zone: Zone) -> np.ndarray:
    """The zone's four corners (4, 2) [m]: a, b, c and the implied a + c - b."""
    a, b, c = (np.asarray(p, dtype=float) for p in zone.corners)
    return np.array([a, b, c, a + c - b])


def _draw_route(ax: Axes, route: Route, colour: str, width: float, label: str | None) -> None:
    pts = route.array
    ax.plot(pts[:, 0], pts[:, 1], color=colour, lw=width, ls="--", alpha=0.8, label=label, zorder=3)
    for (x0, y0), (x1, y1) in zip(pts[:-1], pts[1:], strict=True):
        ax.annotate(
            "",
            xy=(x0 + 0.6 * (x1 - x0), y0 + 0.6 * (y1 - y0)),
            xytext=(x0 + 0.4 * (x1 - x0), y0 + 0.4 * (y1 - y0)),
            arrowprops={"arrowstyle": "-|>", "color": colour, "lw": width, "mutation_scale": 14},
            zorder=3,
        )


def _draw_single_peds(ax: Axes, mapdef: MapDef) -> None:
    for i, ped in enumerate(mapdef.single_pedestrians):
        label = "single ped" if i == 0 else None
        ax.plot(*ped.start, "o", color=SINGLE_PED_COLOUR, ms=6, label=label, zorder=5)
        name = f"{ped.id} ({ped.role})" if ped.role else ped.id
        ax.annotate(name, ped.start, textcoords="offset points", xytext=(4, 4), fontsize=7, zorder=5)
        if ped.hold_ref_point is not None:  # the point whose approach by the robot releases the hold
            ax.plot(*ped.hold_ref_point, "s", mfc="none", color=SINGLE_PED_COLOUR, ms=7, zorder=5)
        path = [ped.start, *ped.trajectory] if ped.trajectory else ([ped.start, ped.goal] if ped.goal else [])
        if len(path) > 1:
            xy = np.asarray(path, dtype=float)
            ax.plot(xy[:, 0], xy[:, 1], ":", color=SINGLE_PED_COLOUR, lw=1.2, zorder=4)
            ax.plot(*xy[-1], "x", color=SINGLE_PED_COLOUR, ms=6, zorder=5)


def _draw_pois(ax: Axes, mapdef: MapDef) -> None:
    for i, (key, xy) in enumerate(mapdef.pois.items()):
        ax.plot(*xy, "*", color=POI_COLOUR, ms=10, label="point of interest" if i == 0 else None, zorder=5)
        ax.annotate(
            mapdef.poi_labels.get(key, key),
            xy,
            textcoords="offset points",
            xytext=(5, -9),
            fontsize=7,
            color=POI_COLOUR,
            zorder=5,
        )


def draw_map(ax: Axes, mapdef: MapDef, *, routes: bool = True, legend: bool = True) -> None:
    """Draw the static scene onto ``ax`` (already framed by ``figure.map_axes``)."""
    ax.add_patch(Rectangle((0, 0), mapdef.width, mapdef.height, fill=False, lw=2, ec="black", zorder=1))
    for poly in mapdef.obstacles:
        ax.add_patch(
            Polygon(np.asarray(poly, dtype=float), closed=True, fc=OBSTACLE_COLOUR, ec="black", zorder=2)
        )
    for field, (colour, label) in ZONE_STYLE.items():
        for i, zone in enumerate(getattr(mapdef, field)):
            ax.add_patch(
                Polygon(
                    zone_polygon(zone),
                    closed=True,
                    fc=colour,
                    ec=colour,
                    alpha=0.3,
                    label=label if i == 0 else None,
                )
            )
    if routes:
        for i, r in enumerate(mapdef.ped_routes):
            _draw_route(ax, r, PED_ROUTE_COLOUR, 1.0, "ped route" if i == 0 else None)
        for i, r in enumerate(mapdef.robot_routes):
            _draw_route(ax, r, ROBOT_ROUTE_COLOUR, 1.6, "robot route" if i == 0 else None)
    _draw_pois(ax, mapdef)
    _draw_single_peds(ax, mapdef)
    if legend:
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7, frameon=False)


def render_map(mapdef: MapDef, path: str | Path, *, title: str | None = None) -> Path:
    """Write a preview of ``mapdef`` to ``path`` (.png or .svg); returns the path."""
    fig, ax = map_axes(mapdef, title=title, extra_width_in=1.6)
    draw_map(ax, mapdef)
    return save(fig, path)
