"""Robot collision checks of one step (reference §4): pedestrians, static segments, leaving the map.

Why numpy and not pymunk: one disc against S segments and N discs is two short array
expressions (about 10 µs for the classic maps); a pymunk ``shape_query`` on a static space costs
about the same per call but needs the pedestrian bodies re-synced every step, and its contact
test is inflated by collision slop, so it would not reproduce the reference's exact
"distance <= r_robot + r_ped" rule. Discrete checks at dt, no sweeping, as the reference.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.sim.geometry import SegmentSet
from core.sim.observation import CollisionKind


@dataclass(frozen=True)
class Contact:
    kind: CollisionKind
    point: np.ndarray  #: (2,) where: the pedestrian's centre, the nearest point of the segment, or the robot centre [m]


def ped_contact(xy: np.ndarray, radius: float, ped_pos: np.ndarray, ped_radius: float) -> tuple[Contact | None, float]:
    """Collision iff a centre distance <= r_robot + r_ped (inclusive); also returns the minimum centre distance [m]."""
    if len(ped_pos) == 0:
        return None, np.inf
    d2 = (ped_pos[:, 0] - xy[0]) ** 2 + (ped_pos[:, 1] - xy[1]) ** 2
    k = int(np.argmin(d2))
    dmin = float(np.sqrt(d2[k]))
    if dmin <= radius + ped_radius:
        return Contact("pedestrian", ped_pos[k].copy()), dmin
    return None, dmin


class StaticChecker:
    """``static_contact`` that skips the segment test while the robot cannot have reached a segment.

    After each full test it keeps the slack (distance to the nearest segment minus the radius) and
    spends it by the distance travelled; the test is exact, just not repeated needlessly.
    """

    def __init__(self, walls: SegmentSet, width: float, height: float, radius: float):
        self.walls, self.width, self.height, self.radius = walls, width, height, radius
        self.slack = -1.0
        self.last = np.zeros(2)

    def check(self, xy: np.ndarray) -> Contact | None:
        x, y = float(xy[0]), float(xy[1])
        self.slack -= ((x - self.last[0]) ** 2 + (y - self.last[1]) ** 2) ** 0.5
        self.last = np.array([x, y])
        if not (0.0 <= x <= self.width and 0.0 <= y <= self.height):
            return Contact("out_of_bounds", np.array([x, y]))
        if self.slack > 0 or len(self.walls) == 0:
            return None
        ox, oy, dist = self.walls.offset_components(self.last[None])
        k = int(np.argmin(dist[0]))
        self.slack = float(dist[0, k]) - self.radius
        if self.slack <= 0:
            return Contact("static", self.last - np.array([ox[0, k], oy[0, k]]))
        return None


def static_contact(xy: np.ndarray, radius: float, walls: SegmentSet, width: float, height: float) -> Contact | None:
    """Out of bounds if the centre leaves [0, W] x [0, H]; static if the disc touches any segment (edges and bounds).

    Like the reference this is a segment test: a robot wholly inside a large polygon without touching an edge is not flagged.
    """
    x, y = float(xy[0]), float(xy[1])
    if not (0.0 <= x <= width and 0.0 <= y <= height):
        return Contact("out_of_bounds", np.array([x, y]))
    if len(walls) == 0:
        return None
    off, dist = walls.offsets(xy)
    k = int(np.argmin(dist))
    if dist[k] <= radius:
        return Contact("static", xy - off[k])
    return None
