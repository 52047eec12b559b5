"""Collision events: pedestrian, static edge, out of bounds, and the exact timeout."""

from __future__ import annotations

import numpy as np
import pytest

from foresight.core.sim.collision import static_contact
from foresight.core.sim.geometry import SegmentSet
from foresight.core.sim.simulator import Simulator

from .scenes import open_map, scenario, walker


def drive_until_done(scen, cmd=(1.0, 0.0), steps=400):
    sim = Simulator()
    sim.reset(scen, 0, max_steps=steps)
    for _ in range(steps):
        obs, ev = sim.step(cmd)
        if ev.done:
            return sim, obs, ev
    raise AssertionError("episode did not end")


def test_robot_hits_a_standing_pedestrian_at_centre_distance_1_4():
    # a ped with speed 0 cannot be pushed away by the robot force
    m = open_map(
        robot_start=(2.0, 9.9, 0.2, 0.2),
        robot_goal=(37, 9.5),
        singles=(walker("p", (10, 10), None, speed=0.0),),
    )
    sim, obs, ev = drive_until_done(scenario(m))
    assert ev.collision == "pedestrian" and ev.outcome == "collision_pedestrian"
    d = np.hypot(*(obs.robot_pose[:2] - obs.ped_positions[0]))
    assert d <= 1.4 and d > 1.4 - 0.21  # discrete check: detected within one step (<= 0.2 m at 2 m/s)
    tr = sim.trace
    assert (
        tr.collision_kind == "pedestrian"
        and tr.collision_step == tr.steps
        and tr.outcome == "collision_pedestrian"
    )
    assert np.allclose(tr.collision_point, [10, 10])


def test_robot_hits_an_obstacle_edge():
    wall = ((10.0, 5.0), (12.0, 5.0), (12.0, 15.0), (10.0, 15.0))
    m = open_map(obstacles=(wall,), robot_start=(2.0, 9.9, 0.2, 0.2), robot_goal=(37, 9.5))
    sim, obs, ev = drive_until_done(scenario(m))
    assert ev.collision == "static" and ev.outcome == "collision_static"
    assert 9.0 <= obs.robot_pose[0] <= 9.2  # disc radius 1 touches x = 10, detected within one step
    assert sim.trace.collision_point[0] == pytest.approx(10.0)


def test_static_contact_kinds():
    walls = SegmentSet(np.array([[0, 0, 10, 0], [0, 10, 10, 10], [0, 0, 0, 10], [10, 0, 10, 10.0]]))
    assert static_contact(np.array([5.0, 5.0]), 1.0, walls, 10, 10) is None
    assert static_contact(np.array([5.0, 0.9]), 1.0, walls, 10, 10).kind == "static"
    assert static_contact(np.array([5.0, 1.0]), 1.0, walls, 10, 10).kind == "static"  # inclusive
    assert static_contact(np.array([-0.1, 5.0]), 1.0, walls, 10, 10).kind == "out_of_bounds"


def test_driving_off_the_map_is_a_collision():
    m = open_map(width=20, robot_start=(2.0, 14.9, 0.2, 0.2), robot_goal=(37 - 20, 14.5))
    sim = Simulator()
    sim.reset(scenario(m), 0)
    sim.robot[2] = np.pi  # face the left bound
    for _ in range(100):
        _, ev = sim.step((1.0, 0.0))
        if ev.done:
            break
    assert ev.collision in ("static", "out_of_bounds")
    assert sim.robot[0] <= 1.0 + 1e-9


def test_timeout_exactly_at_max_episode_steps():
    m = open_map()
    sim = Simulator()
    sim.reset(scenario(m, max_episode_steps=7), 0)
    for k in range(1, 8):
        obs, ev = sim.step((0.0, 0.0))
        assert ev.timeout == (k == 7) and ev.done == (k == 7)
    assert obs.step == 7 and sim.trace.steps == 7 and sim.trace.outcome == "timeout"
    with pytest.raises(Exception, match="episode is over"):
        sim.step((0.0, 0.0))


def test_goal_reached_within_tolerance():
    m = open_map(width=20, robot_start=(2.0, 9.9, 0.2, 0.2), robot_goal=(12, 9.5))
    sim, obs, ev = drive_until_done(scenario(m))
    assert ev.goal_reached and ev.outcome == "success"
    assert np.hypot(*(obs.robot_pose[:2] - obs.goal)) <= 2.0


def test_pymunk_checker_agrees_with_the_numpy_rule():
    from foresight.core.maps.model import MapDef
    from foresight.core.sim.collision import StaticChecker
    from foresight.core.sim.geometry import StaticMap

    m = MapDef(
        name="m",
        width=20,
        height=20,
        obstacles=(((5, 5), (9, 5), (7, 9)), ((12, 2), (18, 2), (18, 6), (12, 6))),
    )
    st = StaticMap(m)
    rng = np.random.default_rng(0)
    pts = rng.uniform(-0.5, 20.5, (3000, 2))
    for p in pts:
        checker = StaticChecker(st, 1.0)  # fresh: no slack carried over
        a = checker.check(p)
        b = static_contact(p, 1.0, st.walls, 20, 20)
        assert (a is None) == (b is None)
        if a is not None:
            assert a.kind == b.kind and np.allclose(a.point, b.point)
    # along a path the slack shortcut never misses a contact
    checker = StaticChecker(st, 1.0)
    path = np.stack([np.linspace(1.5, 18.5, 400), np.full(400, 3.0)], axis=1)
    got = [checker.check(p) is not None for p in path]
    want = [static_contact(p, 1.0, st.walls, 20, 20) is not None for p in path]
    assert got == want
