"""Forecast uncertainty: an isotropic Gaussian around each forecast position whose spread grows with its age.

A pedestrian keeps walking roughly as observed, but its velocity is only known up to an error and
changes on the way (turns, speed changes, avoidance). With an initial position error sigma_0 and a
velocity error of std sigma_v, a forecast made t seconds ahead is off by a Gaussian with variance
``sigma_0^2 + (sigma_v t)^2`` per axis: the constant-velocity model's own covariance, and a
calibrated envelope for a learned model whose residuals grow the same way. ``fit`` estimates the two
parameters from forecast errors (``bench/forecast_calibration.py`` prints them per predictor).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class GrowingSigma:
    """Per-axis std [m] of a forecast position ``t`` seconds ahead: sqrt(sigma0^2 + (sigma_v t)^2)."""

    sigma0: float  #: [m] position error at t = 0
    sigma_v: float  #: [m/s] velocity error

    def __call__(self, times: np.ndarray) -> np.ndarray:
        t = np.asarray(times, dtype=float)
        return np.sqrt(self.sigma0**2 + (self.sigma_v * t) ** 2)

    @classmethod
    def fit(cls, times: np.ndarray, errors: np.ndarray) -> GrowingSigma:
        """Least squares on per-axis variances: ``errors`` (M, K, 2) forecast minus truth at ``times`` (K,)."""
        var = np.mean(np.asarray(errors, dtype=float) ** 2, axis=(0, 2))  # (K,) per-axis variance
        A = np.stack([np.ones_like(times), np.asarray(times, dtype=float) ** 2], axis=1)
        (a, b), *_ = np.linalg.lstsq(A, var, rcond=None)
        return cls(sigma0=float(np.sqrt(max(a, 0.0))), sigma_v=float(np.sqrt(max(b, 0.0))))


#: Constant velocity on the planner's time base, fitted by ``bench/forecast_calibration.py --per-scenario 1``
#: on the stress suite's training seeds (25329 pedestrian horizons: sigma0 0.00, sigma_v 0.161); sigma0 is
#: kept at a 0.02 m floor so that a spread is never zero.
CV_SIGMA = GrowingSigma(sigma0=0.02, sigma_v=0.16)
#: The shipped learned model's residual envelope, fitted the same way (sigma_v 0.132).
LEARNED_SIGMA = GrowingSigma(sigma0=0.02, sigma_v=0.13)
