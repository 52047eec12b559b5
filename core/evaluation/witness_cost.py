"""What a planner's own cost made of a witness's course: why it did not drive what the witness drove.

A witness (``core.evaluation.witness``) shows that a failed episode could be solved; it does not say why the planner
did not solve it. The planner rides along the witness's run as a shadow: at every decision it sees what the witness
saw, decides as it would have (its choice is not driven), and prices the witness's own next commands with the same
cost, against the same forecast. Where the witness's course costs more than the planner's choice, the planner would
have left it, and the terms it charged more for it (weighted, as they enter the cost) say what kept it off: a speed
margin the witness does not keep, a forecast contact that never came, a wall it passes closer than the planner's
margin. That turns a failure into a question about one term, instead of a tuning run over many.

For the predictive planner (``PredictivePlanner.price``); deterministic: the witness is replayed command for command.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict

from foresight.core.errors import ConfigError
from foresight.core.evaluation.plannerspec import ResolvedPlanner, build_planner
from foresight.core.planners.predictive.cost import weighted
from foresight.core.planners.scripted import ScriptedConfig
from foresight.core.scenarios.model import ResolvedScenario
from foresight.core.sim.planner import EpisodeInfo

SHOWN_TERMS = (
    3  #: terms named per decision: those the witness's course was charged most for over the planner's choice
)


class PricedDecision(BaseModel):
    """One decision of the shadow planner along the witness's run."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    time_s: float
    position: tuple[float, float]  #: the robot's (the witness's) [m]
    speed: float  #: [m/s]
    waiting: bool  #: the witness stands here (at rest, commanded to stay)
    chosen_cost: float  #: the planner's cost of its own choice here
    witness_cost: float  #: its cost of the witness's next commands, against the same forecast
    dearer: dict[
        str, float
    ]  #: the terms charged most for the witness's course over the choice (weighted, > 0)

    @property
    def rejected(self) -> bool:
        """The planner would have left the witness's course here."""
        return self.witness_cost > self.chosen_cost


class WitnessCost(BaseModel):
    """Every ``every``-th decision of the shadow planner along one witness's run."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    scenario: str
    seed: int
    planner: str  #: name and config hash of the planner priced with
    decisions: list[PricedDecision]

    def dearer(self, waiting: bool) -> dict[str, float]:
        """Summed over the decisions where the planner would have left the course while the witness waits (or
        drives): what it charged more for it, most first."""
        out: dict[str, float] = {}
        for d in self.decisions:
            if d.rejected and d.waiting == waiting:
                for k, v in d.dearer.items():
                    out[k] = out.get(k, 0.0) + v
        return dict(sorted(out.items(), key=lambda kv: -kv[1]))

    def summary(self) -> str:
        """One line: while the witness waits and while it drives, at how many decisions (and from when) the planner
        would have left its course, and for what."""
        parts = []
        for waiting, what in ((True, "waits"), (False, "drives")):
            mine = [d for d in self.decisions if d.waiting == waiting]
            left = [d for d in mine if d.rejected]
            if not mine:
                continue
            if not left:
                parts.append(f"while it {what}, never ({len(mine)} decisions)")
                continue
            terms = ", ".join(f"{k} +{v:.1f}" for k, v in list(self.dearer(waiting).items())[:SHOWN_TERMS])
            parts.append(
                f"while it {what}, at {len(left)} of {len(mine)} decisions ({left[0].time_s:g}-"
                f"{left[-1].time_s:g} s) for {terms}"
            )
        return "the planner's own cost would have left the witness's course " + "; ".join(parts)


class _Replay:
    """Drives recorded commands and lets the shadow planner decide (and price) at each step, undriven."""

    name = "witness_replay"

    def __init__(self, commands: np.ndarray, shadow: Any, every: int):
        self.commands, self.shadow, self.every = commands, shadow, every
        self.priced: list[PricedDecision] = []

    @property
    def diagnostics(self) -> dict[str, Any] | None:
        return None

    def reset(self, info: EpisodeInfo) -> None:
        self.shadow.reset(info)
        self.k = 0

    def plan(self, obs: Any) -> tuple[float, float]:
        self.shadow.plan(obs)
        if self.k % self.every == 0:
            chosen = self.shadow.diagnostics
            ahead = self.commands[self.k :]
            cost, parts = self.shadow.price(ahead)
            base = weighted(chosen["terms"], self.shadow.config.weights)
            more = {k: v - base.get(k, 0.0) for k, v in parts.items() if v - base.get(k, 0.0) > 1e-6}
            top = dict(sorted(more.items(), key=lambda kv: -kv[1])[:SHOWN_TERMS])
            self.priced.append(
                PricedDecision(
                    time_s=round(float(obs.time), 3),
                    position=(round(float(obs.robot_pose[0]), 2), round(float(obs.robot_pose[1]), 2)),
                    speed=round(float(obs.robot_velocity[0]), 2),
                    waiting=bool(abs(float(obs.robot_velocity[0])) < 1e-6 and not ahead[0].any()),
                    chosen_cost=round(float(chosen["cost"]), 3),
                    witness_cost=round(cost, 3),
                    dearer={k: round(v, 3) for k, v in top.items()},
                )
            )
        v, w = self.commands[min(self.k, len(self.commands) - 1)]
        self.k += 1
        return float(v), float(w)


def price_witness(
    scenario: ResolvedScenario,
    seed: int,
    plan: ScriptedConfig,
    planner: ResolvedPlanner,
    every_s: float = 0.5,
    run: Any = None,
) -> WitnessCost:
    """The witness's run replayed with ``planner`` (the predictive planner) shadowing it, priced every ``every_s``;
    ``run``: the witness's recorded run (``witness.witness_run``) where the caller has it already."""
    from foresight.core.evaluation.witness import witness_run
    from foresight.core.sim.episode import run_episode
    from foresight.core.sim.simulator import Simulator

    shadow = build_planner(planner)
    if not hasattr(shadow, "price"):
        raise ConfigError(
            f"pricing a witness needs a planner that can price a course (the predictive planner), "
            f"not {planner.name!r}",
            item="planner",
        )
    run = run if run is not None else witness_run(scenario, seed, plan)
    sim = Simulator()
    every = max(1, int(round(every_s / scenario.scenario.simulation_config.dt)))
    replay = _Replay(np.asarray(run.trace.command, dtype=float), shadow, every)
    run_episode(scenario, seed, replay, simulator=sim)
    return WitnessCost(
        scenario=scenario.name,
        seed=int(seed),
        planner=f"{planner.name} {planner.config_hash[:12]}",
        decisions=replay.priced,
    )
