"""Closed loop: a doorway standoff with pedestrians who wait for the robot ends only if the robot commits.

The reference's doorway at its own defaults (pedestrians repelled by the robot): the pedestrians stop
on the far side of the door and wait for the robot, and a robot that never trusts them to make room
waits for them for ever. Both ways, with constant velocity (deterministic, about a second each).
"""

from __future__ import annotations

import pytest

from foresight.core.planners.registry import make_planner
from foresight.core.scenarios.loader import load_matrix
from foresight.core.sim.episode import run_episode


@pytest.fixture(scope="module")
def doorway(reference_matrix_path):
    return load_matrix(reference_matrix_path).get("classic_doorway_low")


@pytest.mark.parametrize(
    ("config", "outcome"), [({}, "success"), ({"safety": {"crowd": {"yielding": {"speed": 0.0}}}}, "timeout")]
)
def test_the_robot_commits_after_yielding_and_passes_the_door(doorway, config, outcome):
    result = run_episode(doorway, 141, make_planner("predictive", config, model="cv"))
    assert result.outcome == outcome
    assert result.min_clearance is None or result.min_clearance > 0
