"""Wilson intervals against published values; the bootstrap is seeded and therefore reproducible."""

from __future__ import annotations

import pytest

from foresight.core.evaluation.stats import bootstrap_mean, rate, wilson_interval


@pytest.mark.parametrize(
    ("k", "n", "low", "high"),
    [
        (0, 10, 0.0, 0.2775),  # the "rule of three" regime: not a zero-width interval
        (1, 10, 0.0179, 0.4042),
        (5, 10, 0.2366, 0.7634),
        (8, 10, 0.4902, 0.9433),
        (10, 10, 0.7225, 1.0),
        (30, 69, 0.3243, 0.5521),  # computed by hand from the score formula
    ],
)
def test_wilson_matches_known_values(k: int, n: int, low: float, high: float) -> None:
    lo, hi = wilson_interval(k, n)
    assert lo == pytest.approx(low, abs=1e-4)
    assert hi == pytest.approx(high, abs=1e-4)


def test_rate_without_episodes_is_none() -> None:
    r = rate(0, 0)
    assert r.rate is None and r.low is None and r.n == 0


def test_wilson_rejects_impossible_counts() -> None:
    with pytest.raises(ValueError):
        wilson_interval(11, 10)


def test_bootstrap_is_seeded_and_brackets_the_mean() -> None:
    values = [0.1, 0.5, 0.9, 1.3, 0.2, None, 0.7]
    a = bootstrap_mean(values, samples=500, seed=7)
    b = bootstrap_mean(values, samples=500, seed=7)
    c = bootstrap_mean(values, samples=500, seed=8)
    assert a == b
    assert (a.low, a.high) != (c.low, c.high)
    assert a.n == 6
    assert a.mean == pytest.approx(0.6166667, abs=1e-6)
    assert a.low < a.mean < a.high


def test_bootstrap_degenerate_cases() -> None:
    assert bootstrap_mean([]).mean is None
    one = bootstrap_mean([2.0])
    assert one.mean == one.low == one.high == 2.0
