"""Paired A/B statistics: McNemar's exact test and the Wilcoxon signed-rank test against hand-computed values,
the minimum sample size, and paired records against the unpaired MOVER interval on the same data."""

from __future__ import annotations

import math

import pytest

from foresight.core.evaluation.delta import Estimate, mover, paired_delta, paired_deltas
from foresight.core.evaluation.stats import (
    MIN_PAIRS,
    mcnemar_p,
    paired_bootstrap,
    wilcoxon_p,
    wilson_interval,
)

from .traces import record


def _binomial_two_sided(k: int, n: int) -> float:
    """Exact two-sided binomial p at 1/2, written out (the independent check of mcnemar_p)."""
    tail = sum(math.comb(n, i) for i in range(min(k, n - k) + 1)) / 2**n
    return min(1.0, 2 * tail)


@pytest.mark.parametrize("a_only,b_only", [(0, 6), (1, 9), (5, 5), (3, 12), (0, 0), (40, 25)])
def test_mcnemar_is_the_exact_binomial_on_discordant_pairs(a_only: int, b_only: int) -> None:
    expected = 1.0 if a_only + b_only == 0 else _binomial_two_sided(b_only, a_only + b_only)
    assert mcnemar_p(a_only, b_only) == pytest.approx(expected, rel=1e-9)
    assert mcnemar_p(0, 6) == pytest.approx(0.03125)  # 2 / 2^6


def test_wilcoxon_signed_rank_small_exact_case() -> None:
    # six positive differences, no ties: the exact two-sided p is 2 / 2^6
    assert wilcoxon_p([0.1, 0.2, 0.3, 0.4, 0.5, 0.6]) == pytest.approx(0.03125)
    # ranks 1..4 with signs + - + -: W+ = 1 + 3 = 4; 7 of the 16 sign patterns give W+ <= 4 -> p = 2 * 7 / 16
    assert wilcoxon_p([0.1, -0.2, 0.3, -0.4]) == pytest.approx(0.875)
    assert wilcoxon_p([0.0, 0.0]) == 1.0  # no non-zero difference


def test_paired_bootstrap_is_seeded_and_brackets_the_mean() -> None:
    diff = [0.1 * (i % 7) - 0.2 for i in range(50)]
    low, high = paired_bootstrap(diff)
    assert low < sum(diff) / len(diff) < high
    assert paired_bootstrap(diff) == (low, high)


def test_no_significance_mark_below_the_minimum_number_of_pairs() -> None:
    few = paired_delta("success", [False] * 8, [True] * 8)  # 8 discordant pairs all one way: p = 0.0078
    assert few.p_value == pytest.approx(2 / 2**8) and not few.significant
    many = paired_delta("success", [False] * 10 + [True] * (MIN_PAIRS - 10), [True] * MIN_PAIRS)
    assert many.n_pairs == MIN_PAIRS and many.discordant == (0, 10) and many.significant
    unpaired = mover(Estimate(value=0.0, low=0.0, high=0.3, n=8), Estimate(value=1.0, low=0.7, high=1.0, n=8))
    assert unpaired.low > 0 and not unpaired.significant


def test_pairing_finds_a_difference_the_unpaired_interval_cannot() -> None:
    # 40 episodes: A succeeds in 28, B in the same 28 plus 7 more (7 discordant pairs, all B's way)
    a = [i < 28 for i in range(40)]
    b = [i < 35 for i in range(40)]
    paired = paired_delta("success", a, b)
    assert paired.method == "paired" and paired.test == "mcnemar_exact"
    assert paired.delta == pytest.approx(7 / 40) and paired.p_value == pytest.approx(2 / 2**7)
    assert paired.significant and paired.low > 0
    ea, eb = (
        Estimate(value=k / 40, low=wilson_interval(k, 40)[0], high=wilson_interval(k, 40)[1], n=40)
        for k in (28, 35)
    )
    unpaired = mover(ea, eb)
    assert unpaired.delta == pytest.approx(paired.delta) and unpaired.low < 0 and not unpaired.significant


def test_paired_deltas_of_records_pair_by_scenario_and_seed() -> None:
    seeds = range(MIN_PAIRS + 4)
    a = [record("s_low", s, "collision_pedestrian" if s % 2 else "success", ped_y=0.3) for s in seeds]
    b = [record("s_low", s, "success", ped_y=2.0) for s in reversed(seeds)]  # order does not matter
    d = paired_deltas(a, b)
    assert d is not None
    assert d["success"].discordant == (0, len(seeds) // 2) and d["success"].significant
    assert d["collision"].delta == pytest.approx(-0.5)
    assert d["min_clearance"].test == "wilcoxon_signed_rank" and d["min_clearance"].delta > 0
    assert d["min_clearance"].p_value < 0.01
    assert paired_deltas(a, b[:-1]) is None  # other episodes: not paired


def test_the_binary_interval_agrees_with_mcnemar() -> None:
    # 5 discordant pairs of 230, all one way: p = 0.0625, so the interval must include 0
    d = paired_delta("success", [True] * 225 + [False] * 5, [True] * 230)
    assert d.p_value == pytest.approx(0.0625) and not d.significant and d.low < 0 < d.high
    # 7 of 40, all one way: Clopper-Pearson lower bound of 7/7 is 0.025^(1/7), hence the delta's
    e = paired_delta("success", [i < 28 for i in range(40)], [i < 35 for i in range(40)])
    assert e.low == pytest.approx(7 / 40 * (2 * 0.025 ** (1 / 7) - 1)) and e.high == pytest.approx(7 / 40)
    none = paired_delta("collision", [False] * 30, [False] * 30)  # no discordant pair: +-(1 - 0.025^(1/30))
    assert none.delta == 0 and none.high == pytest.approx(1 - 0.025 ** (1 / 30)) and none.low == -none.high
