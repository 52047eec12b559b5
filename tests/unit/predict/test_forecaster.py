import numpy as np
import pytest

from foresight.core.errors import ConfigError
from foresight.core.predict.forecaster import (
    ConstantVelocityForecaster,
    Forecast,
    Forecaster,
    LearnedForecaster,
)
from foresight.core.predict.predictor import ConstantVelocityPredictor
from foresight.core.predict.timebase import PLANNER_TIMEBASE, TimeBase
from tests.unit.predict.helpers import make_obs


def _walk(forecaster, steps, robot_pose=(1.0, -2.0, 2.0)):
    """Ped 5 walks at (1.0, 0.5) m/s, ped 6 stands still; robot fixed but rotated."""
    for k in range(steps):
        t = 0.1 * k
        fc = forecaster.update(make_obs(k, robot_pose, [5, 6], [[t * 1.0, t * 0.5], [3.0, 3.0]]))
    return fc, 0.1 * (steps - 1)


def test_cv_forecaster_extrapolates_in_world_frame():
    f = ConstantVelocityForecaster(PLANNER_TIMEBASE)
    assert isinstance(f, Forecaster)
    fc, t = _walk(f, 12)
    assert isinstance(fc, Forecast) and fc.source == "constant_velocity"
    assert list(fc.ped_ids) == [6, 5] or list(fc.ped_ids) == [5, 6]
    i = list(fc.ped_ids).index(5)
    expected = np.array([[t + s, 0.5 * (t + s)] for s in fc.times])
    np.testing.assert_allclose(fc.positions[i], expected, atol=1e-5)
    np.testing.assert_allclose(fc.positions[1 - i], np.tile([3.0, 3.0], (12, 1)), atol=1e-5)
    np.testing.assert_allclose(fc.times, 0.2 * np.arange(1, 13))


def test_new_pedestrian_has_no_velocity_until_two_grid_points():
    f = ConstantVelocityForecaster(PLANNER_TIMEBASE)
    fc, _ = _walk(f, 2)  # only 0.1 s seen: less than one 0.2 s step
    i = list(fc.ped_ids).index(5)
    assert np.allclose(fc.positions[i], fc.positions[i, 0])
    fc, _ = _walk(ConstantVelocityForecaster(PLANNER_TIMEBASE), 3)
    assert not np.allclose(fc.positions[i], fc.positions[i, 0])


def test_reset_on_new_episode_and_gap_error():
    f = ConstantVelocityForecaster(PLANNER_TIMEBASE)
    _walk(f, 6)
    fc = f.update(make_obs(0, (0, 0, 0), [9], [[1.0, 1.0]]))  # step 0 = new episode
    assert list(fc.ped_ids) == [9]
    with pytest.raises(ConfigError, match="does not follow"):
        f.observe(make_obs(5, (0, 0, 0), [9], [[1.0, 1.0]]))


def test_timebase_needs_integer_stride():
    f = ConstantVelocityForecaster(TimeBase(0.25, 3, 4))
    with pytest.raises(ConfigError, match="integer multiple"):
        f.observe(make_obs(0, (0, 0, 0), [1], [[0, 0]]))


def test_learned_forecaster_uses_nearest_and_labels_far_cv():
    class Doubling(ConstantVelocityPredictor):
        name = "double"
        max_agents = 1

        def predict(self, features, mask):
            return 2 * super().predict(features, mask)

    f = LearnedForecaster(Doubling(PLANNER_TIMEBASE))
    fc, _ = _walk(f, 4, robot_pose=(3.0, 3.5, 0.0))  # ped 6 is nearest
    assert fc.source == "learned+cv_far:double"
    assert fc.ped_ids[0] == 6


def test_empty_scene():
    fc = ConstantVelocityForecaster(PLANNER_TIMEBASE).update(make_obs(0, (0, 0, 0), [], np.zeros((0, 2))))
    assert fc.positions.shape == (0, 12, 2)


def test_learned_forecaster_refuses_focal_frame_models():
    p = ConstantVelocityPredictor(PLANNER_TIMEBASE)
    p.frame_convention = "focal_pedestrian"
    with pytest.raises(ConfigError, match="focal_pedestrian"):
        LearnedForecaster(p)
