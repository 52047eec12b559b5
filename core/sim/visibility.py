"""Which pedestrians the planner observes (robot_sf ``observation_visibility``): field of view, range, wall occlusion.

Only the observation is filtered: the trace, collisions and metrics keep every pedestrian.
"""

from __future__ import annotations

import math

import numpy as np

from foresight.core.scenarios.model import ObservationVisibility


def _cross(ax: np.ndarray, ay: np.ndarray, bx: np.ndarray, by: np.ndarray) -> np.ndarray:
    return ax * by - ay * bx


def occluded(eye: np.ndarray, points: np.ndarray, segments: np.ndarray) -> np.ndarray:
    """(K,) True where the sight line eye -> point properly crosses an obstacle edge (S, 4) x1, y1, x2, y2."""
    if len(points) == 0 or len(segments) == 0:
        return np.zeros(len(points), dtype=bool)
    px, py = eye[0], eye[1]
    qx, qy = points[:, 0:1], points[:, 1:2]  # (K, 1)
    ax, ay, bx, by = (segments[None, :, i] for i in range(4))  # (1, S)
    d1 = _cross(bx - ax, by - ay, px - ax, py - ay)
    d2 = _cross(bx - ax, by - ay, qx - ax, qy - ay)
    d3 = _cross(qx - px, qy - py, ax - px, ay - py)
    d4 = _cross(qx - px, qy - py, bx - px, by - py)
    return ((d1 * d2 < 0) & (d3 * d4 < 0)).any(axis=1)


def visible(
    robot: np.ndarray, points: np.ndarray, vis: ObservationVisibility, segments: np.ndarray
) -> np.ndarray:
    """(K,) mask of the points (K, 2) the robot (x, y, heading, ...) sees under ``vis``."""
    rel = np.asarray(points, dtype=float).reshape(-1, 2) - robot[:2]
    ok = np.ones(len(rel), dtype=bool)
    if vis.max_range_m is not None:
        ok &= np.hypot(rel[:, 0], rel[:, 1]) <= vis.max_range_m
    if vis.fov_degrees < 360:
        bearing = np.arctan2(rel[:, 1], rel[:, 0]) - robot[2]
        ok &= np.abs((bearing + math.pi) % (2 * math.pi) - math.pi) <= math.radians(vis.fov_degrees) / 2
    if vis.static_occlusion and ok.any():
        ok[ok] = ~occluded(robot[:2], rel[ok] + robot[:2], segments)
    return ok
