"""ORCA baseline through pyrvo (the RVO2 library), static obstacles included.

One RVO2 simulator per episode holds the obstacles (map polygons plus four boundary walls) and
one agent per body; each decision overwrites the agents' states: the robot is agent 0 with a preferred velocity toward
its current route waypoint, every pedestrian an agent moving at its observed velocity. After one
RVO2 step the robot's new velocity is the ORCA velocity, tracked with a unicycle command.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pyrvo
from pydantic import BaseModel, ConfigDict, Field

from foresight.core.planners.social_force import command_for, cruise_speed, limits_of
from foresight.core.sim.observation import Observation
from foresight.core.sim.planner import EpisodeInfo


class OrcaConfig(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")

    neighbor_dist: float = Field(default=8.0, gt=0)  #: [m]
    max_neighbors: int = Field(default=16, ge=1, le=256)
    time_horizon: float = Field(default=2.0, gt=0)  #: [s] against pedestrians
    time_horizon_obst: float = Field(default=1.0, gt=0)  #: [s] against static obstacles
    radius_margin: float = Field(default=0.1, ge=0)  #: added to the true robot radius [m]
    ped_radius_margin: float = Field(default=0.0, ge=0)  #: added to every pedestrian's radius [m]
    #: near the waypoint the preferred speed is at most distance x this [1/s]; None = 1 / dt (arrive in one step).
    #: CrowdNav's ORCA uses 1 (its preferred velocity is the goal vector itself within 1 m)
    arrival_gain: float | None = Field(default=None, gt=0)
    #: False = every pedestrian at the observation's nominal ``ped_radius``, whatever its own radius (CrowdNav++'s
    #: ORCA robot keeps the radii of its first observation, 0.3 m for the humans it has not yet seen)
    observed_radii: bool = True
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
        self._agents = -1
        self._polys: list[np.ndarray] = []
        self._dt = 0.1
        self._diag: dict[str, Any] | None = None

    def reset(self, info: EpisodeInfo) -> None:
        m = info.scenario.map
        walls = _boundary_walls(m.width, m.height, self.config.wall_thickness)
        self._polys = [_ccw(np.asarray(p, dtype=float)) for p in m.obstacles] + [_ccw(w) for w in walls]
        self._dt = float(info.dt)
        self._sim, self._agents = None, -1
        self._diag = None

    @property
    def diagnostics(self) -> dict[str, Any] | None:
        return self._diag

    def _simulator(self, n_agents: int) -> Any:
        """An RVO2 simulator with the static obstacles and ``n_agents`` agents, kept while the count holds.

        Agents are never removed: pyrvo's ``clear_agents`` deletes them but leaves their pointers in
        RVO2's agent k-d tree (use after free: episodes then differ from run to run). The pedestrian
        count is fixed per episode (pedestrians respawn), so one simulator serves the whole episode.
        """
        if self._sim is None or self._agents != n_agents:
            c = self.config
            sim = pyrvo.RVOSimulator()
            sim.set_time_step(self._dt)
            for poly in self._polys:
                sim.add_obstacle([(float(x), float(y)) for x, y in poly])
            sim.process_obstacles()
            for _ in range(n_agents):
                sim.add_agent(
                    (0.0, 0.0),
                    c.neighbor_dist,
                    c.max_neighbors,
                    c.time_horizon,
                    c.time_horizon_obst,
                    1.0,
                    1.0,
                    (0.0, 0.0),
                )
            self._sim, self._agents = sim, n_agents
        return self._sim

    def plan(self, obs: Observation) -> tuple[float, float]:
        c = self.config
        vmax, wmax = limits_of(obs.robot_limits)
        x, y, th = (float(a) for a in obs.robot_pose)
        v = float(obs.robot_velocity[0])
        sim = self._simulator(1 + len(obs.ped_positions))
        to_wp = np.asarray(obs.waypoint, dtype=float) - obs.robot_pose[:2]
        dist = float(np.hypot(*to_wp))
        reach = dist / max(obs.dt, 1e-9) if c.arrival_gain is None else dist * c.arrival_gain
        pref = (
            to_wp / dist * min(cruise_speed(obs.robot_limits, c.speed_ratio), reach)
            if dist > 1e-9
            else np.zeros(2)
        )
        _set_agent(
            sim,
            0,
            (x, y),
            (v * np.cos(th), v * np.sin(th)),
            tuple(pref),
            obs.robot_radius + c.radius_margin,
            vmax,
        )
        radii = (
            obs.radii() if c.observed_radii else np.full(len(obs.ped_positions), obs.ped_radius)
        ).tolist()
        for i, (p, u) in enumerate(zip(obs.ped_positions, obs.ped_velocities, strict=True), start=1):
            r = radii[i - 1] + c.ped_radius_margin
            _set_agent(sim, i, tuple(p), tuple(u), tuple(u), r, max(float(np.hypot(*u)), 1e-3))
        sim.do_step()
        u = np.asarray(sim.get_agent_velocity(0).to_tuple())
        cmd = command_for(u, obs, vmax, wmax, c.turn_gain)
        self._diag = {"command": cmd, "orca_velocity": u.tolist(), "preferred_velocity": pref.tolist()}
        return cmd


def _set_agent(
    sim: Any, i: int, pos: tuple, vel: tuple, pref: tuple, radius: float, max_speed: float
) -> None:
    """Overwrite every per-decision input of agent ``i`` (nothing carries over between decisions)."""
    sim.set_agent_position(i, (float(pos[0]), float(pos[1])))
    sim.set_agent_velocity(i, (float(vel[0]), float(vel[1])))
    sim.set_agent_pref_velocity(i, (float(pref[0]), float(pref[1])))
    sim.set_agent_radius(i, float(radius))
    sim.set_agent_max_speed(i, float(max_speed))
