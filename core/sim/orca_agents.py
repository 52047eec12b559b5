"""ORCA agents (RVO2 through pyrvo) for a crowd of fixed size: one simulator per episode, inputs overwritten each step.

Agents are never removed (pyrvo's ``clear_agents`` leaves dangling pointers in RVO2's k-d tree, see
``core.planners.orca``); a crowd's size is fixed per episode (humans respawn), so one simulator serves it. Each
step sets every agent's position, velocity, preferred velocity, radius and max speed, runs one RVO2 step and reads
the new velocities; positions are integrated by the caller in double precision. An agent's new velocity depends
on the others' positions, velocities and radii only, so one shared simulator gives what CrowdNav's one simulator
per human gives.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pyrvo

from foresight.core.scenarios.crowd_models import OrcaPedestrians


class OrcaAgents:
    def __init__(self, n: int, params: OrcaPedestrians, dt: float, obstacles: list[np.ndarray]):
        self.n = n
        sim: Any = pyrvo.RVOSimulator()
        sim.set_time_step(float(dt))
        for poly in obstacles:
            sim.add_obstacle([(float(x), float(y)) for x, y in poly])
        if obstacles:
            sim.process_obstacles()
        for _ in range(n):
            sim.add_agent(
                (0.0, 0.0),
                params.neighbor_dist,
                params.max_neighbors,
                params.time_horizon,
                params.time_horizon_obst,
                0.3,
                1.0,
                (0.0, 0.0),
            )
        self.sim = sim

    def step(
        self, pos: np.ndarray, vel: np.ndarray, pref: np.ndarray, radius: np.ndarray, vmax: np.ndarray
    ) -> np.ndarray:
        """New velocities (n, 2) [m/s] of agents at ``pos`` (n, 2) moving at ``vel`` and preferring ``pref``."""
        sim = self.sim
        for i in range(self.n):
            sim.set_agent_position(i, (float(pos[i, 0]), float(pos[i, 1])))
            sim.set_agent_velocity(i, (float(vel[i, 0]), float(vel[i, 1])))
            sim.set_agent_pref_velocity(i, (float(pref[i, 0]), float(pref[i, 1])))
            sim.set_agent_radius(i, float(radius[i]))
            sim.set_agent_max_speed(i, float(vmax[i]))
        sim.do_step()
        return np.array([sim.get_agent_velocity(i).to_tuple() for i in range(self.n)], dtype=float).reshape(
            self.n, 2
        )


def obstacle_polygons(obstacles) -> list[np.ndarray]:
    """A map's obstacle polygons counter-clockwise, as RVO2 wants them (positive signed area)."""
    out = []
    for poly in obstacles:
        p = np.asarray(poly, dtype=float)
        x, y = p[:, 0], p[:, 1]
        area = 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))
        out.append(p if area > 0 else p[::-1])
    return out


class OrcaCrowdDynamics:
    """``pedestrian_model: orca`` for a map's crowd: each pedestrian an ORCA agent heading for its current goal at its
    desired speed (the behaviours set goals, respawns and waits as for the social-force crowd); the map's obstacles
    are RVO2 obstacles. Stands in for ``core.sim.crowd.CrowdDynamics`` (same ``step``)."""

    def __init__(
        self, crowd, params: OrcaPedestrians, dt: float, ped_radius: float, robot_radius: float, obstacles
    ):
        self.c, self.params, self.dt = crowd, params, dt
        self.ped_radius, self.robot_radius = ped_radius, robot_radius
        self.n = len(crowd.pos)
        self.agents = OrcaAgents(self.n + int(params.robot_visible), params, dt, obstacle_polygons(obstacles))
        self.robot_vel = np.zeros(2)  #: set by the simulator before each step (a visible robot's velocity)

    def step(self, robot: complex, centroids=None) -> None:
        if self.n == 0:
            return
        c, margin = self.c, 0.01 + self.params.safety_space
        pos, vel = c.pos.copy(), c.vel.copy()
        to_goal = c.goal - pos
        dist = np.hypot(to_goal[:, 0], to_goal[:, 1])
        speed = np.minimum(c.vmax, dist / self.dt)  # arrive without overshooting
        pref = to_goal * (speed / np.maximum(dist, 1e-12))[:, None]
        rad, vmax = np.full(self.n, self.ped_radius + margin), c.vmax.copy()
        if self.params.robot_visible:
            pos = np.vstack([pos, [[robot.real, robot.imag]]])
            vel = np.vstack([vel, self.robot_vel[None]])
            pref = np.vstack([pref, self.robot_vel[None]])
            rad = np.append(rad, self.robot_radius + margin)
            vmax = np.append(vmax, max(float(np.hypot(*self.robot_vel)), 1e-3))
        new = self.agents.step(pos, vel, pref, rad, vmax)[: self.n]
        c.z[:] = c.z + self.dt * (new[:, 0] + 1j * new[:, 1])
        c.zv[:] = new[:, 0] + 1j * new[:, 1]
