"""One frame of a running episode as an RGB array: the Gymnasium env's ``render()`` (``rgb_array``, ``human``).

The map is drawn once per view; each frame moves the robot, its heading, the pedestrians and the goal over it.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from matplotlib.collections import PatchCollection
from matplotlib.patches import Circle

from foresight.core.maps.model import MapDef
from foresight.core.render.figure import map_axes
from foresight.core.render.map_view import draw_map
from foresight.core.render.trace import PED_COLOUR

ROBOT_COLOUR = "tab:green"


class LiveView:
    """A figure of one map that draws simulator observations (``frame(obs) -> (H, W, 3) uint8``)."""

    def __init__(self, mapdef: MapDef, *, title: str | None = None, width_px: int = 640):
        self.fig, self.ax = map_axes(mapdef, title=title)
        self.fig.set_dpi(width_px / self.fig.get_figwidth())
        draw_map(self.ax, mapdef, routes=True, legend=False)
        self.fig.tight_layout()
        self.robot = Circle((0, 0), 0.3, fc=ROBOT_COLOUR, ec="black", zorder=6)
        self.ax.add_patch(self.robot)
        (self.heading,) = self.ax.plot([], [], color="black", lw=1.5, zorder=7)
        (self.goal,) = self.ax.plot([], [], marker="*", ms=14, color="gold", mec="black", ls="", zorder=5)
        self.peds = PatchCollection([], fc=PED_COLOUR, ec="black", alpha=0.8, zorder=4)
        self.ax.add_collection(self.peds)
        self.clock = self.ax.text(0.01, 0.99, "", transform=self.ax.transAxes, va="top", fontsize=9)

    def frame(self, obs: Any) -> np.ndarray:
        x, y, heading = (float(v) for v in obs.robot_pose[:3])
        self.robot.center, self.robot.radius = (x, y), float(obs.robot_radius)
        reach = 2.0 * float(obs.robot_radius)
        self.heading.set_data([x, x + reach * np.cos(heading)], [y, y + reach * np.sin(heading)])
        self.goal.set_data([float(obs.goal[0])], [float(obs.goal[1])])
        self.peds.set_paths(
            [Circle((float(p[0]), float(p[1])), float(obs.ped_radius)) for p in obs.ped_positions]
        )
        self.clock.set_text(f"t = {float(obs.time):.1f} s (step {int(obs.step)})")
        self.fig.canvas.draw()
        return np.asarray(self.fig.canvas.buffer_rgba())[..., :3].copy()

    def show(self, frame: np.ndarray, pause_s: float) -> None:
        """Draw ``frame`` in a window (``render_mode="human"``; needs a display and an interactive backend)."""
        import matplotlib.pyplot as plt

        if getattr(self, "_window", None) is None:
            self._window = plt.imshow(frame)
            plt.axis("off")
        else:
            self._window.set_data(frame)
        plt.pause(pause_s)
