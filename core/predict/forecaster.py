"""Forecasters: what the planner calls. They keep live histories from Observations and return
world-frame forecasts on their time base (``core.predict.forecast``: the contract; K = 1 but for a model with
modes, ``core.predict.nn.modes``).

Usage per episode: ``reset()``, then on every simulator step ``observe(obs)`` followed by
``forecast()`` (or ``update(obs)`` for both).
"""

from __future__ import annotations

import math
from typing import Protocol, runtime_checkable

import numpy as np

from foresight.core.errors import ConfigError
from foresight.core.predict.features import ego_to_world, extract_features
from foresight.core.predict.forecast import Forecast
from foresight.core.predict.history import LiveHistory
from foresight.core.predict.predictor import ConstantVelocityPredictor, Predictor, StaticPredictor
from foresight.core.predict.timebase import TimeBase
from foresight.core.predict.uncertainty import CV_SIGMA, LEARNED_SIGMA, GrowingSigma
from foresight.core.sim.observation import Observation

SIGMA_FLOOR = 0.02  #: [m] a model's spread is never taken below this (as the envelopes' sigma0)


@runtime_checkable
class Forecaster(Protocol):
    timebase: TimeBase

    def reset(self) -> None: ...

    def observe(self, obs: Observation) -> None: ...

    def forecast(self) -> Forecast: ...

    def update(self, obs: Observation) -> Forecast: ...


class _PredictorForecaster:
    """Runs a Predictor on the live window's N nearest pedestrians; farther ones (if any) get CV."""

    def __init__(self, predictor: Predictor, max_agents: int | None, source: str, uncertainty: GrowingSigma):
        self.predictor = predictor
        self.uncertainty = uncertainty
        self.timebase = predictor.timebase
        self.max_agents = max_agents
        self.source = source
        self.history = LiveHistory(self.timebase)
        self._cv = ConstantVelocityPredictor(self.timebase)

    def reset(self) -> None:
        self.history.reset()

    def observe(self, obs: Observation) -> None:
        self.history.observe(obs)

    def update(self, obs: Observation) -> Forecast:
        self.observe(obs)
        return self.forecast()

    def forecast(self) -> Forecast:
        window = self.history.window()
        feats = extract_features(window, self.timebase, None)  # all present, closest first
        n = len(feats.ped_ids)
        ego = np.zeros((n, self.timebase.horizon, 2), dtype=np.float32)
        times = self.timebase.times
        sigma = np.repeat(self.uncertainty(times)[None], n, axis=0)
        source = self.source
        n_modes = int(getattr(self.predictor, "n_modes", 1))
        extra = weights = None
        if n:
            k = n if self.max_agents is None else min(n, self.max_agents)
            near = _pad(feats.features[:k], feats.mask[:k], self.max_agents)
            if getattr(self.predictor, "has_sigma", False):  # the model's own spread
                pos, spread = self.predictor.predict_dist(near[0][None], near[1][None])
                ego[:k], sigma[:k] = pos[0, :k], np.maximum(spread[0, :k].astype(np.float64), SIGMA_FLOOR)
            elif n_modes == 1:
                ego[:k] = self.predictor.predict(near[0][None], near[1][None])[0, :k]
            if n_modes > 1:  # the model's modes and weights; mode 0 is the trajectory above
                modes, w = self.predictor.predict_modes(near[0][None], near[1][None])
                ego[:k] = modes[0, :k, 0]
                extra, weights = np.repeat(ego[:, None], n_modes, axis=1), np.zeros((n, n_modes))
                extra[:k], weights[:k] = modes[0, :k], w[0, :k]
                weights[k:, 0] = 1.0
            if k < n:
                ego[k:] = self._cv.predict(feats.features[None, k:], feats.mask[None, k:])[0]
                sigma[k:] = CV_SIGMA(times)
                source = source.replace("learned:", "learned+cv_far:")
                # a far pedestrian: constant velocity as every mode, all weight on mode 0
                if extra is not None:
                    extra[k:] = ego[k:, None]
        if extra is None:
            world = ego_to_world(ego, feats.origin, feats.heading)
            return Forecast.single(feats.ped_ids.copy(), world, sigma, times, source, self.timebase)
        return Forecast(
            feats.ped_ids.copy(),
            ego_to_world(extra, feats.origin, feats.heading),
            weights,
            np.repeat(sigma[:, None], n_modes, axis=1),  # every mode with mode 0's spread
            times,
            source,
            self.timebase,
        )


def _pad(features: np.ndarray, mask: np.ndarray, slots: int | None) -> tuple[np.ndarray, np.ndarray]:
    """Zero-pad (k, F)/(k,) to the predictor's slot count so it sees the shapes it was trained on."""
    if slots is None or len(mask) == slots:
        return features, mask
    f = np.zeros((slots, features.shape[1]), dtype=features.dtype)
    m = np.zeros(slots, dtype=mask.dtype)
    f[: len(mask)], m[: len(mask)] = features, mask
    return f, m


def fitted_timebase(tb: TimeBase, sim_dt: float) -> TimeBase | None:
    """A rule-built forecast needs no trained grid: where the simulator's step does not divide the time base (0.25 s
    steps against 0.2 s), the nearest multiple of the step over at least the same horizon (None: it divides)."""
    ratio = tb.dt / sim_dt
    if abs(ratio - round(ratio)) <= 1e-6 * max(1.0, ratio) and round(ratio) >= 1:
        return None
    dt = sim_dt * max(1, round(ratio))
    return TimeBase(dt=dt, history=tb.history, horizon=max(1, math.ceil(tb.dt * tb.horizon / dt - 1e-9)))


class _RuleForecaster(_PredictorForecaster):
    """A forecast by rule, built from its time base alone (``__init__(timebase)``), so it can move to any grid."""

    def fit(self, sim_dt: float) -> None:
        """Forecast on whole simulator steps (``fitted_timebase``)."""
        fitted = fitted_timebase(self.timebase, sim_dt)
        if fitted is not None:
            self.__init__(fitted)


class ConstantVelocityForecaster(_RuleForecaster):
    """Every present pedestrian continues at its last observed (backward-difference) velocity."""

    def __init__(self, timebase: TimeBase):
        super().__init__(ConstantVelocityPredictor(timebase), None, "constant_velocity", CV_SIGMA)


class StaticForecaster(_RuleForecaster):
    """Every present pedestrian stays at its observed position (CrowdNav++'s prediction ``none``). Its spread is
    constant velocity's (``CV_SIGMA``), so against ``cv`` only the forecast positions differ."""

    def __init__(self, timebase: TimeBase):
        super().__init__(StaticPredictor(timebase), None, "static", CV_SIGMA)


class LearnedForecaster(_PredictorForecaster):
    """A learned Predictor (its own time base and slot count) on the nearest pedestrians.

    Pedestrians beyond the model's ``max_agents`` nearest get constant velocity, and ``source``
    says so (``learned+cv_far:<name>``); nothing falls back silently. The forecast's spread is the model's own
    (``has_sigma``: a sigma head, floored at ``SIGMA_FLOOR``), else the predictor's ``uncertainty`` when it has
    one, else the calibrated envelope ``LEARNED_SIGMA`` (checkpoints without a sigma head).
    """

    def __init__(self, predictor: Predictor, max_agents: int | None = None):
        frame = getattr(predictor, "frame_convention", "robot")
        if frame != "robot":
            raise ConfigError(
                f"model {predictor.name!r} was trained in the {frame!r} frame (robot-less data such as "
                "ETH/UCY); the planner feeds robot-frame features: use a model trained on simulator "
                "data",
                item="model",
            )
        slots = max_agents if max_agents is not None else getattr(predictor, "max_agents", None)
        super().__init__(
            predictor, slots, f"learned:{predictor.name}", getattr(predictor, "uncertainty", LEARNED_SIGMA)
        )
