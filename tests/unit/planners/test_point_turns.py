"""Point turns: turn in place, then drive straight; how a robot backed into a corner beside a door gets out."""

from __future__ import annotations

import numpy as np
import pytest

from foresight.core.errors import ConfigError
from foresight.core.planners.predictive.config import PredictivePlannerConfig, SamplingConfig
from foresight.core.planners.predictive.planner import PredictivePlanner
from foresight.core.planners.predictive.sampling import turn_then_go
from foresight.core.predict.forecaster import ConstantVelocityForecaster
from foresight.core.predict.timebase import PLANNER_TIMEBASE
from foresight.core.sim.robot import RobotLimits
from tests.unit.planners.scenes import corridor_map, info_for, observation

#: a wall across the map at x = 14..16 with a door at y = 14..18
WALL = (
    ((14.0, 0.0), (16.0, 0.0), (16.0, 14.0), (14.0, 14.0)),
    ((14.0, 18.0), (16.0, 18.0), (16.0, 20.0), (14.0, 20.0)),
)


def test_sequences_turn_at_the_full_rate_then_drive_straight():
    cfg = SamplingConfig(point_turns={"angles": (-0.8, 1.2), "speed_ratios": (0.25, 0.5)})
    seqs = turn_then_go(cfg, RobotLimits(), steps=40, dt=0.1, speed_ratio=1.0)
    assert seqs.shape == (4, 40, 2)
    right, left = seqs[0], seqs[2]  # -0.8 rad at 0.5 m/s, +1.2 rad at 0.5 m/s
    assert np.all(right[:8] == [0.0, -1.0]) and np.all(right[8:] == [0.5, 0.0])  # 0.8 rad at 1 rad/s: 8 steps
    assert np.all(left[:12] == [0.0, 1.0]) and np.all(left[12:] == [0.5, 0.0])
    assert seqs[1, -1, 0] == pytest.approx(1.0)  # 0.5 of the 2 m/s limit
    assert turn_then_go(SamplingConfig(point_turns={"angles": ()}), RobotLimits(), 40, 0.1, 1.0).shape == (
        0,
        40,
        2,
    )


def _decide(turns: tuple[float, ...]) -> dict:
    m = corridor_map(obstacles=WALL)
    planner = PredictivePlanner(
        PredictivePlannerConfig.from_dict({"sampling": {"point_turns": {"angles": list(turns)}}}),
        ConstantVelocityForecaster(PLANNER_TIMEBASE),
    )
    planner.reset(info_for(m))
    # beside the door, facing the wall just above it: every arc forward clips the corner
    planner.plan(observation(m, pose=(12.8, 18.0, 0.2), velocity=(0.0, 0.0), route=((22.0, 16.0),)))
    return planner.diagnostics


def test_a_robot_facing_the_wall_beside_a_door_turns_and_goes_instead_of_standing():
    stuck = _decide(())
    assert stuck["terms"]["progress"] == pytest.approx(
        0.0, abs=0.05
    )  # held arcs: nothing better than standing
    out = _decide(SamplingConfig().point_turns.angles)  # the default point turns
    assert out["terms"]["progress"] > 0.5 and out["terms"]["static_collision"] == 0
    first_steps, v0, w0 = out["sequence"][0]
    assert v0 == 0.0 and abs(w0) == pytest.approx(1.0)  # it turns in place first
    assert out["cost"] < stuck["cost"]


def test_point_turns_never_drive_backwards():
    with pytest.raises(ConfigError) as exc:
        PredictivePlannerConfig.from_dict({"sampling": {"point_turns": {"speed_ratios": [-0.5]}}})
    assert "sampling.point_turns.speed_ratios" in str(exc.value)
