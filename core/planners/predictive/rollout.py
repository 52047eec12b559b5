"""Roll candidate command sequences out with the simulator's own robot kinematics.

The planner never re-implements the robot: a rollout is ``core.sim.robot.unicycle_rollout``
(``unicycle_step`` repeated, vectorised over the steps) with the episode's limits and simulator dt,
so a rollout is exactly what the simulator would do with the same commands. Costs are then read
at the simulator steps that coincide with the forecast's times (``eval_index``), so robot and
pedestrians are compared at the same instants.
"""

from __future__ import annotations

import numpy as np

from foresight.core.errors import ConfigError
from foresight.core.sim.robot import RobotLimits, robot_rollout, unicycle_rollout


def eval_steps(times: np.ndarray, sim_dt: float) -> np.ndarray:
    """Simulator step index (0-based, into the rollout) of each forecast time (K,); they must coincide."""
    k = np.rint(times / sim_dt).astype(np.int64)
    if np.any(np.abs(k * sim_dt - times) > 1e-6) or np.any(k < 1):
        raise ConfigError(
            f"forecast times {times.tolist()} are not whole simulator steps of {sim_dt} s",
            item="forecast.times",
        )
    return k - 1


def rollout(state0: np.ndarray, commands: np.ndarray, limits: RobotLimits, dt: float) -> np.ndarray:
    """States (B, n, 5) after each of n steps from ``state0`` (B, 5) or (5,) under ``commands`` (B, n, 2).

    ``unicycle_rollout`` (repeated ``unicycle_step`` without a Python loop over the steps) for differential drive,
    else the robot's own kinematics (``robot_rollout``); for a holonomic robot the commands are velocities in the
    frame of the start state's heading, so rollouts done at heading 0 turn with the robot like the others.
    """
    if limits.kind == "differential_drive":
        return unicycle_rollout(state0, commands, limits, dt)
    return robot_rollout(state0, commands, limits, dt)


SPEED_DECIMALS = (
    12  #: start speeds are rounded to this many decimals (floating-point noise) before the lookup
)


class FrameRollouts:
    """``rollout`` of fixed command sets, each done once per starting speed in the robot's frame, then turned and
    moved to the robot's pose.

    The kinematics do not depend on where the robot stands or which way it faces, only on its speeds
    (v, omega) and the commands, so a decision's rollouts are the stored ones for its speeds, rotated
    and translated (equal to ``rollout`` up to floating-point rounding). The planner's command sets are
    fixed per episode and its speeds come from a few ramps, so most decisions reuse stored rollouts:
    the rollout was a quarter of a decision's time. Speeds are looked up to ``SPEED_DECIMALS`` (a ramp reaches
    0.3 as 0.1 + 0.2 and as 0.30000000000000004: one speed, one stored rollout, done from the rounded speed), and
    the least recently used rollout makes room for a new one.
    """

    def __init__(self, limits: RobotLimits, dt: float, capacity: int = 512):
        self.limits, self.dt, self.capacity = limits, dt, capacity
        self._local: dict[tuple, np.ndarray] = {}

    def __call__(self, states0: np.ndarray, commands: np.ndarray, key: object) -> np.ndarray:
        """States (P * B, n, 5): each start state of ``states0`` (P, 5) under every sequence of ``commands`` (B, n, 2),
        start by start; ``key`` names the command set (the same key, the same commands). Headings come out
        unwrapped (every use of them is periodic)."""
        local = []
        for v, w in np.round(states0[:, 3:], SPEED_DECIMALS).tolist():
            done = self._local.pop(
                (key, v, w), None
            )  # stored again below: the last used is the last in the dict
            if done is None:
                if len(self._local) >= self.capacity:
                    del self._local[
                        next(iter(self._local))
                    ]  # the least recently used (dicts keep insertion order)
                start = np.repeat(np.array([[0.0, 0.0, 0.0, v, w]]), len(commands), axis=0)
                done = rollout(start, commands, self.limits, self.dt)
            self._local[(key, v, w)] = done
            local.append(done)
        local = local[0][None] if len(local) == 1 else np.stack(local)  # (P, B, n, 5)
        s0 = states0[:, None, None, :]
        c, s = np.cos(s0[..., 2]), np.sin(s0[..., 2])
        x, y = local[..., 0], local[..., 1]
        out = np.empty(local.shape)
        out[..., 0] = s0[..., 0] + c * x - s * y
        out[..., 1] = s0[..., 1] + s * x + c * y
        out[..., 2] = local[..., 2] + s0[..., 2]
        out[..., 3:] = local[..., 3:]
        return out.reshape((-1,) + out.shape[2:])


def extend_forecast(
    positions: np.ndarray, sigma: np.ndarray, times: np.ndarray, extra_steps: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Append ``extra_steps`` on the same grid: each pedestrian at its final forecast velocity, its spread
    growing at its final rate. Returns positions (N, K+e, 2), sigma (N, K+e) and times (K+e,)."""
    if extra_steps <= 0:
        return positions, sigma, times
    dt = times[1] - times[0] if len(times) > 1 else times[0]
    vel = (positions[:, -1] - positions[:, -2]) / dt if len(times) > 1 else np.zeros_like(positions[:, -1])
    growth = (sigma[:, -1] - sigma[:, -2]) / dt if len(times) > 1 else np.zeros_like(sigma[:, -1])
    k = np.arange(1, extra_steps + 1) * dt
    ext = positions[:, -1:, :] + k[None, :, None] * vel[:, None, :]
    ext_sigma = sigma[:, -1:] + k[None, :] * growth[:, None]
    return (
        np.concatenate([positions, ext], axis=1),
        np.concatenate([sigma, ext_sigma], axis=1),
        np.concatenate([times, times[-1] + k]),
    )
