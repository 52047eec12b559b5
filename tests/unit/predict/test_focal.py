"""A focal-pedestrian-frame model (ETH/UCY, 0.4 s) forecasts live pedestrians and drives the planner."""

from __future__ import annotations

import numpy as np

from foresight.core.planners.registry import make_forecaster, make_planner
from foresight.core.predict.focal import FocalForecaster
from foresight.core.predict.predictor import ConstantVelocityPredictor
from foresight.core.predict.timebase import ETHUCY_TIMEBASE
from foresight.core.sim.planner import EpisodeInfo
from tests.unit.predict.helpers import make_obs


class FocalCV(ConstantVelocityPredictor):
    """Constant velocity read from focal-frame features: its forecast, taken back to the world, is plain CV."""

    frame_convention = "focal_pedestrian"
    name = "focal_cv"


def test_each_pedestrian_is_forecast_in_its_own_frame_and_returned_to_the_world():
    f = make_forecaster(FocalCV(ETHUCY_TIMEBASE))
    assert isinstance(f, FocalForecaster)
    vel = np.array([[1.0, 0.5], [-0.3, 0.8]])
    start = np.array([[0.0, 0.0], [5.0, 1.0]])
    for k in range(40):  # 4 s: more than the 8 x 0.4 s history
        t = 0.1 * k
        fc = f.update(make_obs(k, (2.0, 2.0, 1.0), [5, 6], start + t * vel))
    now = start + 3.9 * vel
    expected = now[:, None] + ETHUCY_TIMEBASE.times[None, :, None] * vel[:, None]
    np.testing.assert_allclose(fc.positions, expected, atol=1e-4)
    assert fc.source == "learned_focal:focal_cv" and fc.timebase == ETHUCY_TIMEBASE


def test_a_short_history_gets_constant_velocity_and_says_so():
    f = FocalForecaster(FocalCV(ETHUCY_TIMEBASE))
    for k in range(10):
        fc = f.update(make_obs(k, (0.0, 0.0, 0.0), [1], [[0.1 * k, 0.0]]))
    assert fc.source.startswith("learned_focal+cv_short:")
    np.testing.assert_allclose(fc.positions[0, :, 0], 0.9 + ETHUCY_TIMEBASE.times, atol=1e-9)


def test_an_ethucy_model_drives_the_planner_through_resampling():
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "bench"))
    from planner_latency import scenario

    from foresight.core.sim.simulator import Simulator

    planner, sc, sim = (
        make_planner("predictive", None, model=FocalCV(ETHUCY_TIMEBASE)),
        scenario(8),
        Simulator(),
    )
    obs = sim.reset(sc, 1)
    x0 = float(obs.robot_pose[0])
    planner.reset(
        EpisodeInfo(scenario=sc, seed=1, dt=sim.dt, robot_radius=sim.limits.radius, ped_radius=sim.ped_radius)
    )
    for _ in range(50):
        obs, ev = sim.step(planner.plan(obs))
        assert not ev.done
    d = planner.diagnostics
    assert d["forecast_source"] == "learned_focal:focal_cv"
    assert (
        d["predictions"]["times"][-1] == ETHUCY_TIMEBASE.times[-1]
    )  # the model's own forecast, 4.8 s at 0.4 s
    assert float(obs.robot_pose[0]) > x0 + 1.0  # it drives on along its route
