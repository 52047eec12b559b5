"""The planner protocol every controller satisfies (collection, baselines, predictive planner, your own).

Planner interface, version 1 (:data:`PLANNER_API_VERSION`), the contract for plugins and in-process planners:

- ``reset(info: EpisodeInfo)`` once before each episode (scenario, seed, dt, true radii);
- ``plan(obs: Observation) -> (v, omega)`` once per simulation step: commanded linear speed [m/s] and turn rate
  [rad/s] (a holonomic robot takes (vx, vy)); an exception or a non-finite command ends the episode as
  ``planner_error`` with the message;
- ``diagnostics`` (optional): a dict describing the last decision, or None;
- ``finish(outcome: str)`` (optional): called after each episode with its outcome.

A plugin is an installed package declaring an entry point in the group ``foresight.planners``
(``my_planner = "my_pkg:MyPlanner"``): the object there has a ``config_model`` (a pydantic model: the
planner's config, validated at submission) and is called as ``obj(config)`` to build a fresh planner per
episode; ``planner_api = 1`` may state the version it was written for. See ``core.planners.registry``.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

from foresight.core.scenarios.model import ResolvedScenario
from foresight.core.sim.observation import Observation

PLANNER_API_VERSION = 1  #: the interface version above; a plugin declaring another is refused


def config_hash(resolved: dict[str, Any]) -> str:
    """A planner config's identity: sha256 of its canonical JSON (sorted keys, compact), every key resolved."""
    return hashlib.sha256(json.dumps(resolved, sort_keys=True, separators=(",", ":")).encode()).hexdigest()


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
