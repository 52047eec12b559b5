"""Single-pedestrian roles and proximity holds on hand-built scenes (robot driven by fixed commands)."""

from __future__ import annotations

import math

import numpy as np

from foresight.core.sim.simulator import Simulator

from .scenes import open_map, scenario, walker


def _drive(scen, command, steps: int, seed: int = 0) -> tuple[Simulator, list[np.ndarray], list[np.ndarray]]:
    """Run ``steps`` steps of a constant command; robot states and all ped positions after each step."""
    sim = Simulator()
    sim.reset(scen, seed)
    robots, peds = [], []
    for _ in range(steps):
        obs, events = sim.step(command)
        robots.append(sim.robot.copy())
        peds.append(sim.crowd.pos.copy())
        assert not events.collision, f"unexpected collision at step {sim.t}"
    return sim, robots, peds


def _offset_point(robot: np.ndarray, offset: tuple[float, float]) -> np.ndarray:
    c, s = math.cos(robot[2]), math.sin(robot[2])
    return robot[:2] + np.array([offset[0] * c - offset[1] * s, offset[0] * s + offset[1] * c])


def test_lead_pedestrian_stays_ahead_of_the_robot_at_its_offset() -> None:
    lead = walker("l1", (6.0, 1.5), speed=1.0, role="lead", role_offset=(3.0, 0.0))
    scen = scenario(open_map(singles=(lead,)), max_episode_steps=400)
    _, robots, peds = _drive(scen, (0.6, 0.0), 150)
    for k in range(30, 150):  # after a 3 s transient
        gap = np.linalg.norm(peds[k][0] - _offset_point(robots[k], (3.0, 0.0)))
        assert gap < 0.75, f"step {k}: {gap:.2f} m from its lead point"
        assert peds[k][0][0] > robots[k][0] + 2.0  # ahead of the robot, not beside or behind
    assert robots[-1][0] > 8.0  # the robot really drove: the lead walked with it


def test_follow_and_accompany_keep_their_offsets() -> None:
    follow = walker("f1", (1.5, 6.0), speed=1.0, role="follow", role_offset=(-3.0, 0.0))
    side = walker(
        "a1", (5.0, 6.0), speed=1.0, role="accompany", role_target_id="robot:0", role_offset=(0.0, 3.0)
    )
    scen = scenario(open_map(singles=(follow, side)), max_episode_steps=400)
    _, robots, peds = _drive(scen, (0.5, 0.0), 200)
    for k in range(100, 200):
        assert np.linalg.norm(peds[k][0] - _offset_point(robots[k], (-3.0, 0.0))) < 0.75
        assert np.linalg.norm(peds[k][1] - _offset_point(robots[k], (0.0, 3.0))) < 0.75


def test_wait_role_holds_its_start() -> None:
    scen = scenario(open_map(singles=(walker("w1", (10.0, 8.0), (30.0, 8.0), role="wait"),)))
    _, _, peds = _drive(scen, (0.0, 0.0), 50)
    assert (
        np.linalg.norm(peds[-1][0] - (10.0, 8.0)) < 0.05
    )  # held (goal := position, velocity := 0 each step)


def _crossing(timeout: float | None = 30.0):
    """A ped that walks to a curb (10, 6), then crosses to (10, 3) = hold_ref_point, once released."""
    ped = walker(
        "c1",
        (10.0, 9.0),
        speed=1.0,
        trajectory=((10.0, 6.0), (10.0, 3.0)),
        hold_until_robot_within_m=3.0,
        hold_ref_point=(10.0, 3.0),
        hold_timeout_s=timeout,
    )
    return scenario(open_map(singles=(ped,)), max_episode_steps=600)


def test_hold_releases_when_the_robot_comes_within_the_distance() -> None:
    sim, robots, peds = _drive(_crossing(), (1.0, 0.0), 110)
    assert sim.singles.released_by == {"c1": "robot_proximity"}
    ref = np.array([10.0, 3.0])
    within = next(k for k, r in enumerate(robots) if np.linalg.norm(r[:2] - ref) <= 3.0)
    # before the robot came near, the ped stood at the curb; it left within two steps of the robot's arrival
    arrived = next(k for k, p in enumerate(peds) if np.linalg.norm(p[0] - (10.0, 6.0)) <= 0.2)
    assert arrived < within - 10
    assert np.linalg.norm(peds[within - 1][0] - (10.0, 6.0)) < 0.25
    assert peds[within + 10][0][1] < peds[within - 1][0][1] - 0.2  # walking on towards (10, 3)


def test_hold_releases_after_its_timeout_without_the_robot() -> None:
    sim, _, peds = _drive(_crossing(timeout=4.0), (0.0, 0.0), 150)
    assert sim.singles.released_by == {"c1": "timeout"}
    arrived = next(k for k, p in enumerate(peds) if np.linalg.norm(p[0] - (10.0, 6.0)) <= 0.2)
    held = [np.linalg.norm(p[0] - peds[arrived + 1][0]) for p in peds[arrived + 1 : arrived + 39]]
    assert max(held) < 0.05  # held at the curb for the 4 s timeout
    assert np.linalg.norm(peds[-1][0] - (10.0, 3.0)) < 0.5  # then crossed


def test_hold_never_releases_early_while_the_robot_is_away() -> None:
    sim, _, _ = _drive(_crossing(timeout=30.0), (0.0, 0.0), 120)
    assert sim.singles.released_by == {}


def test_roles_and_holds_are_deterministic() -> None:
    peds = (
        walker("l1", (6.0, 1.5), speed=1.0, role="lead", role_offset=(3.0, 0.0)),
        walker("j1", (20.0, 12.0), speed=1.0, role="join", role_target_id="l1"),
        walker(
            "c1",
            (10.0, 9.0),
            speed=1.0,
            trajectory=((10.0, 6.0), (10.0, 3.0)),
            hold_until_robot_within_m=3.0,
            hold_ref_point=(10.0, 3.0),
        ),
    )
    scen = scenario(open_map(singles=peds), max_episode_steps=300)
    a, b = _drive(scen, (0.8, 0.05), 120, seed=7), _drive(scen, (0.8, 0.05), 120, seed=7)
    assert np.array_equal(a[0].trace.ped_pos, b[0].trace.ped_pos)
    assert np.array_equal(a[0].trace.robot, b[0].trace.robot)
    # the joiner closed in on the lead pedestrian
    assert np.linalg.norm(a[2][-1][1] - a[2][-1][0]) < np.linalg.norm(np.subtract((20.0, 12.0), (6.0, 1.5)))


def test_join_walks_to_its_target_and_stays_with_it() -> None:
    target = walker("t1", (20.0, 20.0), (30.0, 20.0), speed=0.4)
    joiner = walker("j1", (8.0, 12.0), speed=1.0, role="join", role_target_id="t1")
    scen = scenario(open_map(singles=(target, joiner)), max_episode_steps=600)
    _, _, peds = _drive(scen, (0.0, 0.0), 400)
    gaps = [np.linalg.norm(p[1] - p[0]) for p in peds]
    assert gaps[0] > 10 and max(gaps[250:]) < 1.5  # reached the walking target, then kept up with it


def test_leave_and_lead_with_a_script_walk_the_script() -> None:
    traj = ((12.0, 10.0), (16.0, 12.0))
    plain = walker("a", (8.0, 10.0), speed=1.0, trajectory=traj)
    leave = walker("b", (8.0, 10.0), speed=1.0, trajectory=traj, role="leave")
    lead = walker("c", (8.0, 10.0), speed=1.0, trajectory=traj, role="lead")
    runs = [
        _drive(scenario(open_map(singles=(p,)), max_episode_steps=200), (0.5, 0.0), 100)[2]
        for p in (plain, leave, lead)
    ]
    assert np.array_equal(runs[0][-1], runs[1][-1]) and np.array_equal(runs[0][-1], runs[2][-1])
    assert np.linalg.norm(runs[0][-1][0] - traj[-1]) < 0.5
