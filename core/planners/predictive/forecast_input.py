"""A forecast as the planner's cost reads it: world frame, on the rollout's time grid, one row per mode.

Any predictor's forecast (``core.predict.forecast``) enters here. Its frame is converted to the world; times
that are not whole simulator steps, or steps coarser than the planner's (an ETH/UCY model's 0.4 s), are
resampled by linear interpolation onto the planner's step (``PLANNER_TIMEBASE.dt``, out to the shorter of the
forecast's and the planner's horizon), from each pedestrian's observed position at t = 0; spreads likewise, from
``SIGMA_FLOOR``. Each mode becomes a row of its own with its weight, so the cost sums every mode's chance-margin
excess and contact probability weighted (the mixture's expectation). A one-mode world-frame forecast on a usable
grid passes through untouched: the same arrays, the same decisions as before modes existed.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from foresight.core.predict.forecast import Forecast
from foresight.core.predict.forecaster import SIGMA_FLOOR
from foresight.core.predict.timebase import PLANNER_TIMEBASE
from foresight.core.sim.observation import Observation

MIN_MODE_WEIGHT = 1e-3  #: modes less likely than this are dropped (their expected contact is negligible)


@dataclass(frozen=True)
class PlannerForecast:
    ped_ids: np.ndarray  #: (R,) the pedestrian of each row (repeated once per kept mode)
    positions: np.ndarray  #: (R, T, 2) world [m] at ``times``
    sigma: np.ndarray  #: (R, T) isotropic per-axis std [m]
    times: np.ndarray  #: (T,) whole simulator steps ahead [s]
    weights: np.ndarray | None  #: (R,) each row's mode probability; None: one mode per pedestrian (weight 1)


def on_grid(times: np.ndarray, sim_dt: float, step: float = PLANNER_TIMEBASE.dt) -> bool:
    """True when ``times`` are whole simulator steps no coarser than the planner's ``step`` (or than one simulator
    step, where that is coarser: CrowdNav's 0.25 s): used as they are."""
    k = np.rint(times / sim_dt)
    whole = bool(np.all(np.abs(k * sim_dt - times) <= 1e-6) and np.all(k >= 1))
    gaps = np.diff(np.concatenate([[0.0], times]))
    return whole and bool(np.all(gaps <= max(step, sim_dt) + 1e-6))  # no grid is finer than the simulator's


def planner_grid(times: np.ndarray, sim_dt: float, step: float = PLANNER_TIMEBASE.dt) -> np.ndarray:
    """The planner's times for a forecast reaching ``times[-1]``: its step (rounded to whole simulator steps) out to
    the shorter of that and the planner's horizon."""
    k = max(1, int(round(step / sim_dt)))
    dt = k * sim_dt
    horizon = min(float(times[-1]), PLANNER_TIMEBASE.horizon * PLANNER_TIMEBASE.dt)
    n = max(1, int(np.floor(horizon / dt + 1e-6)))
    return dt * np.arange(1, n + 1, dtype=np.float64)


def resample(values: np.ndarray, times: np.ndarray, start: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """Linear interpolation of ``values`` (R, T, ...) at ``times`` onto ``grid`` (G,), with ``start`` (R, ...) at
    t = 0; held at the last value beyond ``times[-1]``."""
    t = np.concatenate([[0.0], times])
    v = np.concatenate([start[:, None], values], axis=1)
    i = np.clip(np.searchsorted(t, grid, side="right") - 1, 0, len(t) - 2)
    a = np.clip((grid - t[i]) / (t[i + 1] - t[i]), 0.0, 1.0)
    shape = (1, len(grid)) + (1,) * (values.ndim - 2)
    a = a.reshape(shape)
    return v[:, i] * (1.0 - a) + v[:, i + 1] * a


def planner_forecast(fc: Forecast, obs: Observation, sim_dt: float) -> PlannerForecast:
    """The rows the planner's cost reads (module docstring)."""
    times = np.asarray(fc.times, dtype=float)
    if fc.n_modes == 1 and fc.frame == "world" and not fc.full_covariance and on_grid(times, sim_dt):
        return PlannerForecast(fc.ped_ids, fc.positions, fc.sigma, times, None)
    fc = fc.to_world()
    n, K, T = fc.modes.shape[:3]
    ids = np.repeat(np.asarray(fc.ped_ids, dtype=np.int64), K)
    pos = fc.modes.reshape(n * K, T, 2)
    sigma = fc.mode_sigma.reshape(n * K, T)
    weights = np.asarray(fc.weights, dtype=float).reshape(n * K)
    if not on_grid(times, sim_dt):
        grid = planner_grid(times, sim_dt)
        pos = resample(pos, times, _current(obs, ids, pos, times), grid)
        sigma = resample(sigma, times, np.full(len(ids), SIGMA_FLOOR), grid)
        times = grid
    keep = weights >= MIN_MODE_WEIGHT
    if not np.all(keep):
        ids, pos, sigma, weights = ids[keep], pos[keep], sigma[keep], weights[keep]
    return PlannerForecast(ids, pos, sigma, times, weights)


def _current(obs: Observation, ids: np.ndarray, pos: np.ndarray, times: np.ndarray) -> np.ndarray:
    """(R, 2) each row's pedestrian where it is now: observed, else its forecast taken back to t = 0."""
    obs_ids = np.asarray(obs.ped_ids, dtype=np.int64)
    same = ids[:, None] == obs_ids[None, :]
    found = np.any(same, axis=1) if len(obs_ids) else np.zeros(len(ids), dtype=bool)
    if len(times) > 1:
        back = pos[:, 0] - (pos[:, 1] - pos[:, 0]) * (times[0] / (times[1] - times[0]))
    else:
        back = pos[:, 0].copy()
    if found.any():
        back[found] = np.asarray(obs.ped_positions, dtype=float)[np.argmax(same[found], axis=1)]
    return back
