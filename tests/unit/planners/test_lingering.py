"""Lingering: a pedestrian who has stood by the robot for a while is not making room for it, whatever a model that
expects people to step aside forecasts (a replayed person shuffling 5 cm from a standing robot walked into it)."""

from __future__ import annotations

import numpy as np

from foresight.core.planners.predictive.config import PredictivePlannerConfig
from foresight.core.planners.predictive.planner import PredictivePlanner
from foresight.core.predict.forecaster import ConstantVelocityForecaster
from foresight.core.predict.timebase import PLANNER_TIMEBASE
from tests.unit.planners.scenes import corridor_map, info_for, observation

ROBOT = (5.0, 10.0, 0.0)


def _planner(linger_s: float) -> PredictivePlanner:
    cfg = PredictivePlannerConfig.from_dict({"safety": {"crowd": {"lingering_s": linger_s}}})
    planner = PredictivePlanner(cfg, ConstantVelocityForecaster(PLANNER_TIMEBASE))
    planner.reset(info_for(corridor_map()))
    return planner


def _lingering(planner: PredictivePlanner, steps: int) -> list[bool]:
    """Three pedestrians over ``steps`` decisions: one shuffling 0.2 m from contact, one walking past at 1 m/s as
    close, one standing 4 m beyond contact."""
    m, mask = corridor_map(), None
    for k in range(steps):
        shuffle = 0.03 * (k % 2)
        peds = [(6.0 + shuffle, 11.5), (3.0 + 0.1 * k, 11.6), (5.0, 15.4)]
        obs = observation(
            m,
            pose=ROBOT,
            velocity=(0.0, 0.0),
            peds=peds,
            ped_vels=[(0.3 * (1 - 2 * (k % 2)), 0.0), (1.0, 0.0), (0.0, 0.0)],
            step=k,
        )
        mask = planner._memory.crowd.lingers(obs, obs.ped_ids, contact=1.4)
    return mask.tolist()


def test_only_a_pedestrian_that_stayed_by_the_robot_for_the_whole_window_lingers():
    planner = _planner(1.5)
    assert _lingering(planner, 10) == [False, False, False]  # 0.9 s: not yet
    planner = _planner(1.5)
    assert _lingering(planner, 16) == [True, False, False]


def test_lingering_is_on_by_default_and_off_at_zero():
    assert PredictivePlannerConfig().safety.crowd.lingering_s == 1.5
    assert _lingering(_planner(0.0), 16) == [False, False, False]


def test_a_lingering_pedestrian_is_forecast_on_its_own_velocity_not_the_models():
    """The scene holds the lingerer to its straight line (here the 0.3 m/s shuffle), not to a forecast that leaves."""
    planner = _planner(1.5)
    m = corridor_map()
    for k in range(16):
        obs = observation(
            m, pose=ROBOT, velocity=(0.0, 0.0), peds=[(6.0, 11.5)], ped_vels=[(0.0, -0.3)], step=k
        )
        fc = planner.forecaster.update(obs)
        leaving = (
            fc.positions + np.array([0.0, 3.0]) * fc.times[None, :, None]
        )  # as a model expecting it to leave
        scene, _, _ = planner._scene(obs, leaving, fc.sigma, fc.times, fc.ped_ids)
    assert scene.ped_future.shape[0] == 1
    want = np.array([6.0, 11.5]) + fc.times[:, None] * np.array([0.0, -0.3])
    np.testing.assert_allclose(scene.ped_future[0, : len(fc.times)], want, atol=1e-9)
