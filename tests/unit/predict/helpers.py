"""Hand-built observations and traces for the prediction tests."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from foresight.core.sim.observation import Observation


def make_obs(
    step: int, robot_pose, ids, positions, dt: float = 0.1, robot_velocity=(0.5, 0.1), waypoint=(10.0, 5.0)
) -> Observation:
    ids = np.asarray(ids, dtype=np.int64)
    positions = np.asarray(positions, dtype=float).reshape(len(ids), 2)
    return Observation(
        step=step,
        time=step * dt,
        dt=dt,
        robot_pose=np.asarray(robot_pose, float),
        robot_velocity=np.asarray(robot_velocity, float),
        robot_radius=0.3,
        waypoint=np.asarray(waypoint, float),
        goal=np.asarray(waypoint, float),
        route=np.asarray([waypoint], float),
        goal_tolerance=0.5,
        ped_ids=ids,
        ped_positions=positions,
        ped_velocities=np.zeros_like(positions),
        ped_radius=0.3,
        static=None,
    )


def make_trace(robot: np.ndarray, ped_ids: np.ndarray, ped_pos: np.ndarray, dt: float = 0.1):
    """A stand-in with the trace contract's arrays: robot (T+1, 5), ped_ids (T+1, N), ped_pos (T+1, N, 2)."""
    return SimpleNamespace(
        robot=robot,
        ped_ids=ped_ids,
        ped_pos=ped_pos,
        ped_vel=np.zeros_like(ped_pos),
        dt=dt,
        command=np.zeros((len(robot) - 1, 2)),
    )


def scripted_episode(steps: int = 40, seed: int = 0):
    """A small deterministic episode: moving turning robot, 4 pedestrians, one respawns (new id) at step 20.

    Returns (trace, observations, waypoints (T+1, 2)).
    """
    rng = np.random.default_rng(seed)
    t = np.arange(steps + 1) * 0.1
    robot = np.zeros((steps + 1, 5))
    robot[:, 0], robot[:, 1] = 1.0 + 0.8 * t, 2.0 + 0.2 * t**2
    robot[:, 2] = 0.3 + 0.4 * t
    robot[:, 3], robot[:, 4] = 0.8, 0.4
    start = rng.uniform(0, 8, size=(4, 2))
    vel = rng.uniform(-1.2, 1.2, size=(4, 2))
    ped_pos = start[None] + t[:, None, None] * vel[None] + 0.05 * np.sin(3 * t)[:, None, None]
    ped_ids = np.tile(np.arange(4, dtype=np.int64), (steps + 1, 1))
    ped_ids[20:, 2] = 7  # respawned: new id, teleported
    ped_pos[20:, 2] += 5.0
    ped_ids[:5, 3] = -1  # slot empty at the start
    waypoints = np.stack([np.full(steps + 1, 9.0), np.where(t < 2, 4.0, 6.0)], axis=1)
    trace = make_trace(robot, ped_ids, ped_pos)
    obs = []
    for k in range(steps + 1):
        present = ped_ids[k] >= 0
        obs.append(
            make_obs(
                k,
                robot[k, :3],
                ped_ids[k][present],
                ped_pos[k][present],
                robot_velocity=robot[k, 3:5],
                waypoint=waypoints[k],
            )
        )
    return trace, obs, waypoints
