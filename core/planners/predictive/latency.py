"""Planning under command latency: the decision is made for the moment its command takes effect.

With ``robot_config.command_latency_s`` = L, the command chosen now acts from t + L on, and until then the robot
carries out the commands already issued (``Observation.pending_commands``). So the rollouts start from the state
the robot will be in at t + L (those commands rolled forward with the simulator's own kinematics,
``core.sim.latency.advance``), and the forecast is read L seconds later: the pedestrians' positions at rollout time
tau are the forecast's at L + tau (linear between its points, from each pedestrian's observed position at t = 0, and
beyond its last point at its last velocity); their spreads likewise, held beyond the last. The planner sees an
observation of t + L: the robot's predicted state and the pedestrians where the forecast puts them then.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from foresight.core.errors import ConfigError
from foresight.core.planners.predictive.forecast_input import PlannerForecast, _current, resample
from foresight.core.predict.forecaster import SIGMA_FLOOR
from foresight.core.sim.latency import advance
from foresight.core.sim.observation import Observation
from foresight.core.sim.robot import RobotLimits


def check_latency(latency: float, horizon: float, scenario: str) -> None:
    """A latency at or beyond the planner's horizon leaves it nothing to plan: refused, naming the field."""
    if latency >= horizon:
        raise ConfigError(
            f"robot_config.command_latency_s {latency:g} s must be below the predictive planner's horizon "
            f"({horizon:g} s: forecast plus search.extra_horizon_s)",
            source=scenario,
            item="robot_config.command_latency_s",
        )


def delayed(obs: Observation) -> bool:
    """True when commands are in flight (the scenario has a command latency)."""
    return obs.pending_commands is not None and len(obs.pending_commands) > 0


def start_state(obs: Observation, limits: RobotLimits) -> np.ndarray:
    """(5,) the robot's state when a command issued now takes effect."""
    state = np.concatenate([obs.robot_pose, obs.robot_velocity]).astype(float)
    if not delayed(obs):
        return state
    return advance(state, obs.pending_commands, obs.pending_durations, limits)


def look_ahead(
    obs: Observation, pf: PlannerForecast, limits: RobotLimits
) -> tuple[Observation, PlannerForecast]:
    """The observation and forecast of t + L (module docstring); unchanged without latency."""
    if not delayed(obs):
        return obs, pf
    lag = float(np.sum(obs.pending_durations))
    state = start_state(obs, limits)
    times = np.asarray(pf.times, dtype=float)
    pos = np.asarray(pf.positions, dtype=float)
    now = _current(obs, np.asarray(pf.ped_ids, dtype=np.int64), pos, times) if len(pos) else pos[:, 0]
    if len(pos):
        t_ext = np.concatenate([times, [times[-1] + lag]])
        last = pos[:, -1] - (pos[:, -2] if len(times) > 1 else now)
        span = times[-1] - (times[-2] if len(times) > 1 else 0.0)
        ext = np.concatenate([pos, (pos[:, -1] + last * (lag / span))[:, None]], axis=1)
        shifted = resample(ext, t_ext, now, times + lag)
        sigma = resample(
            np.asarray(pf.sigma, dtype=float), times, np.full(len(pos), SIGMA_FLOOR), times + lag
        )
        at_lag = resample(ext, t_ext, now, np.array([lag]))[:, 0]
    else:
        shifted, sigma, at_lag = pos, np.asarray(pf.sigma, dtype=float), now
    peds = np.asarray(obs.ped_positions, dtype=float) + lag * np.asarray(obs.ped_velocities, dtype=float)
    ids = np.asarray(pf.ped_ids, dtype=np.int64)
    w = np.ones(len(ids)) if pf.weights is None else np.asarray(pf.weights, dtype=float)
    for i, pid in enumerate(np.asarray(obs.ped_ids, dtype=np.int64)):
        rows = ids == pid
        if rows.any():  # where the forecast puts the pedestrian at t + L (the mixture's mean)
            peds[i] = np.average(at_lag[rows], axis=0, weights=w[rows])
    ahead = dataclasses.replace(
        obs,
        robot_pose=state[:3].copy(),
        robot_velocity=state[3:].copy(),
        ped_positions=peds,
        pending_commands=None,
        pending_durations=None,
    )
    return ahead, dataclasses.replace(pf, positions=shifted, sigma=sigma)
