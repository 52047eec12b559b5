"""The forecast contract in the planner: modes weighed, time bases resampled, frames converted, K = 1 untouched."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from foresight.core.planners.predictive.forecast_input import planner_forecast
from foresight.core.planners.predictive.planner import PredictivePlanner
from foresight.core.predict.forecast import Forecast, PredictorError, check_forecast
from foresight.core.predict.forecaster import ConstantVelocityForecaster
from foresight.core.predict.timebase import ETHUCY_TIMEBASE, PLANNER_TIMEBASE
from tests.unit.planners.scenes import corridor_map, info_for, observation


class Modes(ConstantVelocityForecaster):
    """Constant velocity, turned into a mixture by ``make(fc) -> Forecast``."""

    def __init__(self, make):
        super().__init__(PLANNER_TIMEBASE)
        self.make = make

    def forecast(self) -> Forecast:
        return self.make(super().forecast())


def _decide(forecaster, peds=((9.0, 10.4), (12.0, 8.0)), vels=((-1.0, 0.0), (0.0, 1.0))):
    m = corridor_map()
    p = PredictivePlanner(None, forecaster)
    p.reset(info_for(m))
    cmd = p.plan(observation(m, peds=peds, ped_vels=np.array(vels, dtype=float)))
    return cmd, p.diagnostics


def _stack(fc: Forecast, modes: list[np.ndarray], weights: list[float]) -> Forecast:
    n = len(fc.ped_ids)
    return replace(
        fc,
        modes=np.stack(modes, axis=1),
        weights=np.tile(np.asarray(weights, dtype=float), (n, 1)),
        spread=np.repeat(fc.spread, len(modes), axis=1),
    )


def test_identical_modes_decide_as_one():
    base_cmd, base = _decide(ConstantVelocityForecaster(PLANNER_TIMEBASE))
    cmd, diag = _decide(Modes(lambda fc: _stack(fc, [fc.positions, fc.positions], [0.5, 0.5])))
    assert cmd == base_cmd and diag["forecast_modes"] == 2
    np.testing.assert_allclose(diag["cost"], base["cost"], rtol=1e-9, atol=1e-9)
    for term in ("collision", "risk", "near_miss", "ttc"):
        np.testing.assert_allclose(diag["terms"][term], base["terms"][term], rtol=1e-9, atol=1e-12)


def test_a_mode_into_the_robot_costs_by_its_weight():
    """A second mode walking straight at the robot's path raises the chosen course's risk with its weight."""

    def at_robot(fc: Forecast, w: float) -> Forecast:
        toward = fc.positions.copy()
        toward[:, :, 1] = 10.0  # everyone on the robot's line
        return _stack(fc, [fc.positions, toward], [1.0 - w, w])

    p = PredictivePlanner(None, Modes(lambda fc: at_robot(fc, 0.0)))
    m = corridor_map()
    obs = observation(m, peds=[(9.0, 12.0)], ped_vels=np.array([[-0.5, 0.0]]))
    costs = []
    for w in (0.0, 0.2, 0.6):
        p = PredictivePlanner(None, Modes(lambda fc, w=w: at_robot(fc, w)))
        p.reset(info_for(m))
        total, terms = p.score_commands(obs, np.array([[1.0, 0.0]]))
        costs.append(float(terms["risk"][0] + terms["collision"][0]))
    assert costs[0] < costs[1] < costs[2]


def test_coarse_time_base_is_resampled_onto_the_rollout_step():
    n = 2
    times = ETHUCY_TIMEBASE.times  # 0.4 s steps, 4.8 s
    vel = np.array([[1.0, 0.0], [0.0, -0.5]])
    start = np.array([[8.0, 10.0], [12.0, 12.0]])
    pos = start[:, None] + times[None, :, None] * vel[:, None]
    fc = Forecast.single(np.array([1, 2]), pos, np.tile(0.1 + 0.1 * times, (n, 1)), times, "test")
    obs = observation(corridor_map(), peds=[tuple(p) for p in start], ped_vels=vel)
    obs = replace(obs, ped_ids=np.array([1, 2]))
    pf = planner_forecast(fc, obs, 0.1)
    np.testing.assert_allclose(pf.times, PLANNER_TIMEBASE.times)  # the planner's step and horizon
    np.testing.assert_allclose(
        pf.positions, start[:, None] + pf.times[None, :, None] * vel[:, None], atol=1e-9
    )
    np.testing.assert_allclose(pf.sigma[:, 1], 0.1 + 0.1 * 0.4)  # 0.4 s is a forecast step: exact
    assert pf.weights is not None and np.all(pf.weights == 1.0)


def test_a_forecast_on_a_coarser_simulator_step_is_used_as_it_is():
    """CrowdNav's 0.25 s steps are coarser than the planner's 0.2 s: constant velocity fits its grid to them, and that
    forecast is the finest there can be, so it passes untouched, its whole horizon kept (not cut to 2.25 s)."""
    cv = ConstantVelocityForecaster(PLANNER_TIMEBASE)
    cv.fit(0.25)
    vel = np.array([[1.0, 0.0]])
    obs = replace(observation(corridor_map(), peds=[(8.0, 10.0)], ped_vels=vel), dt=0.25)
    cv.reset()
    cv.observe(obs)
    fc = cv.forecast()
    pf = planner_forecast(fc, obs, 0.25)
    assert pf.weights is None and np.array_equal(pf.positions, fc.positions)
    assert pf.times[-1] == pytest.approx(fc.times[-1]) and pf.times[-1] > 2.25


def test_pedestrian_frame_is_converted_to_the_world():
    times = PLANNER_TIMEBASE.times
    ego = np.stack([times * 1.0, np.zeros_like(times)], axis=-1)[None]  # 1 m/s straight ahead
    anchors = np.array([[5.0, 5.0, np.pi / 2]])  # facing world +y
    cov = np.zeros((1, 1, len(times), 2, 2))
    cov[..., 0, 0], cov[..., 1, 1] = 0.09, 0.01  # spread along the walking direction
    fc = Forecast(
        np.array([3]), ego[:, None], np.ones((1, 1)), cov, times, "t", frame="pedestrian", anchors=anchors
    )
    world = fc.to_world()
    np.testing.assert_allclose(world.modes[0, 0, :, 0], 5.0, atol=1e-12)
    np.testing.assert_allclose(world.modes[0, 0, :, 1], 5.0 + times)
    np.testing.assert_allclose(world.spread[0, 0, 0], [[0.01, 0.0], [0.0, 0.09]], atol=1e-12)
    np.testing.assert_allclose(world.sigma[0], 0.3)  # the conservative isotropic spread: the largest axis


def _cv(n=2, k=1) -> Forecast:
    t = PLANNER_TIMEBASE.times
    return Forecast(
        np.arange(n), np.zeros((n, k, len(t), 2)), np.full((n, k), 1.0 / k), np.ones((n, k, len(t))), t, "x"
    )


@pytest.mark.parametrize(
    "broken, expected",
    [
        (lambda f: replace(f, modes=f.modes[:, :, :-1]), "modes must be"),
        (lambda f: replace(f, modes=np.where(f.modes == 0, np.nan, f.modes)), "NaN"),
        (lambda f: replace(f, weights=f.weights * 2), "sum to 1"),
        (lambda f: replace(f, times=f.times * 2), "declared time base"),
        (lambda f: replace(f, spread=-f.spread), "spread must be >= 0"),
        (lambda f: replace(f, frame="robot"), "frame must be"),
    ],
)
def test_broken_forecasts_are_refused_naming_the_predictor(broken, expected):
    with pytest.raises(PredictorError, match=f"predictor 'mine'.*{expected}"):
        check_forecast(broken(_cv()), "mine", timebase=PLANNER_TIMEBASE)


def test_too_few_modes_and_missing_pedestrians_are_refused():
    with pytest.raises(PredictorError, match="1 mode.*at least 6"):
        check_forecast(_cv(), "mine", min_modes=6)
    with pytest.raises(PredictorError, match="was asked for"):
        check_forecast(_cv(), "mine", ped_ids=np.array([0, 1, 2]))
    assert check_forecast(_cv(k=6), "mine", min_modes=6).n_modes == 6
