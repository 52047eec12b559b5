"""bench/prediction_switch.py's arithmetic on hand-made episodes with known answers: counts, rates, Wilson intervals,
navigation time, and each forecast paired with constant velocity (discordant pairs, exact McNemar p)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from tests.unit.bench_scripts import load_bench

switch = load_bench("prediction_switch")


def _row(
    suite: str, seed: int, forecast: str, outcome: str, steps: int = 40, ade: float | None = 0.1
) -> dict:
    return {
        "suite": suite,
        "seed": seed,
        "forecast": forecast,
        "outcome": outcome,
        "nav_time_s": steps * 0.25,
        "ade_m": ade,
        "fde_m": None if ade is None else 2 * ade,
    }


def test_counts_rates_intervals_and_the_pairing_with_cv() -> None:
    cv = ["success"] * 7 + ["collision_pedestrian", "timeout", "collision_static"]
    learned = ["success"] * 6 + ["collision_pedestrian"] + ["success"] * 3
    rows = [_row("s", k, "cv", o, steps=40 + k) for k, o in enumerate(cv)]
    rows += [_row("s", k, "learned", o, ade=None if k == 0 else 0.2) for k, o in enumerate(learned)]
    rows += [
        _row("s", k, "static", "collision_pedestrian") for k in range(5)
    ]  # only the first 5 episodes ran
    table = switch.summarize(rows, ["static", "cv", "learned"])["s"]
    c = table["forecasts"]["cv"]
    assert (c["episodes"], c["success"], c["collisions"], c["timeouts"]) == (10, 7, 2, 1)
    assert c["success_interval"] == pytest.approx([0.3968, 0.8922], abs=1e-4)  # Wilson 95 % of 7 / 10
    assert c["nav_time_s"] == pytest.approx(np.mean([40 + k for k in range(7)]) * 0.25)
    assert table["forecasts"]["learned"]["forecast_error"] == {
        "ade_m": pytest.approx(0.2),
        "fde_m": pytest.approx(0.4),
    }
    pair = table["paired"]["learned_vs_cv"]
    # cv alone solved episode 6, the learned model alone 7, 8 and 9: 1 : 3, two-sided exact p = 2 x 5 / 16
    assert (pair["episodes"], pair["cv_only"], pair["learned_only"]) == (10, 1, 3)
    assert pair["mcnemar_p"] == pytest.approx(0.625)
    static = table["paired"]["static_vs_cv"]
    assert (static["episodes"], static["cv_only"], static["static_only"]) == (5, 5, 0)
    assert static["mcnemar_p"] == pytest.approx(2 / 32)
    assert "cv_vs_cv" not in table["paired"]


def test_ten_discordant_pairs_one_way_reach_p_below_one_percent() -> None:
    rows = [_row("t", k, "cv", "success" if k < 2 else "collision_pedestrian") for k in range(12)]
    rows += [_row("t", k, "oracle", "success") for k in range(12)]
    pair = switch.summarize(rows, ["cv", "oracle"])["t"]["paired"]["oracle_vs_cv"]
    assert (pair["cv_only"], pair["oracle_only"]) == (0, 10)
    assert pair["mcnemar_p"] == pytest.approx(2 * 0.5**10) and pair["mcnemar_p"] < 0.01


def test_forecast_error_against_the_states_then_seen_leaves_replaced_humans_out() -> None:
    fc = SimpleNamespace(
        ped_ids=np.array([1, 2]),
        times=np.array([0.25, 0.5]),
        positions=np.array([[[0.5, 0.0], [1.0, 0.0]], [[0.0, 0.0], [0.0, 0.0]]]),
    )
    seen = {
        0: {1: np.array([0.0, 0.0]), 2: np.array([0.0, 0.0])},
        1: {1: np.array([0.5, 0.3]), 2: np.array([9.0, 9.0])},  # 2 jumped 12.7 m in 0.25 s: replaced
        2: {1: np.array([1.0, 0.5])},
    }
    ade, fde = switch.forecast_error({0: fc}, seen, 0.25)
    assert ade == pytest.approx(0.4) and fde == pytest.approx(0.5)
    assert switch.forecast_error({0: fc}, {0: {}}, 0.25) is None
