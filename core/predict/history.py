"""Per-pedestrian histories kept from successive Observations (the planner's live path).

Frames are stored at the simulator's dt and sampled on the time base's grid by the same
:func:`core.predict.features.gather_history` that collection applies to traces, so live features
equal trace features for the same situation.
"""

from __future__ import annotations

from collections import deque
from typing import NamedTuple

import numpy as np

from foresight.core.errors import ConfigError
from foresight.core.predict.features import Window, gather_history
from foresight.core.predict.timebase import TimeBase
from foresight.core.sim.observation import Observation


class _Frame(NamedTuple):
    step: int
    dt: float  #: [s]
    ids: np.ndarray  #: (N,) int64
    positions: np.ndarray  #: (N, 2) world [m]


class LiveHistory:
    """The last (H-1)·stride + 1 observations; a new episode (step 0 or a step jump back) restarts it."""

    def __init__(self, timebase: TimeBase):
        self.timebase = timebase
        self._frames: deque[_Frame] = deque()
        self._latest: Observation | None = None
        self._stride: int | None = None

    def reset(self) -> None:
        self._frames.clear()
        self._latest = None
        self._stride = None

    def observe(self, obs: Observation) -> None:
        if self._frames and (obs.step <= self._frames[-1].step or obs.step == 0):
            self.reset()
        if self._frames and obs.step != self._frames[-1].step + 1:
            raise ConfigError(
                f"observation step {obs.step} does not follow step {self._frames[-1].step}: "
                "call observe() on every simulator step",
                item="observation.step",
            )
        if self._stride is None:
            self._stride = self.timebase.stride(obs.dt)
        elif abs(obs.dt - self._frames[-1].dt) > 1e-9:
            raise ConfigError(
                f"simulator dt changed mid-episode ({self._frames[-1].dt} -> {obs.dt})", item="observation.dt"
            )
        ids = np.array(obs.ped_ids, dtype=np.int64)  # copies: a producer may reuse its arrays
        self._frames.append(_Frame(obs.step, obs.dt, ids, np.array(obs.ped_positions, dtype=float)))
        self._latest = obs
        while len(self._frames) > (self.timebase.history - 1) * self._stride + 1:
            self._frames.popleft()

    @property
    def ready(self) -> bool:
        return bool(self._frames)

    def window(self) -> Window:
        """The current situation: every pedestrian present now, with its history on the grid."""
        if not self._frames:
            raise ConfigError("no observation yet: call observe() before forecasting", item="observation")
        now = self._latest
        ids = self._frames[-1].ids
        ids = ids[ids >= 0]
        hist, valid = gather_history(
            [f.ids for f in self._frames],
            [f.positions for f in self._frames],
            self._stride,
            self.timebase.history,
            ids,
        )
        return Window(
            ego_pose=np.asarray(now.robot_pose, float),
            ego_motion=np.asarray(now.robot_velocity, float),
            goal=np.asarray(now.waypoint, float),
            ped_ids=ids,
            ped_hist=hist,
            hist_valid=valid,
        )
