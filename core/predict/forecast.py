"""The forecast contract: what every predictor hands the planner, whoever wrote it.

A forecast is K modes (or samples) per pedestrian with weights, each mode a trajectory at ``times`` with a
per-step spread, in a declared frame:

- ``modes`` (N, K, T, 2) positions [m]; ``weights`` (N, K), each row >= 0 and summing to 1 (K samples of equal
  weight: 1/K each);
- ``spread``: (N, K, T) per-axis standard deviation [m] of an isotropic Gaussian around each mode position, or
  (N, K, T, 2, 2) full covariances [m^2];
- ``times`` (T,) seconds ahead of the observation, strictly increasing and positive (the predictor's own time
  base: 0.4 s steps for an ETH/UCY model, 0.2 s for the planner's default);
- ``frame``: ``"world"`` (the simulator's map frame) or ``"pedestrian"``: each pedestrian's own frame, origin at
  its last observed position, x axis along its last observed displacement (backward difference; world x when it
  stood still), as ETH/UCY models are trained. ``anchors`` (N, 3) x, y, heading place each pedestrian's frame
  in the world; ``to_world`` converts.

The planner (``core.planners.predictive.forecast_input``) converts the frame, resamples ``times`` onto its rollout
step and weighs every mode. A deterministic predictor is K = 1 (``Forecast.single``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from foresight.core.errors import ConfigError
from foresight.core.predict.timebase import TimeBase

FRAMES = ("world", "pedestrian")
WEIGHT_TOLERANCE = 1e-3  #: |sum of a pedestrian's weights - 1| allowed (rounding in a JSON round trip)


class PredictorError(ConfigError):
    """A predictor (plug-in, external process, checkpoint) broke the forecast contract; names the predictor."""

    def __init__(self, predictor: str, message: str):
        super().__init__(f"predictor {predictor!r}: {message}", item="model")
        self.predictor = predictor


@dataclass(frozen=True)
class Forecast:
    """K weighted modes per pedestrian on the predictor's time base and frame (module docstring)."""

    ped_ids: np.ndarray  #: (N,) int64 true pedestrian ids (those present now)
    modes: np.ndarray  #: (N, K, T, 2) positions [m] in ``frame`` at ``times``
    weights: np.ndarray  #: (N, K) probability of each mode; rows sum to 1
    spread: np.ndarray  #: (N, K, T) isotropic per-axis std [m], or (N, K, T, 2, 2) covariance [m^2]
    times: np.ndarray  #: (T,) seconds ahead of the observation's time [s]
    source: str  #: which predictor made it ("constant_velocity", "learned:<name>", "plugin:<name>", ...)
    timebase: TimeBase | None = None  #: the predictor's declared time base (None: only ``times`` is known)
    frame: str = "world"
    anchors: np.ndarray | None = None  #: (N, 3) x, y, heading of each pedestrian's frame ("pedestrian" only)

    @classmethod
    def single(
        cls,
        ped_ids: np.ndarray,
        positions: np.ndarray,
        sigma: np.ndarray,
        times: np.ndarray,
        source: str,
        timebase: TimeBase | None = None,
    ) -> Forecast:
        """A deterministic forecast: one mode of weight 1, positions (N, T, 2) and isotropic sigma (N, T)."""
        n = len(ped_ids)
        return cls(
            ped_ids,
            positions[:, None],
            np.ones((n, 1)),
            sigma[:, None],
            times,
            source,
            timebase,
        )

    @property
    def n_modes(self) -> int:
        return int(self.modes.shape[1])

    @property
    def full_covariance(self) -> bool:
        return self.spread.ndim == 5

    @property
    def top(self) -> np.ndarray:
        """(N,) index of each pedestrian's most likely mode (the first of equal weights)."""
        return np.argmax(self.weights, axis=1) if self.n_modes > 1 else np.zeros(len(self.ped_ids), int)

    @property
    def positions(self) -> np.ndarray:
        """(N, T, 2) the most likely mode of each pedestrian (best-of-1)."""
        if self.n_modes == 1:
            return self.modes[:, 0]
        return self.modes[np.arange(len(self.ped_ids)), self.top]

    @property
    def mode_sigma(self) -> np.ndarray:
        """(N, K, T) isotropic per-axis std [m]; for a covariance, the root of its largest eigenvalue (an isotropic
        Gaussian no narrower than the full one in any direction: the planner's chance margin stays conservative)."""
        if not self.full_covariance:
            return self.spread
        return np.sqrt(np.maximum(np.linalg.eigvalsh(self.spread)[..., -1], 0.0))

    @property
    def sigma(self) -> np.ndarray:
        """(N, T) per-axis std of the most likely mode."""
        s = self.mode_sigma
        if self.n_modes == 1:
            return s[:, 0]
        return s[np.arange(len(self.ped_ids)), self.top]

    def to_world(self) -> Forecast:
        """The same forecast in the world frame (itself when it already is): modes rotated by each anchor's heading
        and moved to its position; covariances rotated (isotropic spreads are unchanged by a rotation)."""
        if self.frame == "world":
            return self
        a = np.asarray(self.anchors, dtype=float)
        c, s = np.cos(a[:, 2])[:, None, None], np.sin(a[:, 2])[:, None, None]
        x, y = self.modes[..., 0], self.modes[..., 1]
        modes = np.empty(self.modes.shape)
        modes[..., 0] = a[:, 0, None, None] + c * x - s * y
        modes[..., 1] = a[:, 1, None, None] + s * x + c * y
        spread = self.spread
        if self.full_covariance:
            rot = np.zeros((len(a), 2, 2))
            rot[:, 0, 0], rot[:, 0, 1] = np.cos(a[:, 2]), -np.sin(a[:, 2])
            rot[:, 1, 0], rot[:, 1, 1] = np.sin(a[:, 2]), np.cos(a[:, 2])
            r = rot[:, None, None]
            spread = r @ spread @ np.swapaxes(r, -1, -2)
        return replace(self, modes=modes, spread=spread, frame="world", anchors=None)


def check_forecast(
    fc: Forecast,
    who: str,
    *,
    ped_ids: np.ndarray | None = None,
    min_modes: int = 1,
    timebase: TimeBase | None = None,
) -> Forecast:
    """``fc`` itself when it keeps the contract, else PredictorError naming ``who`` and what was expected.

    ``ped_ids``: the pedestrians asked about (each must be forecast, in that order); ``min_modes``: the fewest
    modes accepted; ``timebase``: the time base the predictor declared (its ``times`` must be that one's)."""
    if not isinstance(fc, Forecast):
        raise PredictorError(who, f"returned {type(fc).__name__}, expected a Forecast")
    n = len(fc.ped_ids)
    times = np.asarray(fc.times, dtype=float)
    if times.ndim != 1 or len(times) == 0:
        raise PredictorError(who, f"times must be a non-empty 1-D array, got shape {times.shape}")
    if not (np.all(np.isfinite(times)) and times[0] > 0 and np.all(np.diff(times) > 0)):
        raise PredictorError(who, f"times must be positive and increasing, got {times.tolist()}")
    T = len(times)
    if fc.modes.ndim != 4 or fc.modes.shape[0] != n or fc.modes.shape[2:] != (T, 2):
        raise PredictorError(who, f"modes must be (N={n}, K, T={T}, 2), got {fc.modes.shape}")
    K = fc.modes.shape[1]
    if max(1, min_modes) > K:
        raise PredictorError(who, f"gave {K} mode(s) per pedestrian, at least {max(1, min_modes)} expected")
    if fc.weights.shape != (n, K):
        raise PredictorError(who, f"weights must be (N={n}, K={K}), got {fc.weights.shape}")
    if fc.spread.shape not in ((n, K, T), (n, K, T, 2, 2)):
        raise PredictorError(who, f"spread must be (N, K, T) or (N, K, T, 2, 2), got {fc.spread.shape}")
    for name in ("modes", "weights", "spread"):
        a = getattr(fc, name)
        # one sum first (NaN/inf anywhere makes it so; an overflow is told apart by the full test)
        if a.size and not np.isfinite(np.add.reduce(a, axis=None)) and not np.all(np.isfinite(a)):
            raise PredictorError(who, f"{name} holds NaN or infinite values")
    if n and (np.any(fc.weights < 0) or np.any(np.abs(fc.weights.sum(axis=1) - 1.0) > WEIGHT_TOLERANCE)):
        raise PredictorError(who, "weights must be >= 0 and sum to 1 for every pedestrian")
    if np.any((fc.mode_sigma if fc.full_covariance else fc.spread) < 0):
        raise PredictorError(
            who, "spread must be >= 0 (standard deviations; covariances positive semi-definite)"
        )
    if fc.frame not in FRAMES:
        raise PredictorError(who, f"frame must be one of {', '.join(FRAMES)}, got {fc.frame!r}")
    if fc.frame == "pedestrian" and (fc.anchors is None or np.shape(fc.anchors) != (n, 3)):
        raise PredictorError(who, "a forecast in the pedestrian frame needs anchors (N, 3): x, y, heading")
    if ped_ids is not None and not np.array_equal(np.asarray(fc.ped_ids), np.asarray(ped_ids)):
        raise PredictorError(
            who,
            f"forecast pedestrians {np.asarray(fc.ped_ids).tolist()} but was asked for "
            f"{np.asarray(ped_ids).tolist()} (every pedestrian present, in the observation's order)",
        )
    if timebase is not None and (
        times.shape != (timebase.horizon,) or np.max(np.abs(times - timebase.times)) > 1e-6
    ):
        raise PredictorError(
            who, f"forecast times {times.tolist()} are not its declared time base ({timebase.describe()})"
        )
    return fc
