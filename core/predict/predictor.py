"""The Predictor interface (batched, ego frame) and the constant-velocity baseline.

A predictor maps features (B, N, F) and a slot mask (B, N) to future positions (B, N, T, 2) in the
same ego frame as the features, at its declared time base; inactive slots are zero. The learned
model (``core.predict.nn.model``) satisfies the same protocol.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

from foresight.core.errors import ConfigError
from foresight.core.predict.features import current_index, feature_dim
from foresight.core.predict.timebase import TimeBase


@runtime_checkable
class Predictor(Protocol):
    timebase: TimeBase
    name: str

    def predict(self, features: np.ndarray, mask: np.ndarray) -> np.ndarray:
        """(B, N, F), (B, N) -> (B, N, T, 2) future positions [m] in the features' ego frame."""
        ...


def check_batch(features: np.ndarray, mask: np.ndarray, timebase: TimeBase, who: str) -> None:
    """Raise ConfigError when a batch's shapes do not fit ``timebase`` (feature layout depends on H)."""
    want = feature_dim(timebase.history)
    if features.ndim != 3 or features.shape[-1] != want or mask.shape != features.shape[:2]:
        raise ConfigError(
            f"{who} expects features (B, N, {want}) and mask (B, N) for {timebase.describe()}, "
            f"got {features.shape} and {mask.shape}",
            item="features",
        )


class ConstantVelocityPredictor:
    """Every pedestrian keeps its last observed velocity: p_k = p_0 + k dt v_0 (the baseline).

    v_0 is the backward difference over the last time-base step (zero when only the current step
    was observed), read from the features, so it is exactly the velocity the model sees.
    """

    name = "constant_velocity"

    def __init__(self, timebase: TimeBase):
        self.timebase = timebase

    def predict(self, features: np.ndarray, mask: np.ndarray) -> np.ndarray:
        features, mask = np.asarray(features), np.asarray(mask)
        check_batch(features, mask, self.timebase, self.name)
        H = self.timebase.history
        px, vx = current_index(H, "px"), current_index(H, "vx")
        p0 = features[..., px : px + 2].astype(np.float64)
        v0 = features[..., vx : vx + 2].astype(np.float64)
        out = p0[..., None, :] + self.timebase.times[:, None] * v0[..., None, :]
        return (out * mask[..., None, None]).astype(np.float32)


class StaticPredictor:
    """Every pedestrian stays where it is: p_k = p_0 (CrowdNav++'s prediction ``none``, the floor a forecast is
    measured against: what the planner does knowing only where everyone is now)."""

    name = "static"

    def __init__(self, timebase: TimeBase):
        self.timebase = timebase

    def predict(self, features: np.ndarray, mask: np.ndarray) -> np.ndarray:
        features, mask = np.asarray(features), np.asarray(mask)
        check_batch(features, mask, self.timebase, self.name)
        px = current_index(self.timebase.history, "px")
        p0 = features[..., px : px + 2].astype(np.float64)
        out = np.broadcast_to(p0[..., None, :], p0.shape[:-1] + (self.timebase.horizon, 2))
        return (out * mask[..., None, None]).astype(np.float32)
