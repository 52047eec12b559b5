"""CrowdNav's crowds: generator placement rules, ORCA humans, goal rules, swept contact, per-human radii."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from foresight.core.planners.orca import OrcaConfig, OrcaPlanner
from foresight.core.scenarios.loader import load_matrix
from foresight.core.sim.collision import radii_contact
from foresight.core.sim.planner import EpisodeInfo
from foresight.core.sim.simulator import Simulator

SUITES = Path(__file__).resolve().parents[3] / "configs/scenarios/crowdnav"


def _scenario(name: str):
    m = load_matrix(SUITES / f"{name}.yaml")
    return m.scenarios[0]


def _pairwise_clear(pos: np.ndarray, goal: np.ndarray, r: np.ndarray, gap: float) -> bool:
    for i in range(len(pos)):
        for j in range(i):
            m = r[i] + r[j] + gap
            if np.hypot(*(pos[i] - pos[j])) < m or np.hypot(*(pos[i] - goal[j])) < m:
                return False
    return True


def test_circle_crossing_places_five_humans_on_the_circle_clear_of_the_robot_and_each_other():
    sc = _scenario("circle_crossing")
    sim = Simulator()
    obs = sim.reset(sc, 1000)
    g = sim.generated
    assert np.allclose(obs.robot_pose[:2], [20.0, 16.0]) and np.allclose(obs.goal, [20.0, 24.0])
    assert len(obs.ped_ids) == 5
    local = g.pos - g.centre
    # on the 4 m circle up to the (U - 0.5) x 1 m/s noise per axis, goal opposite
    assert np.all(np.abs(np.hypot(local[:, 0], local[:, 1]) - 4.0) <= math.sqrt(0.5) + 1e-9)
    assert np.allclose(g.goal - g.centre, -local)
    assert _pairwise_clear(g.pos, g.goal, g.radius, 0.2)
    robot = np.array([20.0, 16.0])
    assert np.all(np.hypot(*(g.pos - robot).T) >= 0.3 + 0.3 + 0.2)
    again = Simulator().reset(sc, 1000)
    assert np.array_equal(again.ped_positions, obs.ped_positions)  # the seed is the episode
    other = Simulator().reset(sc, 1001)
    assert not np.array_equal(other.ped_positions, obs.ped_positions)


def test_square_crossing_humans_cross_from_one_side_to_the_other():
    sc = _scenario("square_crossing")
    sim = Simulator()
    sim.reset(sc, 1003)
    g = sim.generated
    start, goal = g.pos - g.centre, g.goal - g.centre
    assert np.all(np.abs(start) <= 5.0 + 1e-9) and np.all(np.abs(goal) <= 5.0 + 1e-9)
    assert np.all(np.sign(start[:, 0]) == -np.sign(goal[:, 0]))


def test_orca_humans_walk_to_their_goals_and_ignore_an_invisible_robot():
    sc = _scenario("circle_crossing")
    runs = []
    for cmd in ((0.0, 0.0), (0.0, 1.0)):  # standing still, or driving up through the crowd
        sim = Simulator()
        sim.reset(sc, 1002)
        start, path = sim.generated.pos.copy(), []
        for _ in range(30):
            _, ev = sim.step(cmd)
            path.append(sim.generated.pos.copy())
            assert np.all(np.hypot(*sim.generated.vel.T) <= 1.0 + 1e-6)
            if ev.done:
                break
        runs.append((start, path, sim.generated.goal.copy()))
    (start, path, goal), (_, path2, _) = runs
    assert len(path) == 30 and np.all(np.hypot(*(path[-1] - goal).T) < np.hypot(*(start - goal).T))
    k = min(len(path), len(path2))
    assert np.array_equal(np.array(path[:k]), np.array(path2[:k]))  # nobody reacted to the robot


def test_a_visible_robot_is_avoided():
    sc = _scenario("circle_crossing")
    moved = []
    for visible in (False, True):
        orca = sc.scenario.simulation_config.orca.model_copy(update={"robot_visible": visible})
        cfg = sc.scenario.simulation_config.model_copy(update={"orca": orca})
        s2 = sc.model_copy(update={"scenario": sc.scenario.model_copy(update={"simulation_config": cfg})})
        sim = Simulator()
        sim.reset(s2, 1002)
        for _ in range(12):
            _, ev = sim.step((0.0, 0.0))
            if ev.done:
                break
        moved.append(sim.generated.pos.copy())
    assert not np.allclose(moved[0], moved[1])


def test_crowdnavpp_rand_draws_speeds_and_radii_and_reports_them_to_planners():
    sc = _scenario("crowdnavpp_rand")
    sim = Simulator()
    obs = sim.reset(sc, 1425)
    g = sim.generated
    assert len(g.pos) == 20
    assert np.all((g.vmax >= 0.5) & (g.vmax <= 1.5)) and np.all((g.radius >= 0.3) & (g.radius <= 0.5))
    assert len(np.unique(g.radius)) == 20
    start, goal = obs.robot_pose[:2] - 20.0, obs.goal - 20.0
    assert np.all(np.abs(start) <= 6) and np.all(np.abs(goal) <= 6) and np.hypot(*(goal - start)) >= 8
    assert obs.ped_radii is not None and len(obs.ped_radii) == len(obs.ped_ids)
    assert np.all(np.hypot(*(obs.ped_positions - obs.robot_pose[:2]).T) <= 5.6)  # the 5 m sensor range
    plain = Simulator().reset(_scenario("crowdnavpp_no_rand"), 1425)
    assert plain.ped_radii is None


def test_crowdnavpp_humans_at_their_goal_respawn_with_a_new_id():
    sc = _scenario("crowdnavpp_no_rand")
    sim = Simulator()
    sim.reset(sc, 1430)
    ids0 = sim.generated.ids.copy()
    for _ in range(195):
        _, ev = sim.step((0.0, 0.0))
        if ev.done:
            break
    assert (sim.generated.ids != ids0).any()
    assert sim.generated.next_id > 20


def test_goal_changes_of_the_rand_variant_happen_every_five_seconds():
    sim = Simulator()
    sim.reset(_scenario("crowdnavpp_rand"), 1426)
    g = sim.generated
    goals, changed_at, robot = g.goal.copy(), [], np.array([1.0, 1.0, 0.0, 0.0, 0.0])
    for step in range(1, 41):
        ids = g.ids.copy()
        g.step(robot, np.zeros(2))
        same = g.ids == ids  # a respawned human has a new goal anyway
        if not np.allclose(g.goal[same], goals[same]):
            changed_at.append(step)
        goals = g.goal.copy()
    assert changed_at == [20, 40]  # every 5 s of 0.25 s steps, about half of the humans each time


def test_swept_contact_catches_a_pass_through_within_one_step():
    robot = np.array([0.0, 0.0])
    ped0, ped1, vel = np.array([[-1.0, 0.0]]), np.array([[1.0, 0.0]]), np.array([[8.0, 0.0]])
    radii = np.array([0.3])
    assert radii_contact(robot, 0.3, ped1, radii)[0] is None  # both states clear: the discrete test misses it
    hit, _ = radii_contact(robot, 0.3, ped1, radii, (robot, ped0, vel, 0.25))
    assert hit is not None and hit.kind == "pedestrian"
    far0, far1 = np.array([[-1.0, 0.7]]), np.array([[1.0, 0.7]])  # passes 0.7 m away: no contact (0.6 m)
    assert radii_contact(robot, 0.3, far1, radii, (robot, far0, vel, 0.25))[0] is None
    big = np.array([0.45])  # per-human radius: the same pass at 0.7 m touches a 0.45 m human
    assert radii_contact(robot, 0.3, far1, big, (robot, far0, vel, 0.25))[0] is not None
    # CrowdNav's segment follows the velocity at the start of the step, not where the pedestrian ended up
    still = np.zeros((1, 2))
    assert radii_contact(robot, 0.3, ped1, radii, (robot, ped0, still, 0.25))[0] is None


def test_orca_robot_on_circle_crossing_reaches_or_collides_within_the_horizon():
    sc = _scenario("circle_crossing")
    cfg = OrcaConfig(
        neighbor_dist=10,
        max_neighbors=10,
        time_horizon=5,
        time_horizon_obst=5,
        radius_margin=0.01,
        ped_radius_margin=0.01,
        arrival_gain=1.0,
    )
    outcomes = []
    for seed in range(1000, 1006):
        sim, p = Simulator(), OrcaPlanner(cfg)
        obs = sim.reset(sc, seed)
        p.reset(EpisodeInfo(sc, seed, 0.25, 0.3, 0.3))
        while True:
            cmd = p.plan(obs)
            assert (
                math.hypot(*cmd) <= 1.0 + 1e-4
            )  # a holonomic robot gets a velocity (RVO2 computes in float)
            obs, ev = sim.step(cmd)
            if ev.done:
                outcomes.append(ev.outcome)
                break
        assert sim.t <= 96
    assert "success" in outcomes and set(outcomes) <= {"success", "collision_pedestrian", "timeout"}


def test_a_generated_crowd_needs_orca_pedestrians():
    from pydantic import ValidationError

    from foresight.core.scenarios.model import Scenario

    with pytest.raises(ValidationError, match="pedestrian_model: orca"):
        Scenario(
            name="x",
            map_file="m.yaml",
            crowd_generator={"rule": "circle_crossing", "human_num": 5, "centre": [20, 20]},
        )


def test_orca_pedestrians_walk_a_maps_routes_too() -> None:
    from tests.unit.sim.scenes import scenario, street_map

    base = scenario(street_map(), max_episode_steps=200, ped_density=0.08)
    orca_cfg = base.scenario.simulation_config.model_copy(update={"pedestrian_model": "orca"})
    orca = base.model_copy(
        update={"scenario": base.scenario.model_copy(update={"simulation_config": orca_cfg})}
    )
    paths = []
    for sc in (base, orca):
        sim = Simulator()
        sim.reset(sc, 3)
        start = sim.crowd.pos.copy()
        for _ in range(30):
            _, ev = sim.step((0.0, 0.0))
            if ev.done:
                break
        paths.append((start, sim.crowd.pos.copy(), sim.crowd.vel.copy()))
    (s0, e0, _), (s1, e1, v1) = paths
    assert np.array_equal(s0, s1) and len(s1) > 0  # the same crowd, moved by another model
    assert not np.allclose(e0, e1)
    assert np.all(np.hypot(*v1.T) <= sim.crowd.vmax + 1e-4) and np.hypot(*(e1 - s1).T).max() > 0.5
