"""Sampling points in zones and along routes, with obstacle (and optional robot-clearance) rejection."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from foresight.core.errors import ConfigError
from foresight.core.maps.model import Route, Zone

Validator = Callable[[np.ndarray], np.ndarray]  #: points (K, 2) -> accepted mask (K,)


def sample_zone(zone: Zone, n: int, rng: np.random.Generator, mode: str = "triangle") -> np.ndarray:
    """n raw points (n, 2) in a 3-corner zone: b + u (a - b) + v (c - b).

    ``triangle`` folds (u, v) with u + v > 1 back, covering only the triangle a-b-c (the reference's
    reading, half the rectangle); ``full`` covers the whole parallelogram.
    """
    a, b, c = (np.asarray(p, dtype=float) for p in zone.corners)
    uv = rng.random((n, 2))
    if mode == "triangle":
        fold = uv.sum(axis=1) > 1.0
        uv[fold] = 1.0 - uv[fold]
    return b + uv[:, :1] * (a - b) + uv[:, 1:] * (c - b)


def sample_free(
    zone: Zone,
    n: int,
    rng: np.random.Generator,
    mode: str,
    valid: Validator,
    *,
    what: str = "zone",
    required: bool = True,
) -> np.ndarray | None:
    """n accepted points (n, 2) in a zone, drawn in batches of max(2n, 4), at most 20n (>= 40) draws.

    When the budget runs out: ConfigError if ``required``, else None.
    """
    out: list[np.ndarray] = []
    have, drawn, budget = 0, 0, max(20 * n, 40)
    while have < n:
        if drawn >= budget:
            if not required:
                return None
            raise ConfigError(
                f"could not place {n} points in {what} {zone.corners} (obstacles or robot in the way)"
            )
        batch = max(2 * n, 4)
        cand = sample_zone(zone, batch, rng, mode)
        drawn += batch
        ok = cand[valid(cand)][: n - have]
        out.append(ok)
        have += len(ok)
    return np.concatenate(out)[:n] if out else np.zeros((0, 2))


class RouteGeometry:
    """A polyline route as arrays: waypoints (K, 2), cumulative arc length (K,), total length [m]."""

    def __init__(self, route: Route):
        self.route = route
        self.points = np.asarray(route.waypoints, dtype=float)
        seg = np.linalg.norm(np.diff(self.points, axis=0), axis=1)
        self.cum = np.concatenate([[0.0], np.cumsum(seg)])
        self.length = float(self.cum[-1])

    def point_at(self, s: float) -> tuple[np.ndarray, int]:
        """The point at arc length s [m] and the index of the section (k -> k + 1) containing it."""
        s = float(np.clip(s, 0.0, self.length))
        k = int(np.searchsorted(self.cum, s, side="right") - 1)
        k = min(max(k, 0), len(self.points) - 2)
        span = self.cum[k + 1] - self.cum[k]
        f = (s - self.cum[k]) / span if span > 0 else 0.0
        return self.points[k] + f * (self.points[k + 1] - self.points[k]), k


def polyline_exit_point(
    points: np.ndarray, centre: np.ndarray, radius: float
) -> tuple[np.ndarray, int] | None:
    """First point along a polyline (K, 2) at distance ``radius`` from ``centre``, leaving the circle.

    Returns the point and the index of the section containing it, or None when the polyline
    never reaches that distance.
    """
    for k in range(len(points) - 1):
        p, d = points[k], points[k + 1] - points[k]
        f = p - centre
        a = float(d @ d)
        if a == 0:
            continue
        b = 2.0 * float(f @ d)
        c = float(f @ f) - radius**2
        disc = b * b - 4 * a * c
        if disc < 0:
            continue
        t = (-b + np.sqrt(disc)) / (2 * a)  # the exit root
        if 0.0 <= t <= 1.0 and float(np.linalg.norm(f)) <= radius:
            return p + t * d, k
        t0 = (-b - np.sqrt(disc)) / (2 * a)
        if 0.0 <= t0 <= 1.0:
            return p + t0 * d, k
    return None
