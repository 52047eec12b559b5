"""The 23 reference (robot_sf classic) scenarios run end to end with the goal-seeking controller."""

from __future__ import annotations

import numpy as np
import pytest

from foresight.core.planners.goal import GoalSeeking
from foresight.core.scenarios.loader import load_matrix
from foresight.core.sim.episode import run_episode
from foresight.core.sim.population import pedestrian_count
from foresight.core.sim.simulator import Simulator

# pedestrians per scenario (route + single), reference-simulation §6.3
EXPECTED_PEDS = {
    "classic_bottleneck_low": 0,
    "classic_bottleneck_medium": 1,
    "classic_bottleneck_high": 3,
    "classic_realworld_double_bottleneck_high": 8,
    "classic_station_platform_medium": 26,
    "classic_cross_trap_low": 3,
    "classic_cross_trap_medium": 8,
    "classic_cross_trap_high": 12,
    "classic_doorway_low": 3,
    "classic_doorway_medium": 6,
    "classic_doorway_high": 9,
    "classic_group_crossing_low": 2,
    "classic_group_crossing_medium": 3,
    "classic_group_crossing_high": 4,
    "classic_head_on_corridor_low": 2,
    "classic_head_on_corridor_medium": 4,
    "classic_merging_low": 4,
    "classic_merging_medium": 9,
    "classic_overtaking_low": 3,
    "classic_overtaking_medium": 6,
    "classic_t_intersection_low": 2,
    "classic_t_intersection_medium": 3,
    "classic_urban_crossing_medium": 5,
}


@pytest.fixture(scope="module")
def matrix(reference_matrix_path):
    return load_matrix(reference_matrix_path)


def test_matrix_has_the_23_scenarios_with_reference_pedestrian_counts(matrix):
    assert matrix.names == list(EXPECTED_PEDS)
    assert {s.name: pedestrian_count(s) for s in matrix.scenarios} == EXPECTED_PEDS


@pytest.mark.parametrize("name", list(EXPECTED_PEDS))
def test_each_scenario_runs_an_episode(matrix, name):
    s = matrix.get(name)
    r = run_episode(s, s.scenario.seeds[0], GoalSeeking())
    assert r.outcome in ("success", "collision_pedestrian", "collision_static", "timeout")
    assert 1 <= r.steps <= s.scenario.simulation_config.max_episode_steps
    assert r.trace.ped_ids.shape[1] == EXPECTED_PEDS[name]
    assert np.isfinite(r.trace.ped_pos).all() and np.isfinite(r.trace.robot).all()
    # nobody walks into an obstacle (the wall constraint)
    sim_static = Simulator()._static(s)
    if r.trace.ped_pos.size:
        assert not sim_static.inside_obstacle(r.trace.ped_pos.reshape(-1, 2)).any()


@pytest.mark.parametrize(
    ("name", "seed"), [("classic_station_platform_medium", 302), ("classic_cross_trap_high", 102)]
)
def test_reference_step_one_collisions_do_not_happen(matrix, name, seed):
    # in robot_sf these two episodes collide at step 1 (a pedestrian spawned on the robot)
    s = matrix.get(name)
    sim = Simulator()
    obs = sim.reset(s, seed)
    d = np.hypot(*(obs.ped_positions - obs.robot_pose[:2]).T)
    assert d.min() > 1.4 + 0.5 - 1e-9
    _, ev = sim.step((0.0, 0.0))
    assert ev.collision is None


@pytest.mark.parametrize("name", ["classic_head_on_corridor_medium", "classic_t_intersection_low"])
def test_robot_never_starts_touching_a_wall(matrix, name):
    # robot_sf samples such starts (its spawn zones reach within 1 m of walls): step-1 static collisions
    s = matrix.get(name)
    sim = Simulator()
    for seed in range(30):
        obs = sim.reset(s, seed)
        assert obs.static.distance(obs.robot_pose[None, :2])[0] > obs.robot_radius
