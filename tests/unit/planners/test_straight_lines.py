"""Straight lines: a slow robot holds pedestrians walking at it to their straight line too, not only to a forecast
that bends away (someone who does not see the robot walks on into it)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from foresight.core.planners.predictive.config import PredictivePlannerConfig
from foresight.core.planners.predictive.planner import PredictivePlanner
from foresight.core.predict.forecaster import ConstantVelocityForecaster
from foresight.core.predict.timebase import PLANNER_TIMEBASE
from tests.unit.planners.scenes import corridor_map, info_for, observation


class SwervingForecaster(ConstantVelocityForecaster):
    """Forecasts every pedestrian to turn off its course at once (+y at its current speed): a forecast that bends."""

    def forecast(self):
        fc = super().forecast()
        start = fc.positions[:, :1] - (
            fc.positions[:, 1:2] - fc.positions[:, :1]
        )  # back to the current position
        speed = np.hypot(*(fc.positions[:, 1] - fc.positions[:, 0]).T) / (fc.times[1] - fc.times[0])
        side = np.stack([np.zeros_like(speed), speed], axis=1)
        return dataclasses.replace(fc, modes=(start + fc.times[None, :, None] * side[:, None, :])[:, None])


def _planner(straight: float = 0.3, forecaster=None) -> tuple[PredictivePlanner, object]:
    cfg = {"safety": {"crowd": {"straight": {"speed": straight}}}}
    planner = PredictivePlanner(
        PredictivePlannerConfig.from_dict(cfg), forecaster or ConstantVelocityForecaster(PLANNER_TIMEBASE)
    )
    m = corridor_map()
    planner.reset(info_for(m))
    return planner, m


def _standing_cost(straight: float) -> dict:
    """Terms of standing still while a walker 4 m ahead walks at the robot at 1.2 m/s, forecast to swerve off."""
    planner, m = _planner(straight, SwervingForecaster(PLANNER_TIMEBASE))
    for k in range(2):  # two observations: the forecaster's velocity needs a history
        obs = observation(
            m,
            pose=(5.0, 10.0, 0.0),
            velocity=(0.0, 0.0),
            peds=[(9.0 - 0.12 * k, 10.0)],
            ped_vels=[(-1.2, 0.0)],
            step=k,
        )
        _, terms = planner.score_commands(obs, np.array([[0.0, 0.0]]))
    return terms


def test_standing_in_a_walkers_way_costs_a_collision_even_if_its_forecast_swerves():
    assert (
        _standing_cost(0.0)["collision"][0] == 0.0
    )  # off (the default): the forecast alone, the walker turns away
    assert _standing_cost(0.3)["collision"][0] > 0.0  # on: it may walk straight on


def test_only_walkers_closing_in_on_a_slow_robot_get_a_straight_line():
    planner, m = _planner()
    peds = [(9.0, 10.0), (9.0, 10.0), (9.0, 12.0), (9.0, 10.0)]
    vels = [(-1.0, 0.0), (1.0, 0.0), (0.0, 1.0), (-0.2, 0.0)]  # towards, away, across, closing slowly
    obs = observation(m, pose=(5.0, 10.0, 0.0), velocity=(0.0, 0.0), peds=peds, ped_vels=vels)
    ids = np.array([3, 0, 1, 2], dtype=np.int64)  # forecast order differs from the observation's
    times = np.array([0.4, 0.8])
    mask, lines = planner._memory.crowd.walks_straight(obs, ids, times, np.array([5.0, 10.0]), v=0.0)
    assert mask.tolist() == [False, True, False, False]
    assert lines == pytest.approx(np.array([[[8.6, 10.0], [8.2, 10.0]]]))
    fast = planner._memory.crowd.walks_straight(
        obs, ids, times, np.array([5.0, 10.0]), v=1.0
    )  # 0.5 of v_max: not slow
    assert fast is None  # no pedestrian gets a line


def test_a_walker_seen_to_give_way_gets_no_straight_line():
    """Over 2 s one walker slows from 1.0 to 0.85 m/s on its way to the robot (it gives way), one walks on at
    1.0 m/s, and one slows as much 6 m beyond contact (not on the robot's account): only the first is excused."""
    planner, m = _planner()
    peds = np.array([[8.5, 10.0], [8.5, 8.0], [13.5, 10.0]])
    for k in range(21):
        slowing = 1.0 - 0.15 * k / 20
        vels = [(-slowing, 0.0), (-1.0, 0.0), (-slowing, 0.0)]
        obs = observation(m, pose=(5.0, 10.0, 0.0), velocity=(0.0, 0.0), peds=peds, ped_vels=vels, step=k)
        mask, _ = planner._memory.crowd.walks_straight(
            obs, obs.ped_ids, np.array([0.4, 0.8]), np.array([5.0, 10.0]), v=0.0
        )
    assert planner._memory.crowd.walks_straight.gives_way.reacted == {0}
    assert mask.tolist() == [False, True, True]
