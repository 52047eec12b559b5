"""The live oracle: at every decision, the crowd's next seconds from a copy of the simulator's own crowd.

The recorded oracle (``core.predict.oracle``) records a whole episode's crowd around a robot standing at its start.
On CrowdNav's generated crowds (``core.sim.generated_crowd``) the humans never see the robot, but a new goal or a
replacement human is drawn clear of the robot where it then is, so the recording parts from the episode at the first
such draw and never rejoins it (every later draw of the shared random stream differs). This oracle copies the crowd
as it is at the decision (positions, goals, random stream) and steps the copy over the forecast horizon with the
robot standing where it is now: the future exactly, up to a draw inside the horizon that the robot's next few steps
would have changed. Generated crowds only; the copy shares the crowd's ORCA solver, whose state is set in full at
every step (``core.sim.orca_agents``), so stepping the copy leaves the episode untouched.
"""

from __future__ import annotations

import copy

import numpy as np

from foresight.core.errors import ConfigError
from foresight.core.predict.forecast import Forecast
from foresight.core.predict.oracle import ORACLE_SIGMA
from foresight.core.predict.timebase import PLANNER_TIMEBASE, TimeBase
from foresight.core.predict.uncertainty import GrowingSigma
from foresight.core.sim.observation import Observation


class LiveOracleForecaster:
    """The Forecaster protocol over ``simulator``'s generated crowd (pass the same simulator to ``run_episode``).

    ``sigma``: the spread the planner is told, fixed (the oracle's small one) or growing with the forecast's age
    (e.g. constant velocity's ``CV_SIGMA``: the truth's positions with cv's spread, so only the positions differ)."""

    source = "oracle_live"

    def __init__(
        self,
        simulator,  # noqa: ANN001
        timebase: TimeBase = PLANNER_TIMEBASE,
        sigma: float | GrowingSigma = ORACLE_SIGMA,
    ):
        self.sim, self.timebase = simulator, timebase
        self.sigma = sigma if isinstance(sigma, GrowingSigma) else float(sigma)
        self._obs: Observation | None = None

    def fit(self, sim_dt: float) -> None:
        """Forecast on whole simulator steps (``core.predict.forecaster.fitted_timebase``)."""
        from foresight.core.predict.forecaster import fitted_timebase

        fitted = fitted_timebase(self.timebase, sim_dt)
        if fitted is not None:
            self.timebase = fitted

    def reset(self) -> None:
        if getattr(self.sim, "generated", None) is None:
            raise ConfigError(
                "the live oracle needs a generated crowd (crowd_generator: the CrowdNav suites) in the simulator "
                "the episode runs in",
                item="crowd_generator",
            )
        self._obs = None

    def observe(self, obs: Observation) -> None:
        self._obs = obs

    def update(self, obs: Observation) -> Forecast:
        self.observe(obs)
        return self.forecast()

    def _copy(self):  # noqa: ANN202
        crowd = self.sim.generated
        agents, crowd.agents = crowd.agents, None
        try:
            twin = copy.deepcopy(crowd)
        finally:
            crowd.agents = agents
        twin.agents = agents
        return twin

    def forecast(self) -> Forecast:
        obs, tb = self._obs, self.timebase
        stride = tb.stride(self.sim.dt)
        twin, robot = self._copy(), np.array(self.sim.robot, dtype=float)
        standing = np.zeros(2)
        ahead: list[dict[int, np.ndarray]] = []
        for _ in range(tb.horizon):
            for _ in range(stride):
                twin.step(robot, standing)
            ahead.append(dict(zip(twin.ids.tolist(), twin.pos.copy(), strict=True)))
        ids = np.asarray(obs.ped_ids, dtype=np.int64)
        times = tb.times
        pos = np.empty((len(ids), len(times), 2))
        for i, pid in enumerate(ids.tolist()):
            for k, (t, step) in enumerate(zip(times, ahead, strict=True)):
                at = step.get(
                    pid
                )  # a human replaced inside the horizon: constant velocity from the observation
                pos[i, k] = at if at is not None else obs.ped_positions[i] + t * obs.ped_velocities[i]
        if isinstance(self.sigma, GrowingSigma):
            sigma = np.repeat(self.sigma(times)[None], len(ids), axis=0)
        else:
            sigma = np.full((len(ids), len(times)), self.sigma)
        return Forecast.single(ids.copy(), pos, sigma, times, self.source, tb)
