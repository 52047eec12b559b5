"""Simulator contract: determinism, seeding, spawn clearance, observation, trace file, episode loop."""

from __future__ import annotations

import numpy as np
import pytest

from foresight.core.maps.model import Route, Zone
from foresight.core.planners.goal import GoalSeeking
from foresight.core.sim.episode import run_episode
from foresight.core.sim.simulator import Simulator, stopping_zone_clear
from foresight.core.sim.trace import Trace

from .scenes import open_map, scenario, street_map

STREET = scenario(street_map(), name="street", ped_density=0.08, max_episode_steps=300)


def test_same_seed_same_commands_give_bit_identical_traces():
    a = run_episode(STREET, 5, GoalSeeking(noise_v=0.1, noise_w=0.1)).trace
    b = run_episode(STREET, 5, GoalSeeking(noise_v=0.1, noise_w=0.1), simulator=Simulator()).trace
    for name in ("robot", "command", "ped_ids", "ped_pos", "ped_vel"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    assert a.outcome == b.outcome and a.steps == b.steps


def test_different_seeds_give_different_crowds_and_global_rng_is_untouched():
    np.random.seed(123)
    before = np.random.random()
    np.random.seed(123)
    o1 = Simulator().reset(STREET, 1)
    o2 = Simulator().reset(STREET, 2)
    assert np.random.random() == before
    assert o1.ped_positions.shape == o2.ped_positions.shape
    assert not np.allclose(o1.ped_positions, o2.ped_positions)


def test_no_pedestrian_spawns_within_collision_distance_of_the_robot():
    # the robot's spawn zone lies on the pedestrian route: spawns near it must be resampled
    for seed in range(40):
        obs = Simulator().reset(STREET, seed)
        d = np.hypot(*(obs.ped_positions - obs.robot_pose[:2]).T)
        assert d.min() > obs.robot_radius + obs.ped_radius + 0.5 - 1e-9


def test_robot_spawn_clearance_keeps_the_starting_crowd_farther_away_and_only_at_the_start():
    """A scenario's ``robot_spawn_clearance`` (the stress suite: 3 m) replaces the reference's 0.5 m at reset."""
    far = scenario(
        street_map(), name="street", ped_density=0.08, max_episode_steps=300, robot_spawn_clearance=3.0
    )
    near_before = 0
    for seed in range(40):
        before, after = Simulator().reset(STREET, seed), Simulator().reset(far, seed)
        contact = after.robot_radius + after.ped_radius
        near_before += int(
            (np.hypot(*(before.ped_positions - before.robot_pose[:2]).T) <= contact + 3.0).any()
        )
        d = np.hypot(*(after.ped_positions - after.robot_pose[:2]).T)
        assert d.min() > contact + 3.0 - 1e-9, seed
        assert len(after.ped_positions) == len(before.ped_positions)  # moved along their routes, none dropped
    assert near_before >= 10  # the street's crowd does start that close without it


def test_a_negative_robot_spawn_clearance_is_refused_by_name():
    with pytest.raises(ValueError, match="robot_spawn_clearance"):
        scenario(street_map(), name="street", robot_spawn_clearance=-1.0)


def test_stopping_zone_covers_the_braking_distance_ahead_only():
    robot = np.array([0.0, 0.0, 0.0, 2.0, 0.0])  # 2 m/s along +x, decel 1 m/s^2: 2 m to stop
    pts = np.array([[3.5, 0.0], [3.0, 1.5], [4.0, 0.0], [-3.5, 0.0], [0.0, 2.5], [1.0, 3.0]])
    assert stopping_zone_clear(pts, robot, 1.9, 1.0, 60.0).tolist() == [False, False, True, True, True, True]
    assert stopping_zone_clear(pts, robot * [1, 1, 1, 0, 1], 1.9, 1.0, 60.0).all()  # standing: no zone
    backwards = robot * [1, 1, 1, -1, 1]
    assert stopping_zone_clear(pts, backwards, 1.9, 1.0, 60.0).tolist() == [
        True,
        True,
        True,
        False,
        True,
        True,
    ]
    turned = np.array([0.0, 0.0, np.pi / 2, 1.0, 0.0])  # 1 m/s along +y: 0.5 m to stop
    assert stopping_zone_clear(
        np.array([[0.0, 2.3], [0.0, 2.5], [2.3, 0.0]]), turned, 1.9, 1.0, 60.0
    ).tolist() == [False, True, True]


def test_respawns_keep_out_of_a_moving_robots_stopping_zone():
    """Pedestrians respawn in a zone just ahead of a robot held at 2 m/s: none lands where it cannot brake in time.

    (With the collision distance + margin alone, a few respawns per episode land inside its 2 m stopping distance.)
    """
    m = open_map(
        robot_start=(1.0, 9.0, 2.0, 2.0),
        robot_goal=(37.0, 9.5),
        ped_spawn=(Zone.from_rect(6.0, 7.0, 6.0, 6.0),),
        ped_goal=(Zone.from_rect(22.0, 15.0, 2.0, 2.0),),
        ped_routes=(Route(spawn_id=0, goal_id=0, waypoints=((9.0, 16.0), (9.5, 16.0))),),
    )
    scen = scenario(m, name="respawn_ahead", population_size=8, max_peds_per_group=1, max_episode_steps=300)
    moving = np.array([5.0, 10.0, 0.0, 2.0, 0.0])  # heading for the spawn zone at full speed
    sim = Simulator()
    respawns = 0
    for seed in range(3):
        obs = sim.reset(scen, seed)
        ids = obs.ped_ids.copy()
        while not sim.done:
            sim.robot = moving.copy()  # respawns happen at the start of the step, with this robot state
            obs, _ = sim.step((2.0, 0.0))
            new = ~np.isin(obs.ped_ids, ids)
            ids = np.union1d(ids, obs.ped_ids)
            respawns += int(new.sum())
            # positions are read after the step: the respawned pedestrian walked < 0.3 m since
            assert stopping_zone_clear(
                obs.ped_positions[new],
                moving,
                sim.clear - 0.3,
                sim.limits.decel,
                sim.crowd_params.robot_spawn_cone_deg,
            ).all(), (seed, sim.t)
    assert respawns > 50


def test_observation_contract():
    sim = Simulator()
    obs = sim.reset(STREET, 3)
    assert obs.step == 0 and obs.time == 0.0 and obs.dt == 0.1
    assert obs.robot_pose.shape == (3,) and np.all(obs.robot_velocity == 0)
    assert (
        obs.route.shape[1] == 2
        and np.array_equal(obs.route[-1], obs.goal)
        and np.array_equal(obs.route[0], obs.waypoint)
    )
    assert obs.goal_tolerance == 2.0 and obs.robot_radius == 1.0 and obs.ped_radius == 0.4
    assert obs.ped_ids.dtype == np.int64 and len(obs.ped_ids) == len(obs.ped_positions) == len(
        obs.ped_velocities
    )
    assert obs.robot_limits["v_max"] == 2.0
    with pytest.raises(ValueError):
        obs.ped_positions[0, 0] = 1.0  # read-only views of the trace
    first = obs.ped_positions.copy()
    obs2, _ = sim.step((0.5, 0.1))
    assert np.array_equal(obs.ped_positions, first)  # an old observation does not change
    assert obs2.step == 1 and obs2.time == pytest.approx(0.1)
    # static distance: to the block obstacle (14..20 x 0..4) and the bounds
    d = obs.static.distance(np.array([[17.0, 6.0], [1.0, 10.0], [30.0, 10.0]]))
    assert d == pytest.approx([2.0, 1.0, 10.0])
    assert obs.static.distance(np.zeros((3, 4, 2))).shape == (3, 4)


def test_trace_save_and_load_round_trip(tmp_path):
    r = run_episode(STREET, 4, GoalSeeking())
    path = r.trace.save(tmp_path / "t.npz")
    back = Trace.load(path)
    for name in ("robot", "command", "ped_ids", "ped_pos", "ped_vel"):
        assert np.array_equal(getattr(back, name), getattr(r.trace, name))
    meta = back.metadata()
    assert (
        meta["scenario"] == "street"
        and meta["seed"] == 4
        and meta["dt"] == 0.1
        and meta["outcome"] == r.outcome
    )
    assert "code_version" in meta
    assert back.robot.shape == (r.steps + 1, 5) and back.command.shape == (r.steps, 2)


def test_run_episode_result():
    r = run_episode(STREET, 6, GoalSeeking(), max_steps=50)
    assert r.steps <= 50 and r.outcome in ("success", "collision_pedestrian", "collision_static", "timeout")
    assert r.min_distance is not None and r.min_clearance == pytest.approx(r.min_distance - 1.4)
    assert r.wall_s > 0 and r.trace.ped_pos.shape == (r.steps + 1, r.trace.ped_ids.shape[1], 2)


def test_non_finite_command_is_refused():
    sim = Simulator()
    sim.reset(STREET, 0)
    with pytest.raises(Exception, match="non-finite command"):
        sim.step((float("nan"), 0.0))


def test_robot_spawn_clearance_holds_for_respawns_too():
    """A robot standing at the edge of the spawn zone: with ``robot_spawn_clearance`` 3 m no group respawns within 3 m of contact
    (it waits), with the reference's 0.5 m some do."""
    m = open_map(
        robot_start=(1.0, 9.0, 2.0, 2.0),
        robot_goal=(37.0, 9.5),
        ped_spawn=(Zone.from_rect(6.0, 7.0, 6.0, 6.0),),
        ped_goal=(Zone.from_rect(22.0, 15.0, 2.0, 2.0),),
        ped_routes=(Route(spawn_id=0, goal_id=0, waypoints=((9.0, 16.0), (9.5, 16.0))),),
    )
    standing = np.array([6.5, 10.0, 0.0, 0.0, 0.0])  # at the edge of the spawn zone
    nearest = {}
    for clearance in (None, 3.0):
        scen = scenario(
            m,
            name="respawn_here",
            population_size=8,
            max_peds_per_group=1,
            max_episode_steps=300,
            robot_spawn_clearance=clearance,
        )
        sim, respawned = Simulator(), []
        for seed in range(3):
            obs = sim.reset(scen, seed)
            ids = obs.ped_ids.copy()
            while not sim.done:
                sim.robot = standing.copy()
                obs, _ = sim.step((0.0, 0.0))
                new = ~np.isin(obs.ped_ids, ids)
                ids = np.union1d(ids, obs.ped_ids)
                respawned += np.hypot(*(obs.ped_positions[new] - standing[:2]).T).tolist()
        assert len(respawned) > 10, clearance
        nearest[clearance] = min(respawned) - sim.limits.radius - sim.ped_radius
    # positions are read after the step: a respawned pedestrian walked < 0.3 m since
    assert nearest[3.0] > 3.0 - 0.3 and nearest[None] < 2.0
