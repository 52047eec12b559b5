"""Figure plumbing shared by the renderers: a map-framed axes and saving by file suffix.

Figures are built from ``matplotlib.figure.Figure`` with an Agg canvas, never through pyplot, so
rendering leaves no global state behind and works in worker threads without a display.
"""

from __future__ import annotations

from pathlib import Path

from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from foresight.core import files
from foresight.core.errors import ConfigError
from foresight.core.maps.model import MapDef

FORMATS = {".png": "png", ".svg": "svg"}
WIDTH_IN = 8.0  #: figure width [inch]
DPI = 100


def map_axes(mapdef: MapDef, *, title: str | None = None, extra_width_in: float = 0.0) -> tuple[Figure, Axes]:
    """A figure with one axes framing the map bounds, y pointing up: the simulator's frame, where a heading turns
    counter-clockwise from x (the SVG picture a map came from is its mirror image), as the episode player draws it."""
    aspect = mapdef.height / mapdef.width
    height_in = min(max(WIDTH_IN * aspect, 3.0), 12.0) + 0.6
    fig = Figure(figsize=(WIDTH_IN + extra_width_in, height_in), dpi=DPI)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    ax.set_xlim(0, mapdef.width)
    ax.set_ylim(0, mapdef.height)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(title if title is not None else mapdef.name, fontsize=10)
    return fig, ax


def save(fig: Figure, path: str | Path, *, tight: bool = False) -> Path:
    """Write the figure as PNG or SVG, chosen by the suffix of ``path``; returns the path.

    ``tight`` crops to the drawn content so that legends placed beside the axes are kept whole (charts); map
    pictures keep the figure's fixed size, so two pictures of one map line up pixel for pixel."""
    p = Path(path)
    fmt = FORMATS.get(p.suffix.lower())
    if fmt is None:
        raise ConfigError(
            f"unsupported picture format {p.suffix!r}; use one of {sorted(FORMATS)}", source=p, item="path"
        )
    fig.tight_layout()
    with files.replacing(p) as tmp:
        fig.savefig(tmp, format=fmt, bbox_inches="tight" if tight else None)
    return p
