"""Runaway episodes: a cancel or timeout stops a long episode from inside, a trace has a memory
bound, and every ``max_steps`` has an upper bound."""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from pydantic import ValidationError

from foresight.core.errors import ConfigError
from foresight.core.evaluation.config import EvaluationConfig
from foresight.core.evaluation.runner import run_evaluation
from foresight.core.planners.goal import GoalSeeking
from foresight.core.runtime.context import Cancelled, StageContext
from foresight.core.runtime.refs import BUILTIN_CONFIG_ROOT
from foresight.core.scenarios.model import MAX_EPISODE_STEPS
from foresight.core.sim.episode import run_episode
from foresight.core.sim.trace import MAX_TRACE_BYTES, Trace, trace_bytes
from foresight.core.training.collect import CollectConfig, run_collect

from .scenes import open_map, scenario


class CancelAfter:
    """``is_cancelled`` that turns true ``after_s`` seconds after the first call; records when."""

    def __init__(self, after_s: float):
        self.after_s, self.start = after_s, None

    def __call__(self) -> bool:
        now = time.monotonic()
        self.start = self.start or now
        return now - self.start > self.after_s


def _stuck_ctx(tmp: Path, workers: int = 1, after_s: float = 0.5) -> StageContext:
    return StageContext(
        workdir=tmp,
        resolve_bundle=lambda _b: BUILTIN_CONFIG_ROOT,
        is_cancelled=CancelAfter(after_s),
        workers=workers,
    )


def test_a_cancel_stops_an_episode_whose_robot_cannot_move() -> None:
    sc = scenario(open_map(), max_episode_steps=MAX_EPISODE_STEPS)
    ctx = StageContext(workdir=Path("."), is_cancelled=CancelAfter(0.3))
    t0 = time.monotonic()
    with pytest.raises(Cancelled):
        run_episode(sc, 1, GoalSeeking(speed=0.0), check=ctx.check_cancelled)
    assert time.monotonic() - t0 < 2.0


def test_collect_honours_a_cancel_inside_one_long_episode(tmp_path: Path) -> None:
    config = CollectConfig(
        scenarios=["crossing_low"],
        seeds_per_scenario=1,
        max_steps=MAX_EPISODE_STEPS,
        policy="planner",
        planner={"name": "goal", "config": {"speed": 0.0}},
    )
    ctx = _stuck_ctx(tmp_path)
    t0 = time.monotonic()
    with pytest.raises(Cancelled):
        run_collect(config, ctx)
    assert time.monotonic() - t0 < ctx.is_cancelled.after_s + 2.0


@pytest.mark.parametrize("workers", [1, 2])
def test_evaluate_honours_a_cancel_inside_one_long_episode(tmp_path: Path, workers: int) -> None:
    """In process the episode loop checks; with a pool the parent polls and terminates the processes."""
    config = EvaluationConfig(
        scenarios=["crossing_low", "crossing_medium"],
        seeds_per_scenario=1,
        max_steps=MAX_EPISODE_STEPS,
        planner={"name": "goal", "config": {"speed": 0.0}},
        start_method="fork",
    )
    ctx = _stuck_ctx(tmp_path, workers, after_s=0.5 if workers == 1 else 2.0)
    t0 = time.monotonic()
    with pytest.raises(Cancelled):
        run_evaluation(config, ctx)
    assert time.monotonic() - t0 < ctx.is_cancelled.after_s + 2.0


def test_a_trace_beyond_the_memory_bound_is_refused_before_the_episode() -> None:
    assert (
        trace_bytes(MAX_EPISODE_STEPS, 26) < MAX_TRACE_BYTES
    )  # the largest classic crowd at the largest horizon
    with pytest.raises(ConfigError, match="max_steps.*MiB trace; the limit is 256 MiB"):
        Trace(MAX_EPISODE_STEPS, 1000, dt=0.1, scenario="crowded")


@pytest.mark.parametrize("model", [CollectConfig, EvaluationConfig])
def test_max_steps_is_bounded_everywhere(model) -> None:
    with pytest.raises(ValidationError, match="max_steps"):
        model.model_validate({"max_steps": 10**7})
    assert model.model_validate({"max_steps": MAX_EPISODE_STEPS}).max_steps == MAX_EPISODE_STEPS
