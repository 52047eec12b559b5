"""The robot's route for one episode: sampled start and goal, waypoints, and waypoint advance (reference §2.2)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from foresight.core.errors import ConfigError
from foresight.core.maps.model import MapDef
from foresight.core.sim.zones import Validator, polyline_exit_point, sample_free


@dataclass
class RobotRoute:
    """Start pose and waypoints [*route points, goal]; ``index`` is the current waypoint."""

    start: np.ndarray  #: (2,) [m]
    heading: float  #: initial heading [rad]
    waypoints: np.ndarray  #: (K, 2) [m], goal last
    tolerance: float  #: waypoint and goal proximity [m] (robot radius + goal radius)
    index: int = 0

    @property
    def goal(self) -> np.ndarray:
        return self.waypoints[-1]

    @property
    def current(self) -> np.ndarray:
        return self.waypoints[self.index]

    def advance(self, xy: np.ndarray) -> bool:
        """Move to the next waypoint when within tolerance of the current one; True when the goal is reached."""
        w = self.waypoints[self.index]
        if (xy[0] - w[0]) ** 2 + (xy[1] - w[1]) ** 2 <= self.tolerance**2 and self.index < len(
            self.waypoints
        ) - 1:
            self.index += 1
        g = self.waypoints[-1]
        return (xy[0] - g[0]) ** 2 + (xy[1] - g[1]) ** 2 <= self.tolerance**2


def sample_robot_route(
    map_def: MapDef,
    rng: np.random.Generator,
    tolerance: float,
    zone_mode: str,
    start_ok: Validator,
    goal_ok: Validator,
    start_fallback: Validator | None = None,
) -> RobotRoute:
    """Pick a spawn id uniformly, a route of that spawn uniformly, then start and goal points in its zones.

    ``start_ok``/``goal_ok`` accept candidate points; when no start passes ``start_ok`` within the
    sampling budget, ``start_fallback`` (if given) is used instead of failing.
    """
    routes = list(map_def.robot_routes)
    if not routes:
        raise ConfigError("the map has no robot route", source=map_def.source, item=map_def.name)
    spawn_ids = sorted({r.spawn_id for r in routes})
    sid = spawn_ids[int(rng.integers(len(spawn_ids)))]
    candidates = [r for r in routes if r.spawn_id == sid]
    route = candidates[int(rng.integers(len(candidates)))]
    zone = map_def.robot_spawn_zones[route.spawn_id]
    start = sample_free(
        zone, 1, rng, zone_mode, start_ok, required=start_fallback is None, what="robot spawn zone"
    )
    if start is None:
        start = sample_free(zone, 1, rng, zone_mode, start_fallback, what="robot spawn zone")
    start = start[0]
    goal = sample_free(
        map_def.robot_goal_zones[route.goal_id], 1, rng, zone_mode, goal_ok, what="robot goal zone"
    )[0]
    waypoints = np.vstack([np.asarray(route.waypoints, dtype=float), goal[None]])
    if np.hypot(*(waypoints[0] - start)) <= tolerance:
        # spawn hand-off: first target = where the route leaves the tolerance circle around the start
        exit_ = polyline_exit_point(waypoints, start, tolerance + 1e-6)
        if exit_ is not None:
            point, k = exit_
            waypoints = np.vstack([point[None], waypoints[k + 1 :]])
    d = waypoints[1] - waypoints[0] if len(waypoints) >= 2 else waypoints[0] - start
    return RobotRoute(
        start=start, heading=float(np.arctan2(d[1], d[0])), waypoints=waypoints, tolerance=tolerance
    )
