"""What a learned policy sees: the Gymnasium env's observation, built from the simulator's :class:`Observation`.

One public function, so that a policy trained in ``foresight/CrowdNav-v0`` and the planner that later drives it
(``core.planners.sb3``) see the same numbers. Robot frame: x ahead, y to the left; metres, seconds, radians.

  ``robot``      (3,)    v [m/s], omega [rad/s], robot radius [m]
  ``goal``       (3,)    goal x, y, distance
  ``route``      (R, 2)  the next R route waypoints (current first), padded with the goal
  ``peds``       (K, 4)  the nearest K pedestrians: x, y, vx, vy (velocity relative to the ground, robot frame)
  ``ped_mask``   (K,)    1 where a ``peds`` row holds a pedestrian, 0 for padding
  ``occupancy``  (S, S)  optional: 1 where a cell centre (a square grid of ``occupancy_resolution`` m around the
                         robot, robot frame) lies within half a cell of a wall or outside the map
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from foresight.core.sim.observation import Observation


@dataclass(frozen=True)
class ObservationLayout:
    """The shape of a policy's observation (the env's constructor arguments of the same names)."""

    max_peds: int = 8
    route_points: int = 4
    occupancy: bool = False
    occupancy_size: int = 16
    occupancy_resolution: float = 0.5


def _rotation(heading: float) -> np.ndarray:
    c, s = np.cos(heading), np.sin(heading)
    return np.array([[c, s], [-s, c]])  # world -> robot frame


def policy_observation(obs: Observation, layout: ObservationLayout) -> dict[str, np.ndarray]:
    """The env's observation (float32 arrays keyed as in the module docstring) of one simulator observation."""
    k, r = layout.max_peds, layout.route_points
    rot, here = _rotation(float(obs.robot_pose[2])), obs.robot_pose[:2]
    goal = rot @ (obs.goal - here)
    route = np.vstack([obs.route, np.repeat(obs.goal[None], r, axis=0)])[:r]
    peds, mask = np.zeros((k, 4)), np.zeros(k)
    if len(obs.ped_positions):
        rel = obs.ped_positions - here
        nearest = np.argsort(np.hypot(rel[:, 0], rel[:, 1]), kind="stable")[:k]
        n = nearest.size
        peds[:n, :2] = rel[nearest] @ rot.T
        peds[:n, 2:] = obs.ped_velocities[nearest] @ rot.T
        mask[:n] = 1.0
    out = {
        "robot": np.array([obs.robot_velocity[0], obs.robot_velocity[1], obs.robot_radius]),
        "goal": np.array([goal[0], goal[1], np.hypot(*goal)]),
        "route": (route - here) @ rot.T,
        "peds": peds,
        "ped_mask": mask,
    }
    if layout.occupancy:
        cells = (
            np.arange(layout.occupancy_size) - (layout.occupancy_size - 1) / 2
        ) * layout.occupancy_resolution
        gx, gy = np.meshgrid(cells, cells, indexing="xy")
        world = here + np.stack([gx, gy], axis=-1) @ rot  # robot frame -> world
        out["occupancy"] = (obs.static.distance(world) < layout.occupancy_resolution / 2).astype(float)
    return {key: value.astype(np.float32) for key, value in out.items()}


def action_bounds(limits: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) of the command (v, omega), or (vx, vy) for a holonomic robot, from the robot's limits."""
    if limits.get("holonomic", 0.0):
        low, high = [-limits["v_max"], -limits["v_max"]], [limits["v_max"], limits["v_max"]]
    else:
        low, high = [limits["v_min"], -limits["w_max"]], [limits["v_max"], limits["w_max"]]
    return np.array(low, np.float32), np.array(high, np.float32)


def command_of(
    action: np.ndarray, low: np.ndarray, high: np.ndarray, normalized: bool
) -> tuple[float, float]:
    """The robot command of a policy's action: clipped to [low, high], or mapped from [-1, 1] when normalised."""
    a = np.asarray(action, dtype=float).reshape(-1)[:2]
    if normalized:
        a = low + (np.clip(a, -1.0, 1.0) + 1.0) * 0.5 * (high - low)
    a = np.clip(a, low, high)
    return float(a[0]), float(a[1])
