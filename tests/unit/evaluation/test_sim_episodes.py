"""Taxonomy on real simulator episodes (the hand-built traces cover every label; these check the wiring)."""

from __future__ import annotations

from pathlib import Path

import pytest

from foresight.core.evaluation.episode import run_one
from foresight.core.evaluation.plannerspec import PlannerSpec, resolve_planner
from foresight.core.runtime.context import StageContext
from foresight.core.runtime.refs import BUILTIN_CONFIG_ROOT
from foresight.core.scenarios.loader import load_matrix


@pytest.fixture(scope="module")
def matrix():
    return load_matrix(BUILTIN_CONFIG_ROOT / "scenarios" / "classic_interactions.yaml")


def test_goal_seeking_robot_into_a_head_on_crowd_is_robot_fault(matrix, tmp_path: Path) -> None:
    # the goal-seeking robot never avoids: when it hits someone while driving, it is at fault and late
    rp = resolve_planner(PlannerSpec(name="goal"), StageContext(workdir=tmp_path))
    rec = run_one(matrix.get("head_on_corridor_high"), 1200, rp).record
    assert rec.outcome == "collision_pedestrian"
    assert rec.taxonomy.label == "collision_pedestrian_robot_fault"
    assert "late_reaction" in rec.taxonomy.tags
    assert rec.safety.first_collision_step == rec.steps and rec.safety.min_clearance <= 0
    assert rec.provenance.planner_config_hash == rp.config_hash and rec.timing.plan_ms_mean is not None


def test_planner_exception_becomes_an_error_record(matrix, tmp_path: Path, monkeypatch) -> None:
    from foresight.core.planners.goal import GoalSeeking

    def boom(self, obs):
        if obs.step == 3:
            raise RuntimeError("planner exploded")
        return 0.5, 0.0

    monkeypatch.setattr(GoalSeeking, "plan", boom)
    rp = resolve_planner(PlannerSpec(name="goal"), StageContext(workdir=tmp_path))
    rec = run_one(matrix.get("crossing_low"), 1000, rp).record
    assert rec.outcome == "error" and rec.taxonomy.label == "planner_error"
    assert rec.error == "RuntimeError: planner exploded" and rec.steps == 3


def test_a_failure_no_robot_could_avoid_is_marked_unsolvable_and_counted(tmp_path: Path) -> None:
    """A walker who does not see the robot stands in a one-lane corridor: the robot times out, and the record says
    no robot could have reached the goal; with the walker beside the corridor the same failure is solvable; where
    pedestrians react to the robot (their paths depend on it) nothing is claimed."""
    from foresight.core.evaluation.aggregate import aggregate
    from foresight.core.evaluation.taxonomy import TaxonomyConfig
    from tests.unit.sim.test_feasibility import corridor

    stop = resolve_planner(PlannerSpec(name="goal", config={"speed": 0.0}), StageContext(workdir=tmp_path))
    blocked = run_one(corridor((20.0, 10.0)), 1, stop, max_steps=200).record
    assert blocked.outcome == "timeout" and blocked.taxonomy.reachable is False
    free = run_one(corridor((8.0, 20.0)), 1, stop, max_steps=200).record
    assert free.outcome == "timeout" and free.taxonomy.reachable is True
    reacting = run_one(corridor((20.0, 10.0), peds_have_robot_repulsion=True), 1, stop, max_steps=200).record
    assert reacting.outcome == "timeout" and reacting.taxonomy.reachable is None
    unchecked = run_one(
        corridor((20.0, 10.0)), 1, stop, max_steps=200, taxonomy_cfg=TaxonomyConfig(check_reachability=False)
    ).record
    assert unchecked.taxonomy.reachable is None
    rates = aggregate([blocked, free, reacting]).overall.rates
    assert (rates["unsolvable"].count, rates["unsolvable"].n) == (1, 3)
