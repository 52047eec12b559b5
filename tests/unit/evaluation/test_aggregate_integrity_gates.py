"""Aggregates, integrity violations and the evaluation / closed-loop gates on hand-built records."""

from __future__ import annotations

import pytest

from foresight.core.evaluation.aggregate import BootstrapConfig, aggregate, summarise
from foresight.core.evaluation.gates import (
    ClosedLoopGateConfig,
    EvaluationGateConfig,
    closed_loop_gate,
    evaluation_gate,
)
from foresight.core.evaluation.integrity import check_integrity

from .traces import record

BOOT = BootstrapConfig(samples=200, seed=1)


def _records():
    return [
        record("cross_low", 1),
        record("cross_low", 2),
        record("cross_low", 3, "timeout", speed=0.5),
        record("cross_high", 1),
        record("cross_high", 2, "collision_pedestrian", ped_y=0.0),
        record("door_low", 1),
        record("door_low", 2),
    ]


def test_levels_rates_deltas_and_failed_seeds() -> None:
    agg = aggregate(_records(), BOOT)
    assert agg.overall.episodes == 7
    assert agg.overall.rates["success"].count == 5
    assert agg.overall.rates["collision"].count == 1
    assert [g.key for g in agg.per_scenario] == ["cross_low", "cross_high", "door_low"]
    assert [g.key for g in agg.per_family] == ["cross", "door"]
    assert [g.key for g in agg.per_family_density] == ["cross/low", "cross/high", "door/low"]
    cross_low = agg.per_scenario[0]
    assert cross_low.rates["success"].rate == pytest.approx(2 / 3)
    assert cross_low.delta_to_global["success_rate"] == pytest.approx(2 / 3 - 5 / 7)
    assert [(f.seed, f.outcome) for f in cross_low.failed] == [(3, "timeout")]
    assert agg.per_family[0].taxonomy["collision_pedestrian_robot_fault"] == 1
    assert agg.overall.means["min_clearance"].low <= agg.overall.means["min_clearance"].mean
    assert aggregate(_records(), BOOT) == agg  # deterministic (seeded bootstrap)


def test_clean_records_pass_integrity() -> None:
    rep = check_integrity(_records(), expected=[("cross_low", 1), ("door_low", 2)])
    assert rep.ok and rep.violations == []


def test_success_with_collision_is_a_violation() -> None:
    bad = record("x_low", 1).model_copy(update={"collision_kind": "pedestrian"})
    overlap = record("x_low", 2, ped_y=0.3)  # "success" straight through a pedestrian
    rep = check_integrity([bad, overlap])
    assert not rep.ok
    assert [(v.check, v.seed) for v in rep.violations] == [
        ("success_with_collision", 1),
        ("success_with_collision", 2),
    ]


def test_missing_provenance_and_fallback_and_duplicates_and_missing_episodes() -> None:
    recs = [
        record("a_low", 1, planner_config_hash=""),
        record("a_low", 2, fallback="model failed: cv used"),
        record("a_low", 3),
        record("a_low", 3),
    ]
    rep = check_integrity(recs, expected=[("a_low", 1), ("a_low", 4)])
    checks = sorted(v.check for v in rep.violations)
    assert checks == ["duplicate", "missing_episode", "missing_provenance", "silent_fallback"]


def test_evaluation_gate_pass_and_fail() -> None:
    recs = _records()
    s = summarise(recs, BOOT)
    rep = check_integrity(recs)
    ok = evaluation_gate(s, rep, EvaluationGateConfig(min_success_rate=0.7, min_mean_clearance=0.25))
    assert ok.passed and ok.exit_code == 0
    low = evaluation_gate(s, rep, EvaluationGateConfig(min_success_rate=0.8))
    assert not low.passed and low.exit_code == 2
    assert [c.name for c in low.checks if not c.passed] == ["success_rate"]
    tight = evaluation_gate(s, rep, EvaluationGateConfig(min_success_rate=0.0, min_mean_clearance=2.0))
    assert [c.name for c in tight.checks if not c.passed] == ["mean_min_clearance"]
    broken = check_integrity([*recs, recs[0]])
    assert [c.name for c in evaluation_gate(s, broken, EvaluationGateConfig()).checks if not c.passed] == [
        "integrity"
    ]


def test_gate_on_centre_distance_would_pass_but_clearance_fails() -> None:
    close = [record("c_low", i, ped_y=0.7) for i in range(3)]  # centre 0.7 m, surface gap 0.1 m
    s = summarise(close, BOOT)
    assert s.mean_min_distance.mean == pytest.approx(0.7)
    assert not evaluation_gate(s, check_integrity(close), EvaluationGateConfig()).passed


def test_closed_loop_gate() -> None:
    good = [record("h_low", 1), record("h_low", 2)]
    worse = [record("h_low", 1), record("h_low", 2, "timeout", speed=0.5)]
    cfg = ClosedLoopGateConfig(baseline_variant="base")
    same = closed_loop_gate(
        ("cand", summarise(good, BOOT), summarise(good, BOOT)),
        ("base", summarise(good, BOOT), summarise(good, BOOT)),
        cfg,
    )
    assert same.passed
    drop = closed_loop_gate(
        ("cand", summarise(worse, BOOT), summarise(good, BOOT)),
        ("base", summarise(good, BOOT), summarise(good, BOOT)),
        cfg,
    )
    assert not drop.passed
    assert [c.name for c in drop.checks if not c.passed] == ["hard_success_delta"]
    assert drop.hard_taxonomy.new_labels == ["timeout_slow_progress"]
    strict = ClosedLoopGateConfig(
        baseline_variant="base", min_hard_success_delta=-1.0, fail_on_new_failure_labels=True
    )
    tax = closed_loop_gate(
        ("cand", summarise(worse, BOOT), summarise(good, BOOT)),
        ("base", summarise(good, BOOT), summarise(good, BOOT)),
        strict,
    )
    assert [c.name for c in tax.checks if not c.passed] == ["hard_new_failure_labels"]


def test_closed_loop_gate_reports_paired_tests_and_can_require_a_significant_gain() -> None:
    from foresight.core.evaluation.delta import paired_deltas

    seeds = range(24)
    base = [record("h_low", s, "timeout" if s < 9 else "success", speed=0.5 if s < 9 else 1.0) for s in seeds]
    cand = [record("h_low", s) for s in seeds]  # succeeds on the 9 episodes the baseline timed out
    paired = {"hard": paired_deltas(base, cand), "global": paired_deltas(base, cand)}
    cfg = ClosedLoopGateConfig(baseline_variant="base", require_significant_gain="hard")
    suites = lambda recs: (summarise(recs, BOOT), summarise(recs, BOOT))  # noqa: E731
    gate = closed_loop_gate(("cand", *suites(cand)), ("base", *suites(base)), cfg, paired=paired)
    assert gate.passed and gate.paired["hard"]["success"].discordant == (0, 9)
    hard = next(c for c in gate.checks if c.name == "hard_success_delta")
    assert "mcnemar_exact" in hard.detail and "significant" in hard.detail
    gain = next(c for c in gate.checks if c.name == "hard_significant_success_gain")
    assert gain.passed and gain.value == pytest.approx(2 / 2**9)
    few = {"hard": paired_deltas(base[:12], cand[:12]), "global": None}  # 12 pairs < MIN_PAIRS: no mark
    weak = closed_loop_gate(("cand", *suites(cand)), ("base", *suites(base)), cfg, paired=few)
    assert [c.name for c in weak.checks if not c.passed] == ["hard_significant_success_gain"]
    unpaired = closed_loop_gate(("cand", *suites(cand)), ("base", *suites(base)), cfg)
    assert (
        not unpaired.passed
        and "unpaired" in next(c for c in unpaired.checks if c.name == "hard_success_delta").detail
    )


def test_compare_flags_families_where_a_baseline_is_better() -> None:
    from foresight.core.evaluation.compare import compare

    ours = [record("cross_low", 1), record("cross_low", 2, "timeout", speed=0.5), record("door_low", 1)]
    orca = [record("cross_low", 1), record("cross_low", 2), record("door_low", 1, "timeout", speed=0.5)]
    crash = [
        record("cross_low", 1),
        record("cross_low", 2, "collision_pedestrian", ped_y=0.0),
        record("door_low", 1),
    ]
    c = compare({"predictive": ours, "orca": orca, "goal": crash}, reference="predictive")
    assert c.families_where_a_baseline_is_better == ["cross"]
    assert c.families[0].better_than_reference == ["orca"]  # goal: same success, more collisions
    with pytest.raises(ValueError):
        compare({"predictive": ours, "orca": orca[:2]}, reference="predictive")
    # paired with the reference: orca - predictive per family and overall, never significant on 3 episodes
    assert (
        c.families[0].paired_success["orca"].discordant == (0, 1)
        and c.families[1].paired_success["orca"].delta == -1
    )
    assert (
        c.paired["goal"]["collision"].delta == pytest.approx(1 / 3)
        and not c.paired["orca"]["success"].significant
    )


def test_compare_table_marks_a_paired_difference_with_enough_episodes() -> None:
    from foresight.core.evaluation.compare import compare, table

    cv = [
        record("cross_low", s, "timeout" if s < 10 else "success", speed=0.5 if s < 10 else 1.0)
        for s in range(30)
    ]
    learned = [record("cross_low", s) for s in range(30)]
    c = compare({"learned": learned, "cv": cv}, reference="cv")
    assert c.paired["learned"]["success"].discordant == (0, 10) and c.paired["learned"]["success"].significant
    assert f"+33 pp, p={2 / 2**10:.2g} *" in table(c)


def test_compare_names_the_episodes_that_ended_otherwise() -> None:
    """The discordant pairs behind the paired test, by (scenario, seed), in the JSON and (capped) in the table."""
    from foresight.core.evaluation.compare import SHOWN_CHANGES, compare, table
    from foresight.core.evaluation.delta import changed_episodes

    ours = [record("cross_low", 2, "timeout", speed=0.5), record("cross_low", 1), record("door_low", 1)]
    orca = [
        record("cross_low", 1),
        record("cross_low", 2),
        record("door_low", 1, "collision_pedestrian", ped_y=0.0),
    ]
    c = compare({"predictive": ours, "orca": orca}, reference="predictive")
    assert [(e.scenario, e.seed, e.a, e.b) for e in c.changed["orca"]] == [
        ("cross_low", 2, "timeout", "success"),
        ("door_low", 1, "success", "collision_pedestrian"),
    ]
    text = table(c)
    assert "episodes where orca ends otherwise than predictive:\n  cross_low 2: timeout -> success\n" in text
    assert changed_episodes(ours, orca[:2]) is None  # other episodes: nothing is paired
    many = [record("cross_low", s, "timeout", speed=0.5) for s in range(SHOWN_CHANGES + 5)]
    fine = [record("cross_low", s) for s in range(SHOWN_CHANGES + 5)]
    listing = table(compare({"a": many, "b": fine}, reference="a"))
    assert (
        listing.count(": timeout -> success") == SHOWN_CHANGES
        and "... and 5 more (--json lists every one)" in listing
    )
