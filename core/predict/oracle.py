"""The oracle forecaster: forecasts that are the future, for measuring how much better prediction could help.

Where nobody reacts to the robot (``peds_have_robot_repulsion: false``, replays), the crowd walks the same whatever
the robot does, so its future can be recorded before the episode (``core.sim.feasibility.crowd_paths``, around a
robot standing at its start) and handed to the planner: each pedestrian's recorded position at the forecast times,
with a small fixed spread. A planner driven by it shows what perfect prediction would buy (the gap to the learned
and constant-velocity forecasts) and what it would not (the planner's own failures). Not exact where the recording
and the episode part: a respawn placed away from the moving robot, or someone the recording no longer holds (then
constant velocity from the observation).
"""

from __future__ import annotations

import numpy as np

from foresight.core.predict.forecast import Forecast
from foresight.core.predict.timebase import PLANNER_TIMEBASE, TimeBase
from foresight.core.scenarios.model import ResolvedScenario
from foresight.core.sim.observation import Observation

ORACLE_SIGMA = 0.05  #: [m] the spread the planner is told: small, never zero (its terms divide by it)


class OracleForecaster:
    """The Forecaster protocol over a recorded crowd: ``positions[t]`` (N_t, 2) and ``ids[t]`` (N_t,) at every
    simulator step ``t`` of ``dt`` seconds."""

    source = "oracle"

    def __init__(
        self,
        positions: list[np.ndarray],
        ids: list[np.ndarray],
        dt: float,
        timebase: TimeBase = PLANNER_TIMEBASE,
        sigma: float = ORACLE_SIGMA,
    ):
        self.timebase, self.dt, self.sigma = timebase, float(dt), float(sigma)
        #: step -> id -> position
        self._steps = [dict(zip(i.tolist(), p, strict=True)) for i, p in zip(ids, positions, strict=True)]
        self._obs: Observation | None = None

    @classmethod
    def for_episode(
        cls, scenario: ResolvedScenario, seed: int, max_steps: int | None = None, **kwargs
    ) -> OracleForecaster:
        """The crowd of this (scenario, seed) episode recorded around a robot standing at its start."""
        from foresight.core.sim.feasibility import crowd_paths

        sim, positions, ids = crowd_paths(scenario, seed, max_steps)
        return cls(positions, ids, sim.dt, **kwargs)

    def fit(self, sim_dt: float) -> None:
        """Forecast on whole simulator steps, as constant velocity does (CrowdNav's 0.25 s against 0.2 s): the
        recording holds the states at those steps only."""
        from foresight.core.predict.forecaster import fitted_timebase

        fitted = fitted_timebase(self.timebase, sim_dt)
        if fitted is not None:
            self.timebase = fitted

    def reset(self) -> None:
        self._obs = None

    def observe(self, obs: Observation) -> None:
        self._obs = obs

    def update(self, obs: Observation) -> Forecast:
        self.observe(obs)
        return self.forecast()

    def forecast(self) -> Forecast:
        obs, times = self._obs, self.timebase.times
        now = int(round(obs.time / self.dt))
        ahead = [self._steps[min(now + int(round(t / self.dt)), len(self._steps) - 1)] for t in times]
        ids = np.asarray(obs.ped_ids, dtype=np.int64)
        pos = np.empty((len(ids), len(times), 2))
        for i, pid in enumerate(ids.tolist()):
            for k, (t, step) in enumerate(zip(times, ahead, strict=True)):
                at = step.get(pid)
                pos[i, k] = at if at is not None else obs.ped_positions[i] + t * obs.ped_velocities[i]
        sigma = np.full((len(ids), len(times)), self.sigma)
        return Forecast.single(ids.copy(), pos, sigma, times, self.source, self.timebase)
