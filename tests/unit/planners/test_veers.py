"""Swerves: turn at speed for a while, then straight on; how a robot behind slower walkers pulls out and passes them."""

from __future__ import annotations

import numpy as np
import pytest

from foresight.core.errors import ConfigError
from foresight.core.planners.predictive.config import PredictivePlannerConfig, SamplingConfig
from foresight.core.planners.predictive.planner import PredictivePlanner
from foresight.core.planners.predictive.sampling import veer_then_straight
from foresight.core.predict.forecaster import ConstantVelocityForecaster
from foresight.core.predict.timebase import PLANNER_TIMEBASE
from foresight.core.sim.robot import RobotLimits, unicycle_step
from tests.unit.planners.scenes import corridor_map, info_for, observation

#: a 10 m wide corridor along the robot's route (y = 5..15)
WALLS = (
    ((0.0, 4.0), (30.0, 4.0), (30.0, 5.0), (0.0, 5.0)),
    ((0.0, 15.0), (30.0, 15.0), (30.0, 16.0), (0.0, 16.0)),
)
#: three walkers in a file on the robot's route (y = 10), walking on along it at 0.6 m/s
FILE = np.array([[8.5, 10.0], [9.7, 10.0], [10.9, 10.0]])
WALK = np.array([0.6, 0.0])


def test_sequences_turn_for_each_duration_then_drive_straight_at_one_speed():
    cfg = SamplingConfig(veers={"turn_rates": (-1.0, 0.5), "speed_ratios": (0.5, 1.0), "durations_s": (0.8,)})
    seqs = veer_then_straight(cfg, RobotLimits(), steps=40, dt=0.1, speed_ratio=1.0)
    assert seqs.shape == (4, 40, 2)
    right_fast, left_slow = seqs[1], seqs[2]  # -1.0 x w_max at 2 m/s, +0.5 x w_max at 1 m/s
    assert np.all(right_fast[:8] == [2.0, -1.0]) and np.all(right_fast[8:] == [2.0, 0.0])
    assert np.all(left_slow[:8] == [1.0, 0.5]) and np.all(left_slow[8:] == [1.0, 0.0])
    capped = veer_then_straight(cfg, RobotLimits(), steps=40, dt=0.1, speed_ratio=0.25)
    assert capped[..., 0].max() == pytest.approx(0.5)  # the config's speed cap holds
    assert veer_then_straight(
        SamplingConfig(veers={"turn_rates": ()}), RobotLimits(), 40, 0.1, 1.0
    ).shape == (
        0,
        40,
        2,
    )
    longer = veer_then_straight(
        SamplingConfig(veers={"durations_s": (0.4, 1.6)}), RobotLimits(), 40, 0.1, 1.0
    )
    assert (
        longer.shape == (16, 40, 2)
        and np.count_nonzero(longer[0, :, 1]) == 4
        and np.count_nonzero(longer[8, :, 1]) == 16
    )


def _drive(rates: tuple[float, ...], decisions: int = 80) -> tuple[np.ndarray, np.ndarray, float]:
    """Closed loop behind the file (the robot moved by the simulator's kinematics, the walkers at constant velocity):
    the robot's last state, the walkers' last positions and the smallest gap [m] between robot and walkers."""
    m = corridor_map(obstacles=WALLS)
    # lanes off: a robot held up in the walkers' own lane is charged for it, which alone can pull it out (test_lanes)
    cfg = PredictivePlannerConfig.from_dict(
        {"sampling": {"veers": {"turn_rates": list(rates)}}, "weights": {"lane": 0}}
    )
    planner = PredictivePlanner(cfg, ConstantVelocityForecaster(PLANNER_TIMEBASE))
    planner.reset(info_for(m))
    state, gap = np.array([5.0, 10.0, 0.0, 0.6, 0.0]), np.inf
    for k in range(decisions):
        peds = FILE + WALK * 0.1 * k
        obs = observation(
            m, pose=state[:3], velocity=state[3:], peds=peds, ped_vels=np.tile(WALK, (3, 1)), step=k
        )
        state = unicycle_step(state, np.array(planner.plan(obs)), RobotLimits(), 0.1)
        gap = min(gap, float(np.min(np.hypot(*(peds + WALK * 0.1 - state[:2]).T))) - 1.4)
    return state, FILE + WALK * 0.1 * decisions, gap


def test_a_robot_behind_slower_walkers_pulls_out_and_passes_them_only_with_swerves():
    passed, peds, gap = _drive((-1.0, -0.5, 0.5, 1.0))
    assert (
        passed[0] > peds[:, 0].max() + 0.5 and gap > 0.5
    )  # ahead of the whole file after 8 s, never near it
    behind, peds, _ = _drive(())
    assert behind[0] < peds[:, 0].max()  # the held arcs alone: still behind the file


def test_swerves_never_drive_backwards_turn_for_no_time_or_beyond_the_limit():
    with pytest.raises(ConfigError) as exc:
        PredictivePlannerConfig.from_dict({"sampling": {"veers": {"speed_ratios": [-0.5]}}})
    assert "sampling.veers.speed_ratios" in str(exc.value)
    with pytest.raises(ConfigError) as exc:
        PredictivePlannerConfig.from_dict({"sampling": {"veers": {"durations_s": [0.8, 0.0]}}})
    assert "sampling.veers.durations_s" in str(exc.value)
    with pytest.raises(ConfigError) as exc:
        PredictivePlannerConfig.from_dict({"sampling": {"veers": {"turn_rates": [1.5]}}})
    assert "sampling.veers.turn_rates" in str(exc.value)
