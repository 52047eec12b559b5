"""What the predictive planner keeps across one episode's decisions, apart from the decisions themselves."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from foresight.core.planners.predictive import cost as C
from foresight.core.planners.predictive.crowd import CrowdAssumptions
from foresight.core.planners.predictive.search import BeamSearch, Plan
from foresight.core.planners.predictive.traffic import TrafficMap
from foresight.core.sim.observation import Observation


@dataclass
class EpisodeMemory:
    """One episode's state: made fresh by ``PredictivePlanner.reset``, so nothing leaks into the next episode."""

    crowd: CrowdAssumptions  #: the crowd assumptions and what they saw
    search: BeamSearch  #: with its command sets and step grids cached for the episode
    holonomic: bool  #: commands are velocities (see ``holonomic``)
    prev: np.ndarray = field(default_factory=lambda: np.zeros(2))  #: the last command
    plan: Plan | None = None  #: the last decision's commands (S, 2) and states (S, 5)
    decided: tuple[Observation, C.Scene] | None = None  #: the last decision's observation and scene
    traffic: TrafficMap | None = None  #: walkers lately passing (``weights.lane``)
    route: tuple | None = None  #: (route key, route potential) of the remaining route
