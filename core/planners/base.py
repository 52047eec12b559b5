"""The planner protocol every controller satisfies (collection, baselines, predictive planner)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

from foresight.core.scenarios.model import ResolvedScenario
from foresight.core.sim.observation import Observation


@dataclass(frozen=True)
class EpisodeInfo:
    """What a planner may know about an episode before its first step."""

    scenario: ResolvedScenario
    seed: int
    dt: float  #: simulation step [s]
    robot_radius: float  #: true collision radius [m]
    ped_radius: float  #: true collision radius [m]
    extra: dict[str, Any] = field(default_factory=dict)


@runtime_checkable
class Planner(Protocol):
    """``reset`` once per episode, then ``plan`` once per step; ``diagnostics`` describes the last decision."""

    name: str

    def reset(self, info: EpisodeInfo) -> None: ...

    def plan(self, obs: Observation) -> tuple[float, float]:
        """Return the commanded (linear speed [m/s], turn rate [rad/s])."""
        ...

    @property
    def diagnostics(self) -> dict[str, Any] | None:
        """Per-decision details of the last ``plan`` call (chosen candidate, cost terms, predictions) or None."""
        ...
