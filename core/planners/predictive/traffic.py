"""Where people have been walking lately: the planner's memory of the crowd's lanes.

A forecast covers a few seconds; a robot that stops to wait stays longer than that, and the next walker through a
doorway is often not in view yet. People who do not see the robot walk their lanes, so where they walked lately is
where the next ones will walk. The map counts, per cell, the pedestrians that passed within contact distance of it,
decaying with ``memory_s``, and the planner charges a rollout that ends slow in a lane (``weights.lane``).
"""

from __future__ import annotations

import math

import numpy as np


class TrafficMap:
    """Decaying count of walkers passing within ``radius`` of each cell (a grid of ``resolution``)."""

    def __init__(
        self,
        width: float,
        height: float,
        radius: float,
        resolution: float = 0.2,
        memory_s: float = 20.0,
        every_s: float = 0.5,
        walking_speed: float = 0.3,
    ):
        self.resolution, self.radius, self.memory_s, self.every_s = resolution, radius, memory_s, every_s
        self.walking_speed = walking_speed
        self.grid = np.zeros(
            (int(math.ceil(width / resolution)) + 1, int(math.ceil(height / resolution)) + 1)
        )
        r = int(math.ceil(radius / resolution))
        i, j = np.mgrid[-r : r + 1, -r : r + 1]
        inside = np.hypot(i, j) * resolution <= radius
        self._disk = np.stack([i[inside], j[inside]], axis=1)  # (D, 2) cell offsets within the radius
        self._last = -math.inf

    def observe(self, time: float, positions: np.ndarray, velocities: np.ndarray) -> None:
        """Every ``every_s``: decay, then add each walker's share of a pass (metres walked / the disk's 2 radius)."""
        if time - self._last < self.every_s - 1e-9:
            return
        elapsed, self._last = time - self._last, time
        self.grid *= math.exp(-elapsed / self.memory_s)
        span = min(
            elapsed, self.every_s
        )  # the stretch each walker is taken to have walked since the last stamp
        speed = np.hypot(*np.asarray(velocities, dtype=float).reshape(-1, 2).T)
        walking = speed >= self.walking_speed
        if not walking.any():
            return
        cells = np.rint(np.asarray(positions, dtype=float).reshape(-1, 2)[walking] / self.resolution).astype(
            np.int64
        )
        share = speed[walking] * span / (2.0 * self.radius)
        idx = cells[:, None, :] + self._disk[None]  # (W, D, 2)
        ok = (
            (idx[..., 0] >= 0)
            & (idx[..., 0] < self.grid.shape[0])
            & (idx[..., 1] >= 0)
            & (idx[..., 1] < self.grid.shape[1])
        )
        w = np.broadcast_to(share[:, None], ok.shape)
        np.add.at(self.grid, (idx[..., 0][ok], idx[..., 1][ok]), w[ok])

    def __call__(self, pts: np.ndarray) -> np.ndarray:
        """Walkers that passed (decayed) at points (..., 2); 0 off the map."""
        c = np.rint(np.asarray(pts, dtype=float) / self.resolution).astype(np.int64)
        ok = (
            (c[..., 0] >= 0)
            & (c[..., 0] < self.grid.shape[0])
            & (c[..., 1] >= 0)
            & (c[..., 1] < self.grid.shape[1])
        )
        out = np.zeros(c.shape[:-1])
        out[ok] = self.grid[c[..., 0][ok], c[..., 1][ok]]
        return out
