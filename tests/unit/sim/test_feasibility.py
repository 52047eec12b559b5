"""Space-time reachability (``core.sim.feasibility``): hand-built episodes both ways, timing against the
straight-line bound, and soundness against episodes a real planner solved."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from foresight.core.planners.registry import make_planner
from foresight.core.scenarios.loader import load_matrix
from foresight.core.sim.episode import run_episode
from foresight.core.sim.feasibility import reachability

from .scenes import open_map, scenario, walker

# a 3 m wide corridor (y 8.5 .. 11.5) from x 15 to 25: a 2 m robot cannot pass a walker in it
CORRIDOR = (
    ((15.0, 0.0), (25.0, 0.0), (25.0, 8.5), (15.0, 8.5)),
    ((15.0, 11.5), (25.0, 11.5), (25.0, 30.0), (15.0, 30.0)),
)


def corridor(blocker_at: tuple[float, float], **sim) -> object:
    """The robot drives from x 2 to x 37 along y 10 through the corridor; one walker stands at ``blocker_at``."""
    m = open_map(
        obstacles=CORRIDOR,
        robot_start=(1.5, 9.5, 1.0, 1.0),
        robot_goal=(36.5, 9.5),
        singles=(walker("w", blocker_at, blocker_at, speed=0.0),),
    )
    return scenario(m, **{"peds_have_robot_repulsion": False, "max_episode_steps": 400, **sim})


def test_a_walker_standing_in_a_one_lane_corridor_makes_the_goal_unreachable():
    r = reachability(corridor((20.0, 10.0)), 1)
    assert not r.reachable and r.first_step is None
    assert not r.peds_react  # nobody reacts to the robot: the verdict is exact


def test_the_same_walker_beside_the_corridor_leaves_it_reachable_in_straight_line_time():
    r = reachability(corridor((8.0, 20.0)), 1)
    assert r.reachable
    way = 36.0 - 2.0 - 1.5  # start x to goal x, less the goal tolerance (robot radius 1 + goal radius 0.5)
    assert _from_rest(way) - 3 <= r.first_step <= _from_rest(way) + 3  # as fast as the real robot, not faster


def _from_rest(way: float) -> float:
    """Steps (0.1 s) the robot needs for ``way`` [m] from rest, accelerating at 1 m/s^2 to 2 m/s."""
    return (2.0 / 1.0 / 2 + way / 2.0) / 0.1


@pytest.mark.parametrize("goal", [(30.0, 25.0), (36.0, 10.0)])
def test_a_slanted_run_across_an_open_map_takes_the_robots_own_time(goal: tuple[float, float]):
    """Not faster off the grid's axes either: a lattice that re-rounds every step would let the relaxed robot gain
    up to a cell per axis per step (the verdict before 2026-11-25 reached this goal ~6 % early)."""
    sc = scenario(
        open_map(robot_start=(1.5, 1.5, 1.0, 1.0), robot_goal=goal),
        peds_have_robot_repulsion=False,
        max_episode_steps=400,
    )
    r = reachability(sc, 1, keep_map=True)
    way = float(np.hypot(*(r.where.goal - r.where.start))) - r.where.tolerance
    assert _from_rest(way) - 3 <= r.first_step <= _from_rest(way) + 3


def test_a_walker_coming_through_the_corridor_is_waited_for_when_there_is_time():
    walking = open_map(
        obstacles=CORRIDOR,
        robot_start=(1.5, 9.5, 1.0, 1.0),
        robot_goal=(36.5, 9.5),
        singles=(walker("w", (30.0, 10.0), (6.0, 10.0), speed=1.2),),
    )
    long_enough = reachability(scenario(walking, peds_have_robot_repulsion=False, max_episode_steps=600), 1)
    assert long_enough.reachable
    assert (
        long_enough.first_step > 200
    )  # not through the corridor before the walker is: it waited (straight ~160)
    too_short = reachability(
        scenario(walking, peds_have_robot_repulsion=False, max_episode_steps=long_enough.first_step - 5), 1
    )
    assert not too_short.reachable


@pytest.mark.parametrize(
    ("name", "seed"), [("classic_doorway_low", 141), ("classic_group_crossing_medium", 131)]
)
def test_every_episode_a_planner_solved_is_reachable_no_later(shared_dir: Path, name: str, seed: int):
    """Soundness: the relaxed robot can do whatever the real one did, so a success is never called unreachable."""
    matrix = load_matrix(
        shared_dir / "reference/robot_sf/configs/scenarios/classic_interactions.yaml",
        overrides={"simulation_config": {"ped_speed_tier": "typical", "peds_have_robot_repulsion": False}},
    )
    sc = matrix.get(name)
    ep = run_episode(sc, seed, make_planner("goal"))
    r = reachability(sc, seed)
    if ep.outcome == "success":
        assert r.reachable and r.first_step <= ep.steps
    assert r.reachable  # these two are solvable (the predictive planner solves them)


def test_reference_bottleneck_high_is_unreachable_when_nobody_yields(shared_dir: Path):
    """Three walkers who do not see the robot fill the 4.3 m corridor single file for most of the episode."""
    matrix = load_matrix(
        shared_dir / "reference/robot_sf/configs/scenarios/classic_interactions.yaml",
        overrides={"simulation_config": {"ped_speed_tier": "typical", "peds_have_robot_repulsion": False}},
    )
    r = reachability(matrix.get("classic_bottleneck_high"), 131)
    assert not r.reachable
    assert math.isclose(r.horizon, 500)


def test_the_kept_map_says_where_the_relaxed_robot_could_be_when():
    """Behind a walker standing in the one-lane corridor nothing is ever reachable; before it, each place is first
    reachable no earlier than the fastest straight line allows; the verdict is the one without the map."""
    blocked = corridor((20.0, 10.0))
    r = reachability(blocked, 1, keep_map=True)
    assert r == reachability(blocked, 1)  # the map changes nothing of the verdict
    w = r.where
    first, g = w.reached_at, w.grid
    assert first[round(w.start[0] / g), round(w.start[1] / g)] == 0
    assert (
        first[round(30.0 / g) :, :] < 0
    ).all()  # beyond the walker (x >= 21.4 blocked in the corridor): never
    i, j = np.nonzero(first > 0)
    dist = np.hypot(i * g - w.start[0], j * g - w.start[1])
    assert (
        dist <= first[i, j] * w.dt * 2.0 + 2 * g
    ).all()  # no faster than v_max (2 m/s), up to the grid's slack
    assert len(w.crowd) == r.horizon + 1  # searched to the end: the robot can always wait before the walker
    open_way = reachability(corridor((8.0, 20.0)), 1, keep_map=True)
    assert open_way.where.reached_at.max() == open_way.first_step  # kept up to the step the goal was reached
    assert len(open_way.where.crowd) == open_way.first_step + 1
