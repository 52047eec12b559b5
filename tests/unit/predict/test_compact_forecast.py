"""The forecast message's compact forms (flat arrays, one shared spread) mean exactly the nested ones; a flat list
of the wrong length is one error naming the predictor; the reference external client answers in that form."""

from __future__ import annotations

import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from foresight.core.predict.external import ENV, ExternalPredictor
from foresight.core.predict.forecast import PredictorError
from foresight.core.predict.plugin import ObservationWindow, declaration, forecast_from
from tests.unit.predict.plugin_predictors import StraightOn

REPO = Path(__file__).resolve().parents[3]


def _window(n: int = 3, history: int = 5, dt: float = 0.2) -> ObservationWindow:
    rng = np.random.default_rng(1)
    start, vel = rng.uniform(0, 10, (n, 1, 2)), rng.normal(0, 1, (n, 1, 2))
    return ObservationWindow(
        time=1.0,
        dt=dt,
        ped_ids=np.arange(n, dtype=np.int64) + 4,
        history=start + vel * dt * np.arange(history)[None, :, None],
        valid=np.ones((n, history), dtype=bool),
        robot_pose=np.zeros(3),
        robot_velocity=np.zeros(2),
        waypoint=None,
    )


def _nested_and_flat():
    plugin, w = StraightOn(), _window()
    nested = plugin.predict(w)
    T = plugin.timebase["horizon"]
    flat = {
        "modes": nested["modes"].ravel().tolist(),
        "weights": nested["weights"].ravel().tolist(),
        "sigma": nested["sigma"][0, 0].tolist(),  # the same spread for everyone: one (T,) list
    }
    assert len(flat["sigma"]) == T
    return plugin, w, nested, flat


def test_flat_arrays_and_a_shared_spread_mean_the_nested_forecast():
    plugin, w, nested, flat = _nested_and_flat()
    decl = declaration(plugin, "mine")
    a = forecast_from(nested, w, decl, "mine", "plugin:mine")
    b = forecast_from(flat, w, decl, "mine", "plugin:mine")
    assert b.modes.shape == (3, 2, 12, 2) and b.spread.shape == (3, 2, 12)
    for name in ("modes", "weights", "spread"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    flat_sigma = dict(flat, sigma=nested["sigma"].ravel().tolist())  # a flat (N K T) spread too
    assert np.array_equal(forecast_from(flat_sigma, w, decl, "mine", "s").spread, a.spread)


def test_a_flat_list_of_the_wrong_length_names_the_predictor_and_the_shape():
    plugin, w, _, flat = _nested_and_flat()
    decl = declaration(plugin, "mine")
    with pytest.raises(PredictorError, match=r"'mine'.*modes must be \(N=3, K, T=12, 2\)"):
        forecast_from(dict(flat, modes=flat["modes"][:-1]), w, decl, "mine", "s")
    with pytest.raises(PredictorError, match=r"'mine'.*spread must be"):
        forecast_from(dict(flat, sigma=flat["sigma"][:-1]), w, decl, "mine", "s")


def test_the_reference_client_answers_constant_velocity_in_the_compact_form(monkeypatch):
    monkeypatch.setenv(
        ENV, json.dumps({"reference": [sys.executable, str(REPO / "examples" / "external_predictor.py")]})
    )
    predictor = ExternalPredictor("reference")
    w = _window(n=4)
    reply = predictor.predict(w)
    assert np.ndim(reply["modes"]) == 1 and np.ndim(reply["sigma"]) == 1  # flat on the wire
    fc = forecast_from(reply, w, declaration(predictor, "external:reference"), "external:reference", "s")
    vel = (w.history[:, -1] - w.history[:, -2]) / w.dt
    expected = w.history[:, -1, None] + fc.times[None, :, None] * vel[:, None]
    assert fc.modes.shape == (4, 1, 12, 2)
    # written to 0.1 mm from a history sent to 1 um (its velocity error grows with the horizon)
    assert np.max(np.abs(fc.modes[:, 0] - expected)) <= 1e-4
    assert np.allclose(fc.weights, 1.0) and np.all(np.diff(fc.spread, axis=-1) > 0)


def test_a_window_written_as_one_line_is_its_observe_message():
    w = _window(n=5)
    for window in (
        w,
        replace(w, valid=w.valid & (np.arange(5)[None, :] > 0)),
    ):  # all observed; oldest unobserved
        line = window.to_line()
        assert line.endswith(b"\n") and line.count(b"\n") == 1
        sent, msg = json.loads(line), window.to_message()
        hist_sent, hist_msg = sent["pedestrians"].pop("history"), msg["pedestrians"].pop("history")
        assert sent == msg
        assert [[p is None for p in track] for track in hist_sent] == [
            [p is None for p in track] for track in hist_msg
        ]
        a = np.array([[p or [np.nan, np.nan] for p in track] for track in hist_sent], dtype=float)
        b = np.array([[p or [np.nan, np.nan] for p in track] for track in hist_msg], dtype=float)
        assert np.allclose(a, b, rtol=0, atol=1e-9, equal_nan=True)  # the same numbers, to 1 um
        assert np.allclose(a[window.valid], window.history[window.valid], rtol=0, atol=5e-7)
