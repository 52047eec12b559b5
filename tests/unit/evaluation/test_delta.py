"""A/B deltas: the MOVER interval against Newcombe's published example, and one metric naming for both
stored shapes (an evaluation's GroupStats, a campaign cell's SuiteSummary)."""

from __future__ import annotations

import pytest

from foresight.core.evaluation.aggregate import GroupStats, SuiteSummary
from foresight.core.evaluation.delta import Estimate, deltas, diff_configs, headline, mover
from foresight.core.evaluation.stats import wilson_interval


def _rate(k: int, n: int) -> Estimate:
    low, high = wilson_interval(k, n)
    return Estimate(value=k / n, low=low, high=high)


def test_difference_of_proportions_matches_newcombe_method_10() -> None:
    # Newcombe (1998), Stat. Med. 17:873, example (a): 56/70 vs 48/80, method 10 gives +0.0524 to +0.3339
    d = mover(_rate(48, 80), _rate(56, 70))
    assert d.delta == pytest.approx(0.2)
    assert (d.low, d.high) == (pytest.approx(0.0524, abs=5e-4), pytest.approx(0.3339, abs=5e-4))
    assert d.significant


def test_overlapping_results_are_not_significant_and_missing_sides_give_no_interval() -> None:
    same = mover(_rate(30, 40), _rate(31, 40))
    assert same.low < 0 < same.high and not same.significant
    assert mover(Estimate(value=None), _rate(1, 2)).delta is None
    no_ci = mover(Estimate(value=1.0), Estimate(value=1.5))
    assert no_ci.delta == 0.5 and no_ci.low is None and not no_ci.significant


def test_evaluation_and_campaign_cell_summaries_share_metric_names() -> None:
    rate = {"count": 3, "n": 4, "rate": 0.75, "low": 0.3, "high": 0.95}
    mean = {"n": 4, "mean": 0.4, "low": 0.3, "high": 0.5}
    overall = GroupStats.model_validate(
        {
            "key": "overall",
            "episodes": 4,
            "failed": [],
            "taxonomy": {},
            "rates": {"success": rate, "collision": {**rate, "rate": 0.25}},
            "means": {"min_clearance": mean},
        }
    )
    suite = SuiteSummary.model_validate(
        {
            "episodes": 4,
            "success": {**rate, "rate": 1.0, "low": 0.5, "high": 1.0},
            "collision": rate,
            "mean_min_clearance": mean,
            "mean_min_distance": mean,
            "mean_avg_speed": mean,
            "taxonomy": {},
        }
    )
    assert set(headline(overall)) == {"success", "collision", "min_clearance"}
    assert set(headline(suite)) >= {"success", "collision", "min_clearance"}
    d = deltas(overall, suite)
    assert d["success"].delta == pytest.approx(0.25) and d["min_clearance"].delta == 0.0


def test_config_diff_lists_only_differing_dotted_keys() -> None:
    a = {"planner": {"name": "predictive", "config": {"horizon": 12}}, "seeds": [1, 2]}
    b = {"planner": {"name": "predictive", "config": {"horizon": 8, "w": 1}}, "seeds": [1, 2]}
    assert diff_configs(a, b) == {
        "planner.config.horizon": {"a": 12, "b": 8},
        "planner.config.w": {"a": None, "b": 1},
    }
