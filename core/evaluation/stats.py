"""Interval estimates for evaluation aggregates: Wilson intervals for rates, seeded bootstrap for means.

Wilson is used for rates because with a few episodes per scenario (3-10) the normal approximation gives
intervals outside [0, 1] and zero width at 0 % or 100 %. Bootstrap intervals are seeded so that the same
records always give the same evaluation.json.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from pydantic import BaseModel, ConfigDict

Z95 = 1.959963984540054  #: two-sided 95 % normal quantile


class RateEstimate(BaseModel):
    """A proportion k/n with its Wilson interval."""

    model_config = ConfigDict(frozen=True)

    count: int
    n: int
    rate: float | None  #: None when n == 0
    low: float | None
    high: float | None


class MeanEstimate(BaseModel):
    """A mean over episodes with a percentile-bootstrap interval (None values are excluded)."""

    model_config = ConfigDict(frozen=True)

    n: int
    mean: float | None
    low: float | None
    high: float | None


def wilson_interval(count: int, n: int, z: float = Z95) -> tuple[float, float]:
    """Wilson score interval for ``count`` successes in ``n`` trials (n > 0)."""
    if n <= 0:
        raise ValueError("wilson_interval needs n > 0")
    if not 0 <= count <= n:
        raise ValueError(f"count {count} outside [0, {n}]")
    p = count / n
    z2 = z * z
    denom = 1.0 + z2 / n
    centre = (p + z2 / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z2 / (4 * n * n)) / denom
    return max(0.0, centre - half), min(1.0, centre + half)


def rate(count: int, n: int) -> RateEstimate:
    if n == 0:
        return RateEstimate(count=0, n=0, rate=None, low=None, high=None)
    low, high = wilson_interval(count, n)
    return RateEstimate(count=count, n=n, rate=count / n, low=low, high=high)


def bootstrap_mean(
    values: Sequence[float | None], *, samples: int = 1000, seed: int = 123, confidence: float = 0.95
) -> MeanEstimate:
    """Mean of the non-None, finite values with a seeded percentile-bootstrap interval."""
    arr = np.asarray([v for v in values if v is not None and math.isfinite(v)], dtype=float)
    n = int(arr.size)
    if n == 0:
        return MeanEstimate(n=0, mean=None, low=None, high=None)
    mean = float(arr.mean())
    if n == 1 or samples <= 0:
        return MeanEstimate(n=n, mean=mean, low=mean, high=mean)
    rng = np.random.default_rng(seed)
    idx = rng.integers(0, n, size=(samples, n))
    means = arr[idx].mean(axis=1)
    alpha = (1.0 - confidence) / 2.0
    low, high = np.quantile(means, [alpha, 1.0 - alpha])
    return MeanEstimate(n=n, mean=mean, low=float(low), high=float(high))
