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
