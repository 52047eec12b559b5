"""Forecast spread: the constant-velocity covariance, its fit from errors, and what forecasters hand the planner."""

from __future__ import annotations

import numpy as np
import pytest

from foresight.core.predict.forecaster import ConstantVelocityForecaster
from foresight.core.predict.timebase import PLANNER_TIMEBASE
from foresight.core.predict.uncertainty import CV_SIGMA, GrowingSigma
from tests.unit.predict.helpers import make_obs


def test_sigma_grows_like_a_velocity_error():
    g = GrowingSigma(sigma0=0.1, sigma_v=0.5)
    s = g(np.array([0.0, 1.0, 4.0]))
    assert s.tolist() == pytest.approx([0.1, np.hypot(0.1, 0.5), np.hypot(0.1, 2.0)])
    assert np.all(np.diff(g(PLANNER_TIMEBASE.times)) > 0)


def test_fit_recovers_the_spread_of_gaussian_velocity_errors():
    """Pedestrians whose true velocity differs from the forecast's by N(0, 0.3^2) per axis, plus 0.05 m noise."""
    rng = np.random.default_rng(0)
    t = PLANNER_TIMEBASE.times
    dv = rng.normal(0.0, 0.3, size=(20000, 1, 2))
    err = dv * t[None, :, None] + rng.normal(0.0, 0.05, size=(20000, len(t), 2))
    fit = GrowingSigma.fit(t, err)
    assert fit.sigma_v == pytest.approx(0.3, rel=0.03) and fit.sigma0 == pytest.approx(0.05, rel=0.2)


def test_cv_forecast_carries_its_spread():
    f = ConstantVelocityForecaster(PLANNER_TIMEBASE)
    for k in range(4):
        fc = f.update(make_obs(k, (0.0, 0.0, 0.0), [1, 2], [[0.1 * k, 0.0], [3.0, 3.0]]))
    assert fc.sigma.shape == (2, PLANNER_TIMEBASE.horizon)
    np.testing.assert_allclose(fc.sigma, np.tile(CV_SIGMA(fc.times), (2, 1)))
