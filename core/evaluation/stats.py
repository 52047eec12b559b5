"""Interval estimates for evaluation aggregates (Wilson intervals for rates, seeded bootstrap for means) and
the paired tests of A/B comparisons on the same (scenario, seed) episodes.

Wilson is used for rates because with a few episodes per scenario (3-10) the normal approximation gives
intervals outside [0, 1] and zero width at 0 % or 100 %. Bootstrap intervals are seeded so that the same
records always give the same evaluation.json.

Paired runs (two planners on the same episodes) are compared episode by episode: McNemar's test for a
binary outcome (exact binomial on the discordant pairs, at every count: the chi-square form is only a
large-count shortcut), the Wilcoxon signed-rank test for a continuous metric. Intervals: for a binary
outcome the exact conditional one that matches McNemar's test (Clopper-Pearson on the discordant pairs, so
it excludes 0 exactly when p < 0.05; a percentile bootstrap of 5 discordant pairs in 230 did not), for a
continuous metric a seeded paired bootstrap (pairs resampled together) of the mean difference. No result is marked
significant below ``MIN_PAIRS`` pairs: with fewer, McNemar reaches p < 0.05 only when nearly every
discordant pair goes one way, and the percentile bootstrap under-covers.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from pydantic import BaseModel, ConfigDict

Z95 = 1.959963984540054  #: two-sided 95 % normal quantile
MIN_PAIRS = 20  #: fewest paired episodes (or, unpaired, episodes per side) for a significance mark
ALPHA = 0.05  #: significance level of the paired tests


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


def mcnemar_p(a_only: int, b_only: int) -> float:
    """Two-sided exact McNemar p-value from the discordant pairs (A yes/B no, A no/B yes): a binomial test of
    ``b_only`` out of ``a_only + b_only`` against 1/2; 1.0 without discordant pairs."""
    n = a_only + b_only
    if n == 0:
        return 1.0
    from scipy.stats import binomtest

    return float(binomtest(b_only, n, 0.5).pvalue)


def mcnemar_interval(a_only: int, b_only: int, n: int, confidence: float = 0.95) -> tuple[float, float]:
    """Interval of the paired difference of proportions (B - A) over ``n`` pairs, conditional on the
    discordant count d = a_only + b_only: d/n * (2 q - 1) for q in the Clopper-Pearson interval of b_only/d.
    Without discordant pairs: +-(the Clopper-Pearson upper bound of 0 discordant pairs in n)."""
    from scipy.stats import binomtest

    d = a_only + b_only
    if d == 0:
        upper = 1.0 - ((1.0 - confidence) / 2.0) ** (1.0 / n) if n > 0 else 1.0
        return -upper, upper
    ci = binomtest(b_only, d, 0.5).proportion_ci(confidence_level=confidence, method="exact")
    return d / n * (2 * ci.low - 1), d / n * (2 * ci.high - 1)


def wilcoxon_p(diff: Sequence[float] | np.ndarray) -> float:
    """Two-sided Wilcoxon signed-rank p-value of paired differences (zero differences dropped; exact
    distribution for small samples without ties, normal approximation otherwise); 1.0 when all are zero."""
    d = np.asarray(diff, dtype=float)
    d = d[d != 0]
    if d.size == 0:
        return 1.0
    from scipy.stats import wilcoxon

    return float(wilcoxon(d, zero_method="wilcox").pvalue)


def paired_bootstrap(
    diff: Sequence[float] | np.ndarray, *, samples: int = 2000, seed: int = 123, confidence: float = 0.95
) -> tuple[float, float]:
    """Percentile interval of the mean paired difference, resampling the pairs (seeded)."""
    d = np.asarray(diff, dtype=float)
    if d.size < 2:
        m = float(d.mean()) if d.size else 0.0
        return m, m
    idx = np.random.default_rng(seed).integers(0, d.size, size=(samples, d.size))
    alpha = (1.0 - confidence) / 2.0
    low, high = np.quantile(d[idx].mean(axis=1), [alpha, 1.0 - alpha])
    return float(low), float(high)
