"""Episodes lost before a planner can act: a robot that stands still is walked into within the first seconds.

Such an episode (a walker spawned next to the robot heading at it, a recorded person appearing where it stands)
counts against every planner and measures none. Version 1 of the stress suite had 18 of them in 1.5 s
(``simulation_config.robot_spawn_clearance`` removed them). ``foresight scenarios check`` runs this on any matrix.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from foresight.core.scenarios.model import ResolvedScenario
from foresight.core.sim.simulator import Simulator


@dataclass(frozen=True)
class EarlyContact:
    """A (scenario, seed) episode whose standing robot a pedestrian touched at ``step`` (``time_s``)."""

    scenario: str
    seed: int
    step: int
    time_s: float


def early_contacts(
    scenarios: Iterable[ResolvedScenario], seconds: float = 1.5, seeds: dict[str, Iterable[int]] | None = None
) -> list[EarlyContact]:
    """Every episode (each scenario's own seeds, or ``seeds[name]``) where a pedestrian touches the robot, which
    stands still, within ``seconds`` of the start; in scenario and seed order."""
    sim, out = Simulator(), []
    for s in scenarios:
        for seed in (seeds or {}).get(s.name, s.scenario.seeds):
            sim.reset(s, int(seed))
            while sim.t * sim.dt < seconds - 1e-9 and not sim.done:
                if sim.step((0.0, 0.0))[1].collision == "pedestrian":
                    out.append(EarlyContact(s.name, int(seed), sim.t, round(sim.t * sim.dt, 3)))
    return out


__all__ = ["EarlyContact", "early_contacts"]
