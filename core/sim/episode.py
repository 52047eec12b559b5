"""The single episode loop (reset -> plan -> step) shared by data collection and evaluation."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from foresight.core.scenarios.model import ResolvedScenario
from foresight.core.sim.observation import Events, Observation
from foresight.core.sim.planner import Planner
from foresight.core.sim.simulator import Simulator
from foresight.core.sim.trace import Trace

StepHook = Callable[
    [Observation, tuple[float, float], Events, Any], None
]  #: (obs after step, command, events, diagnostics)
#: steps between two calls of ``check``: a cancel or timeout stops even a 100,000-step episode within milliseconds
CHECK_EVERY = 16


@dataclass
class EpisodeResult:
    scenario: str
    seed: int
    outcome: str  #: success | collision_pedestrian | collision_static | timeout
    steps: int
    trace: Trace
    min_distance: float | None  #: smallest robot-ped centre distance over the episode [m]; None without peds
    min_clearance: float | None  #: the same minus both radii [m]; <= 0 means contact
    wall_s: float  #: reset + loop [s]
    plan_s: float  #: time spent inside planner.plan [s]
    extra: dict[str, Any] = field(default_factory=dict)


def run_episode(
    scenario: ResolvedScenario,
    seed: int,
    planner: Planner,
    *,
    max_steps: int | None = None,
    simulator: Simulator | None = None,
    on_step: StepHook | None = None,
    info_extra: dict[str, Any] | None = None,
    check: Callable[[], None] | None = None,
) -> EpisodeResult:
    """Run one episode to its end (collision, goal or exactly ``max_steps``/max_episode_steps steps).

    ``check`` (e.g. ``StageContext.check_cancelled``) is called every :data:`CHECK_EVERY` steps and stops the
    episode by raising, so a cancelled or timed-out job never waits for a long episode to end (its crowd's
    spawning included).
    """
    t0 = time.perf_counter()
    sim = simulator or Simulator()
    obs = sim.reset(scenario, seed, max_steps=max_steps, check=check)
    planner.reset(sim.episode_info(info_extra))
    plan_time = 0.0
    while True:
        tp = time.perf_counter()
        cmd = planner.plan(obs)
        plan_time += time.perf_counter() - tp
        obs, events = sim.step(cmd)
        if on_step is not None:
            on_step(obs, cmd, events, planner.diagnostics)
        if events.done:
            break
        if check is not None and sim.t % CHECK_EVERY == 0:
            check()
    trace = sim.trace
    dmin = float(sim.min_ped_distance) if np.isfinite(sim.min_ped_distance) else None
    return EpisodeResult(
        scenario=scenario.name,
        seed=int(seed),
        outcome=trace.outcome,
        steps=trace.steps,
        trace=trace,
        min_distance=dmin,
        min_clearance=None if dmin is None else dmin - sim.limits.radius - sim.ped_radius,
        wall_s=time.perf_counter() - t0,
        plan_s=plan_time,
    )
