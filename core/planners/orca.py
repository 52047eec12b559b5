"""ORCA baseline through pyrvo (the RVO2 library), static obstacles included.

Each decision rebuilds the agent set of one RVO2 simulator whose obstacles (map polygons plus four
boundary walls) were added once at ``reset``: the robot is agent 0 with a preferred velocity toward
its current route waypoint, every pedestrian an agent moving at its observed velocity. After one
RVO2 step the robot's new velocity is the ORCA velocity, tracked with a unicycle command.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pyrvo
from pydantic import BaseModel, ConfigDict, Field

from core.planners.base import EpisodeInfo
from core.planners.social_force import limits_of, velocity_to_unicycle
from core.sim.observation import Observation


class OrcaConfig(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")

    neighbor_dist: float = Field(default=8.0, gt=0)  #: [m]
    max_neighbors: int = Field(default=16, ge=1)
    time_horizon: float = Field(default=2.0, gt=0)  #: [s] against pedestrians
    time_horizon_obst: float = Field(default=1.0, gt=0)  #: [s] against static obstacles
    radius_margin: float = Field(default=0.1, ge=0)  #: added to the true robot radius [m]
    speed_ratio: float = Field(default=1.0, gt=0, le=1)  #: preferred speed, ratio of the max speed
    turn_gain: float = Field(default=1.5, gt=0)  #: heading error -> turn rate [1/s]
    wall_thickness: float = Field(default=1.0, gt=0)  #: boundary walls outside the map [m]


def _ccw(poly: np.ndarray) -> np.ndarray:
    """RVO2 wants obstacle polygons counter-clockwise (positive signed area)."""
    x, y = poly[:, 0], poly[:, 1]
    area = 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))
    return poly if area > 0 else poly[::-1]


def _boundary_walls(w: float, h: float, t: float) -> list[np.ndarray]:
    rects = [(-t, -t, w + 2 * t, t), (-t, h, w + 2 * t, t), (-t, 0, t, h), (w, 0, t, h)]
    return [np.array([[x, y], [x + a, y], [x + a, y + b], [x, y + b]], dtype=float) for x, y, a, b in rects]


class OrcaPlanner:
    """ORCA velocity obstacles (RVO2 via pyrvo) with a unicycle tracking the ORCA velocity."""

    name = "orca"

    def __init__(self, config: OrcaConfig | None = None):
        self.config = config or OrcaConfig()
        self._sim: Any = None
        self._diag: dict[str, Any] | None = None

    def reset(self, info: EpisodeInfo) -> None:
        c = self.config
        m = info.scenario.map
        sim = pyrvo.RVOSimulator()
        sim.set_time_step(float(info.dt))
        polys = [np.asarray(p, dtype=float) for p in m.obstacles] + _boundary_walls(m.width, m.height, c.wall_thickness)
        for poly in polys:
            sim.add_obstacle([tuple(map(float, v)) for v in _ccw(poly)])
        sim.process_obstacles()
        self._sim = sim
        self._diag = None

    @property
    def diagnostics(self) -> dict[str, Any] | None:
        return self._diag

    def plan(self, obs: Observation) -> tuple[float, float]:
        c, sim = self.config, self._sim
        vmax, wmax = limits_of(obs.robot_limits)
        x, y, th = (float(a) for a in obs.robot_pose)
        v = float(obs.robot_velocity[0])
        sim.clear_agents()
        sim.add_agent((x, y), c.neighbor_dist, c.max_neighbors, c.time_horizon, c.time_horizon_obst,
                      obs.robot_radius + c.radius_margin, vmax, (v * np.cos(th), v * np.sin(th)))
        to_wp = np.asarray(obs.waypoint, dtype=float) - obs.robot_pose[:2]
        dist = float(np.hypot(*to_wp))
        pref = to_wp / dist * min(c.speed_ratio * vmax, dist / max(obs.dt, 1e-9)) if dist > 1e-9 else np.zeros(2)
        sim.set_agent_pref_velocity(0, (float(pref[0]), float(pref[1])))
        for p, u in zip(obs.ped_positions, obs.ped_velocities, strict=True):
            speed = float(np.hypot(*u))
            i = sim.add_agent((float(p[0]), float(p[1])), c.neighbor_dist, c.max_neighbors, c.time_horizon,
                              c.time_horizon_obst, obs.ped_radius, max(speed, 1e-3), (float(u[0]), float(u[1])))
            sim.set_agent_pref_velocity(i, (float(u[0]), float(u[1])))
        sim.do_step()
        u = np.asarray(sim.get_agent_velocity(0).to_tuple())
        cmd = velocity_to_unicycle(u, th, vmax, wmax, c.turn_gain)
        self._diag = {"command": cmd, "orca_velocity": u.tolist(), "preferred_velocity": pref.tolist()}
        return cmd
