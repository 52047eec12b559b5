"""A model trained in the focal-pedestrian frame (ETH/UCY: no robot) forecasting live pedestrians for the planner.

Each pedestrian present with its full observed history is, in turn, the focal one: its window is built exactly as
the ETH/UCY import builds a training window (``ethucy.scene_samples``: the focal pedestrian first, its current
position and last observed displacement placing the frame, neighbours as observed, no robot channels), all of them
predicted in one batch and turned back into the world. Pedestrians seen for fewer steps than the model observes get
constant velocity, and ``source`` says so. The forecast is on the model's own time base (0.4 s for ETH/UCY); the
planner resamples it onto its step.
"""

from __future__ import annotations

import numpy as np

from foresight.core.predict.features import Window, ego_to_world, extract_features
from foresight.core.predict.forecast import Forecast
from foresight.core.predict.forecaster import SIGMA_FLOOR
from foresight.core.predict.history import LiveHistory
from foresight.core.predict.uncertainty import CV_SIGMA, LEARNED_SIGMA
from foresight.core.sim.observation import Observation

DEFAULT_SLOTS = 12  #: the ETH/UCY import's default slot count, for checkpoints that do not record theirs


class FocalForecaster:
    """The Forecaster protocol over a focal-pedestrian-frame Predictor (module docstring)."""

    def __init__(self, predictor, max_agents: int | None = None):  # noqa: ANN001 - a Predictor
        self.predictor = predictor
        self.timebase = predictor.timebase
        self.slots = max_agents or getattr(predictor, "max_agents", None) or DEFAULT_SLOTS
        self.history = LiveHistory(self.timebase)
        self.source = f"learned_focal:{predictor.name}"
        self.uncertainty = getattr(predictor, "uncertainty", LEARNED_SIGMA)

    def reset(self) -> None:
        self.history.reset()

    def observe(self, obs: Observation) -> None:
        self.history.observe(obs)

    def update(self, obs: Observation) -> Forecast:
        self.observe(obs)
        return self.forecast()

    def forecast(self) -> Forecast:
        w, tb = self.history.window(), self.timebase
        n, times = len(w.ped_ids), tb.times
        world = np.zeros((n, tb.horizon, 2))
        sigma = np.repeat(self.uncertainty(times)[None], n, axis=0)
        full = w.hist_valid.all(axis=1)
        focal = np.flatnonzero(full)
        source = self.source
        if len(focal):
            frames = []
            for i in focal.tolist():
                order = np.concatenate([[i], np.delete(np.arange(n), i)])
                d = w.ped_hist[i, -1] - w.ped_hist[i, -2] if tb.history > 1 else np.zeros(2)
                heading = float(np.arctan2(d[1], d[0])) if np.hypot(*d) > 1e-9 else 0.0
                win = Window(
                    np.array([*w.ped_hist[i, -1], heading]),
                    np.zeros(2),
                    None,
                    w.ped_ids[order],
                    w.ped_hist[order],
                    w.hist_valid[order],
                )
                frames.append(extract_features(win, tb, self.slots))
            feats = np.stack([f.features for f in frames])
            mask = np.stack([f.mask for f in frames])
            if getattr(self.predictor, "has_sigma", False):
                pos, spread = self.predictor.predict_dist(feats, mask)
                sigma[focal] = np.maximum(spread[:, 0].astype(np.float64), SIGMA_FLOOR)
            else:
                pos = self.predictor.predict(feats, mask)
            for j, (i, f) in enumerate(zip(focal.tolist(), frames, strict=True)):
                world[i] = ego_to_world(pos[j, 0], f.origin, f.heading)
        rest = np.flatnonzero(~full)
        if len(rest):  # too short a history for the model: constant velocity from the last two observations
            last, prev, ok = w.ped_hist[rest, -1], w.ped_hist[rest, -2], w.hist_valid[rest, -2]
            vel = np.where(ok[:, None], (last - prev) / tb.dt, 0.0)
            world[rest] = last[:, None] + times[None, :, None] * vel[:, None]
            sigma[rest] = CV_SIGMA(times)
            source = source.replace("learned_focal:", "learned_focal+cv_short:")
        return Forecast.single(w.ped_ids.copy(), world, sigma, times, source, tb)
