"""The static forecast (prediction ``static``, CrowdNav++'s ``none``): everyone stays where they are now, selectable by
name wherever constant velocity is."""

from __future__ import annotations

import numpy as np
import pytest

import foresight
from foresight.core.errors import ConfigError
from foresight.core.planners.predictive.planner import PredictivePlanner
from foresight.core.planners.registry import make_forecaster, make_planner
from foresight.core.predict.forecaster import ConstantVelocityForecaster, Forecaster, StaticForecaster
from foresight.core.predict.oracle import OracleForecaster
from foresight.core.predict.predictor import StaticPredictor
from foresight.core.predict.timebase import PLANNER_TIMEBASE, TimeBase
from foresight.core.runtime.refs import RESERVED_MODEL_IDS
from tests.conftest import REPO
from tests.unit.predict.helpers import make_obs

RAND = REPO / "configs" / "scenarios" / "crowdnav" / "crowdnavpp_rand.yaml"


def _walk(forecaster, steps: int, dt: float = 0.1):
    """Ped 5 walks at (1.0, 0.5) m/s, ped 6 stands still."""
    for k in range(steps):
        t = dt * k
        fc = forecaster.update(make_obs(k, (1.0, -2.0, 2.0), [5, 6], [[t, 0.5 * t], [3.0, 3.0]], dt=dt))
    return fc, dt * (steps - 1)


def test_every_forecast_step_is_the_present_position_with_constant_velocitys_spread():
    static, cv = StaticForecaster(PLANNER_TIMEBASE), ConstantVelocityForecaster(PLANNER_TIMEBASE)
    assert isinstance(static, Forecaster)
    fc, t = _walk(static, 12)
    ref, _ = _walk(cv, 12)
    assert fc.source == "static"
    i = list(fc.ped_ids).index(5)
    np.testing.assert_allclose(fc.positions[i], np.tile([t, 0.5 * t], (12, 1)), atol=1e-5)
    assert not np.allclose(ref.positions[list(ref.ped_ids).index(5)], fc.positions[i])  # cv walks on
    np.testing.assert_allclose(fc.sigma, ref.sigma)  # only the positions differ from cv's
    np.testing.assert_allclose(fc.times, PLANNER_TIMEBASE.times)


def test_the_predictor_repeats_the_current_position_and_zeroes_empty_slots():
    tb = TimeBase(0.4, 3, 5)
    from foresight.core.predict.features import current_index, feature_dim

    feats = np.zeros((1, 2, feature_dim(3)), dtype=np.float32)
    px = current_index(3, "px")
    feats[0, 0, px : px + 2] = [2.0, -1.0]
    feats[0, 1, px : px + 2] = [9.0, 9.0]
    out = StaticPredictor(tb).predict(feats, np.array([[True, False]]))
    assert out.shape == (1, 2, 5, 2)
    np.testing.assert_allclose(out[0, 0], np.tile([2.0, -1.0], (5, 1)))
    assert np.all(out[0, 1] == 0)
    with pytest.raises(ConfigError, match="static expects features"):
        StaticPredictor(tb).predict(feats[..., :-1], np.array([[True, False]]))


def test_on_crowdnavs_quarter_second_steps_it_fits_its_grid_as_cv_and_the_oracle_do():
    for forecaster in (
        StaticForecaster(PLANNER_TIMEBASE),
        ConstantVelocityForecaster(PLANNER_TIMEBASE),
        OracleForecaster([np.zeros((0, 2))], [np.zeros(0, dtype=np.int64)], 0.25),
    ):
        forecaster.fit(0.25)
        assert forecaster.timebase.dt == pytest.approx(0.25) and forecaster.timebase.horizon == 10
        assert forecaster.timebase.stride(0.25) == 1
    fitted = StaticForecaster(PLANNER_TIMEBASE)
    fitted.fit(0.25)
    fc, _ = _walk(fitted, 8, dt=0.25)
    np.testing.assert_allclose(fc.times, 0.25 * np.arange(1, 11))


def test_static_is_a_rule_by_name_for_the_planner_and_a_reserved_model_id():
    assert "static" in RESERVED_MODEL_IDS
    assert isinstance(make_forecaster("static"), StaticForecaster)
    planner = make_planner("predictive", model="static")
    assert isinstance(planner, PredictivePlanner) and isinstance(planner.forecaster, StaticForecaster)


def test_an_evaluation_runs_the_predictive_planner_with_model_static_on_a_crowdnav_suite(tmp_path):
    """The user's path (the library's evaluate, as ``foresight evaluate --local --model static``): the run records the
    rule by name as its model and its checksum, as it does cv."""
    result = foresight.evaluate(
        "predictive", matrix=RAND, seeds=1, model="static", max_steps=12, out=tmp_path / "static"
    )
    assert result.episodes == 1
    assert (result.planner.model_id, result.planner.checkpoint_sha256) == ("static", "static")
