"""Picture of a reachability verdict (``core.sim.feasibility``): when each place became reachable for the relaxed
robot, the crowd it had to get past, start and goal.

Why a picture: "unreachable" alone does not say why. Coloured by the time each place was first reachable, the
region stops where walkers block the way (a corridor they fill, a door they stream through), and the grey
tracks show who blocked it; a reachable episode shows the way the relaxed robot found and when.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.patches import Circle

from foresight.core.maps.model import MapDef
from foresight.core.render.figure import map_axes, save
from foresight.core.render.map_view import draw_map
from foresight.core.sim.feasibility import ReachMap

CMAP = "viridis"
CROWD_COLOUR = "0.35"
TRACK_STRIDE = 3  #: draw every third recorded step of the crowd's tracks


def render_reachability(
    where: ReachMap, mapdef: MapDef, path: str | Path, *, title: str | None = None, ped_radius: float = 0.4
) -> Path:
    """Write the picture to ``path`` (.png or .svg): the first time [s] each cell was reachable, the crowd's tracks
    up to the verdict's step and the pedestrians there (discs of ``ped_radius``), start and goal; returns the path."""
    fig, ax = map_axes(mapdef, title=title, extra_width_in=1.6)
    draw_map(ax, mapdef, routes=False, legend=False)
    seconds = np.ma.masked_less(where.reached_at, 0).astype(float) * where.dt
    g = where.grid
    nx, ny = where.reached_at.shape
    im = ax.imshow(
        seconds.T,
        origin="lower",
        extent=(-g / 2, (nx - 0.5) * g, -g / 2, (ny - 0.5) * g),
        cmap=CMAP,
        alpha=0.8,
        zorder=3,
        interpolation="nearest",
    )
    fig.colorbar(im, ax=ax, label="first reachable [s]", fraction=0.04, pad=0.02)
    tracks = [p for p in where.crowd[::TRACK_STRIDE] if len(p)]
    if tracks:
        pts = np.concatenate(tracks)
        ax.plot(pts[:, 0], pts[:, 1], ".", color=CROWD_COLOUR, ms=1.5, alpha=0.5, zorder=4)
    for x, y in where.crowd[-1] if where.crowd else ():
        ax.add_patch(Circle((x, y), ped_radius, fc=CROWD_COLOUR, ec="black", lw=0.5, alpha=0.8, zorder=5))
    ax.plot(*where.start, "o", color="tab:green", ms=9, mec="black", zorder=6, label="start")
    ax.add_patch(Circle(tuple(where.goal), where.tolerance, fc="none", ec="tab:red", lw=1.2, zorder=6))
    ax.plot(*where.goal, "*", color="tab:red", ms=14, mec="black", zorder=6, label="goal")
    ax.legend(loc="upper left", bbox_to_anchor=(1.18, 1.0), fontsize=7, frameon=False)
    out = save(fig, path)
    fig.clear()
    return out
