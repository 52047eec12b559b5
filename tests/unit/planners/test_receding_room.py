"""Receding room: a slow robot held up behind a walker who walks away from it may pass that walker closer."""

from __future__ import annotations

import numpy as np
import pytest

from foresight.core.planners.predictive.config import PredictivePlannerConfig
from foresight.core.planners.predictive.planner import PredictivePlanner
from foresight.core.predict.forecaster import ConstantVelocityForecaster
from foresight.core.predict.timebase import PLANNER_TIMEBASE
from tests.unit.planners.scenes import corridor_map, info_for, observation

#: a wall along the robot's left (y >= 11.9): the robot cannot swerve wide round a walker on its right
WALL = (((0.0, 11.9), (30.0, 11.9), (30.0, 13.0), (0.0, 13.0)),)


def _planner(room: float | None = None) -> tuple[PredictivePlanner, object]:
    cfg = {} if room is None else {"safety": {"crowd": {"receding": {"room": room}}}}
    planner = PredictivePlanner(
        PredictivePlannerConfig.from_dict(cfg), ConstantVelocityForecaster(PLANNER_TIMEBASE)
    )
    m = corridor_map(obstacles=WALL)
    planner.reset(info_for(m))
    return planner, m


def _follow(room: float | None, speed: float) -> dict:
    """Three decisions behind a walker 2 m ahead and 1.4 m to the right, walking on at 0.65 m/s."""
    planner, m = _planner(room)
    for k in range(3):
        planner.plan(
            observation(
                m,
                pose=(5.0 + 0.07 * k, 10.0, 0.0),
                velocity=(speed, 0.0),
                peds=[(7.0 + 0.065 * k, 8.6)],
                ped_vels=[(0.65, 0.0)],
                step=k,
            )
        )
    return planner.diagnostics


def test_a_slow_robot_behind_a_walker_plans_to_pass_it_only_with_the_room():
    tight, roomy = _follow(0.0, 0.7), _follow(None, 0.7)  # None: the default room
    assert roomy["terms"]["progress"] > tight["terms"]["progress"] + 0.5
    assert roomy["terms"].get("collision", 0.0) == 0.0


def test_a_fast_robot_keeps_its_full_margins():
    tight, roomy = _follow(0.0, 1.8), _follow(None, 1.8)
    assert roomy["sequence"] == tight["sequence"] and roomy["cost"] == pytest.approx(tight["cost"])


def test_only_pedestrians_walking_away_get_room():
    planner, _ = _planner(0.5)
    times = np.array([0.2, 0.4])
    start = np.array([[8.0, 10.0], [8.0, 10.0], [8.0, 10.0], [4.0, 10.0]])  # ahead x3, then behind
    vel = np.array(
        [[0.65, 0.0], [-0.65, 0.0], [0.0, 0.0], [0.1, 0.0]]
    )  # away, towards, standing, closing slowly
    fut = np.stack([start + vel * t for t in times], axis=1)
    room = planner._memory.crowd.receding_room(fut, times, p0=np.array([5.0, 10.0]), v=0.5)
    assert room == pytest.approx([0.5, 0.0, 0.0, 0.0])
    # half the speed that earns full room earns half of it; half-way between half and all of the top speed, half
    strolling = np.stack([start[:1] + np.array([0.15, 0.0]) * t for t in times], axis=1)  # 0.15 m/s away
    half = planner._memory.crowd.receding_room(strolling, times, p0=np.array([5.0, 10.0]), v=0.5)
    assert half == pytest.approx([0.25])
    assert planner._memory.crowd.receding_room(fut, times, np.array([5.0, 10.0]), v=1.2) == pytest.approx(
        [0.25, 0, 0, 0]
    )
    assert not planner._memory.crowd.receding_room(fut, times, np.array([5.0, 10.0]), v=1.6).any()
