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
from foresight.core.sim.robot import RobotLimits, unicycle_rollout


def eval_steps(times: np.ndarray, sim_dt: float) -> np.ndarray:
    """Simulator step index (0-based, into the rollout) of each forecast time (K,); they must coincide."""
    k = np.rint(times / sim_dt).astype(np.int64)
    if np.any(np.abs(k * sim_dt - times) > 1e-6) or np.any(k < 1):
        raise ConfigError(
            f"forecast times {times.tolist()} are not whole simulator steps of {sim_dt} s", item="forecast.times"
        )
    return k - 1


def rollout(state0: np.ndarray, commands: np.ndarray, limits: RobotLimits, dt: float) -> np.ndarray:
    """States (B, n, 5) after each of n steps from ``state0`` (B, 5) or (5,) under ``commands`` (B, n, 2).

    ``unicycle_rollout``: repeated ``unicycle_step`` without a Python loop over the steps.
    """
    return unicycle_rollout(state0, commands, limits, dt)


def extend_forecast(positions: np.ndarray, sigma: np.ndarray, times: np.ndarray,
                    extra_steps: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
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
    return (np.concatenate([positions, ext], axis=1), np.concatenate([sigma, ext_sigma], axis=1),
            np.concatenate([times, times[-1] + k]))
