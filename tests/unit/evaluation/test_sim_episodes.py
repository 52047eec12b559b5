"""Taxonomy on real simulator episodes (the hand-built traces cover every label; these check the wiring)."""

from __future__ import annotations

from pathlib import Path

import pytest

from foresight.core.evaluation.episode import run_one
from foresight.core.evaluation.plannerspec import PlannerSpec, resolve_planner
from foresight.core.scenarios.loader import load_matrix
from foresight.core.stages.context import StageContext
from foresight.core.stages.refs import BUILTIN_CONFIG_ROOT


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
