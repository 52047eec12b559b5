"""A holonomic robot in the predictive planner: its commands are velocities, sampled in the robot's frame.

The planner's rollouts are done once at heading 0 and turned with the robot (``FrameRollouts``); a holonomic
robot's state heading is its direction of motion, so velocities given in that frame turn with it too. The chosen
velocity goes back to the world frame for the simulator. The cost's command terms (speed, turning, smoothness)
were written for (v, omega); a velocity is read as (speed, bearing from straight ahead scaled to the turn-rate
limit): moving sideways or backwards costs as turning does.
"""

from __future__ import annotations

import math

import numpy as np

from foresight.core.sim.robot import RobotLimits


def to_world(local: np.ndarray, heading: float) -> tuple[float, float]:
    """A velocity (2,) in the frame of ``heading`` [rad] as world (vx, vy)."""
    c, s = math.cos(heading), math.sin(heading)
    x, y = float(local[0]), float(local[1])
    return c * x - s * y, s * x + c * y


def to_local(world: np.ndarray, heading: float) -> np.ndarray:
    """World velocities (..., 2) in the frame of ``heading`` [rad]."""
    world = np.asarray(world, dtype=float)
    c, s = math.cos(heading), math.sin(heading)
    out = np.empty(world.shape)
    out[..., 0] = c * world[..., 0] + s * world[..., 1]
    out[..., 1] = -s * world[..., 0] + c * world[..., 1]
    return out


def cost_commands(local: np.ndarray, limits: RobotLimits) -> np.ndarray:
    """Velocities (..., 2) in the robot's frame as (speed, bearing / pi x w_max): what the cost's (v, omega) terms
    read."""
    local = np.asarray(local, dtype=float)
    out = np.empty(local.shape)
    out[..., 0] = np.hypot(local[..., 0], local[..., 1])
    out[..., 1] = np.arctan2(local[..., 1], local[..., 0]) / np.pi * limits.w_max
    return out
