"""The live oracle (``core.predict.live_oracle``): on CrowdNav's generated crowds its forecast is where every human
then is, at every decision of an episode the predictive planner drives, where the recorded oracle parts from it."""

from __future__ import annotations

import numpy as np
import pytest

from foresight.core.errors import ConfigError
from foresight.core.planners.predictive.planner import PredictivePlanner
from foresight.core.predict.live_oracle import LiveOracleForecaster
from foresight.core.predict.oracle import OracleForecaster
from foresight.core.scenarios.loader import load_matrix
from foresight.core.sim.episode import run_episode
from foresight.core.sim.simulator import Simulator
from tests.conftest import REPO
from tests.unit.sim.scenes import scenario, street_map

RAND = REPO / "configs" / "scenarios" / "crowdnav" / "crowdnavpp_rand.yaml"


class _Kept:
    """Keeps every forecast the planner is handed and every state it observes, by step."""

    def __init__(self, inner):  # noqa: ANN001
        self.inner, self.forecasts, self.seen, self.step = inner, {}, {}, 0

    def __getattr__(self, name):  # noqa: ANN001, ANN204
        return getattr(self.inner, name)

    def observe(self, obs) -> None:  # noqa: ANN001
        self.step = obs.step
        self.seen[obs.step] = dict(zip(obs.ped_ids.tolist(), obs.ped_positions.copy(), strict=True))
        self.inner.observe(obs)

    def forecast(self):  # noqa: ANN201
        self.forecasts[self.step] = fc = self.inner.forecast()
        return fc


def _errors(kept: _Kept) -> np.ndarray:
    out = []
    for step, fc in kept.forecasts.items():
        for k, t in enumerate(fc.times):
            later = kept.seen.get(step + int(round(t / 0.25)), {})
            out += [
                np.hypot(*(fc.positions[i, k] - later[p]))
                for i, p in enumerate(fc.ped_ids.tolist())
                if p in later
            ]
    return np.asarray(out)


def test_on_crowdnav_rand_every_forecast_is_where_everyone_then_is() -> None:
    sc = load_matrix(RAND).get("crowdnavpp_rand")
    sim = Simulator()
    live = _Kept(LiveOracleForecaster(sim))
    res = run_episode(sc, 1430, PredictivePlanner(None, live), simulator=sim, max_steps=60)
    errors = _errors(live)
    assert res.steps >= 40 and len(errors) > 1000
    assert live.inner.timebase.dt == 0.25 and live.inner.timebase.horizon == 10
    assert np.max(errors) < 1e-9  # exact, though goals change every 5 s (drawn clear of the moving robot)
    recorded = _Kept(OracleForecaster.for_episode(sc, 1430, 60))
    run_episode(sc, 1430, PredictivePlanner(None, recorded), max_steps=60)
    assert np.max(_errors(recorded)) > 0.1  # the recording around a standing robot parts from the episode


def test_a_crowd_that_is_not_generated_is_refused_by_name() -> None:
    sc = scenario(street_map(), ped_density=0.3, peds_have_robot_repulsion=False, max_episode_steps=20)
    sim = Simulator()
    with pytest.raises(ConfigError, match="generated crowd"):
        run_episode(sc, 3, PredictivePlanner(None, LiveOracleForecaster(sim)), simulator=sim)


def test_with_constant_velocitys_spread_only_the_spread_differs() -> None:
    from foresight.core.predict.uncertainty import CV_SIGMA

    sc = load_matrix(RAND).get("crowdnavpp_rand")
    kept = {}
    for name, sigma in (("fixed", None), ("cv", CV_SIGMA)):
        sim = Simulator()
        live = _Kept(LiveOracleForecaster(sim) if sigma is None else LiveOracleForecaster(sim, sigma=sigma))
        run_episode(sc, 1431, PredictivePlanner(None, live), simulator=sim, max_steps=1)
        kept[name] = live.forecasts[0]
    fixed, grown = kept["fixed"], kept["cv"]
    assert np.array_equal(fixed.positions, grown.positions) and np.all(fixed.sigma == 0.05)
    np.testing.assert_allclose(
        grown.sigma, np.repeat(CV_SIGMA(grown.times)[None], len(grown.ped_ids), axis=0)
    )
