"""The regression gate (candidate vs incumbent on the same episodes) and the floors gate (vs constant velocity)."""

from __future__ import annotations

import math

import pytest

from foresight.core.evaluation.regression import (
    FloorsConfig,
    RegressionGateConfig,
    floors_gate,
    mcnemar_worse_p,
    regression_gate,
)

from .traces import record


def _run(outcomes: list[str]) -> list:
    return [record(f"s_{i % 3}", i, o) for i, o in enumerate(outcomes)]


def _checks(gate) -> dict:
    return {c.name: c for c in gate.checks}


def test_one_sided_mcnemar_is_the_upper_binomial_tail() -> None:
    # 6 discordant pairs all against the candidate: P(X >= 6 | 6, 1/2) = 1/64
    assert mcnemar_worse_p(6, 0) == pytest.approx(1 / 64)
    assert mcnemar_worse_p(0, 6) == pytest.approx(1.0)
    assert mcnemar_worse_p(3, 1) == pytest.approx(sum(math.comb(4, k) for k in (3, 4)) / 16)
    assert mcnemar_worse_p(0, 0) == 1.0


def test_the_unchanged_model_against_itself_passes() -> None:
    runs = _run(["success"] * 8 + ["timeout", "collision_pedestrian"])
    gate = regression_gate(("cand", runs), ("inc", "ab" * 32, list(runs)), RegressionGateConfig())
    assert gate.passed and gate.success.worse == 0 and gate.changed == []
    assert _checks(gate)["success_vs_incumbent"].value == 0.0


def test_a_success_drop_beyond_the_tolerance_fails_naming_value_and_threshold() -> None:
    inc = _run(["success"] * 10)
    cand = _run(["success"] * 8 + ["timeout", "timeout"])
    gate = regression_gate(("cand", cand), ("inc", None, inc), RegressionGateConfig())
    check = _checks(gate)["success_vs_incumbent"]
    assert not gate.passed and not check.passed
    assert check.value == pytest.approx(0.2) and check.threshold == 0.0
    assert sorted((c.seed, c.a, c.b) for c in gate.changed) == [
        (8, "success", "timeout"),
        (9, "success", "timeout"),
    ]
    # within a tolerance of 0.25, and two discordant pairs are no significant evidence: passes
    loose = regression_gate(("cand", cand), ("inc", None, inc), RegressionGateConfig(max_success_drop=0.25))
    assert _checks(loose)["success_vs_incumbent"].passed


def test_the_paired_test_fails_a_drop_inside_the_tolerance_when_it_is_significant() -> None:
    inc = _run(["success"] * 40)
    cand = _run(["success"] * 34 + ["timeout"] * 6)  # 6 of 6 discordant pairs against: p = 1/64 < 0.05
    cfg = RegressionGateConfig(max_success_drop=0.2)
    check = _checks(regression_gate(("c", cand), ("i", None, inc), cfg))["success_vs_incumbent"]
    assert not check.passed and "significantly worse" in check.detail


def test_collisions_rising_fail_and_new_failure_mechanisms_are_flagged() -> None:
    inc = _run(["success"] * 5 + ["timeout"])
    cand = _run(["success"] * 5 + ["collision_pedestrian"])
    gate = regression_gate(("c", cand), ("i", None, inc), RegressionGateConfig())
    checks = _checks(gate)
    assert checks["success_vs_incumbent"].passed and not checks["collision_vs_incumbent"].passed
    new = checks["new_failure_mechanisms"]
    assert new.passed and new.value >= 1 and "flagged" in new.detail
    strict = regression_gate(
        ("c", cand), ("i", None, inc), RegressionGateConfig(fail_on_new_failure_labels=True)
    )
    assert not _checks(strict)["new_failure_mechanisms"].passed


def test_hard_seed_success_may_not_be_lower() -> None:
    runs = _run(["success"] * 4)
    inc_hard = [("a", 1, "success", None), ("b", 2, "success", None)]
    cand_hard = [("a", 1, "success", None), ("b", 2, "timeout", "frozen_robot")]
    gate = regression_gate(("c", runs), ("i", None, runs), RegressionGateConfig(), hard=(cand_hard, inc_hard))
    check = _checks(gate)["hard_success_vs_incumbent"]
    assert not check.passed and check.value == pytest.approx(0.5) and gate.hard_solved == (1, 2, 2)
    assert [(c.scenario, c.a, c.b) for c in gate.hard_changed] == [("b", "success", "timeout")]


def test_other_episodes_are_no_comparison_and_fail() -> None:
    gate = regression_gate(
        ("c", _run(["success"] * 3)), ("i", None, _run(["success"] * 4)), RegressionGateConfig()
    )
    assert not gate.passed and "same episodes" in _checks(gate)["success_vs_incumbent"].detail


def test_floors_are_constant_velocitys_success_and_errors() -> None:
    cv = _run(["success"] * 9 + ["timeout"])
    worse = _run(["success"] * 8 + ["timeout"] * 2)
    gate = floors_gate(worse, cv, FloorsConfig(), ade=(0.3, 0.4), fde=(0.9, 0.8))
    checks = _checks(gate)
    assert not checks["success_vs_constant_velocity"].passed
    assert checks["val_ade_below_constant_velocity"].passed
    assert not checks["val_fde_below_constant_velocity"].passed
    assert floors_gate(cv, cv, FloorsConfig(), ade=(0.3, 0.4), fde=(0.7, 0.8)).passed
