"""Crowd dynamics in the simulator: free walking, passing, the wall constraint, scripted peds, respawn."""

from __future__ import annotations

import numpy as np
import pytest

from foresight.core.maps.model import WaitRule, Zone
from foresight.core.sim.geometry import points_in_polygons
from foresight.core.sim.params import CrowdParams
from foresight.core.sim.simulator import Simulator

from .scenes import open_map, scenario, street_map, walker


def run_still(scen, steps: int, sim: Simulator | None = None, seed: int = 0):
    """Step a standing robot; returns the simulator (trace holds the crowd)."""
    sim = sim or Simulator()
    sim.reset(scen, seed, max_steps=steps)
    for _ in range(steps):
        _, ev = sim.step((0.0, 0.0))
        if ev.done:
            break
    return sim


def test_free_walker_reaches_goal_at_its_desired_speed():
    m = open_map(width=60, height=40, singles=(walker("a", (10, 20), (40, 20), speed=1.0),))
    sim = run_still(scenario(m), 400)
    pos = sim.trace.ped_pos[:, 0]
    speed = np.hypot(*sim.trace.ped_vel[:, 0].T)
    arrived = np.nonzero(np.hypot(*(pos - [40, 20]).T) <= 0.2)[0]
    assert len(arrived), "the walker never reached its goal"
    t = arrived[0] * 0.1
    assert 30 / 1.3 <= t <= 30 / 1.3 + 1.5  # distance / desired speed, plus ~ relaxation time 0.5 s
    assert speed[50:150] == pytest.approx(1.3, abs=0.01)  # desired speed = 1.3 x speed_m_s
    assert np.hypot(*(pos[-1] - [40, 20])) < 0.3  # brakes and stays at the goal


def test_head_on_walkers_pass_without_stalling():
    a, b = walker("a", (10, 20), (40, 20)), walker("b", (40, 20), (10, 20))
    sim = run_still(scenario(open_map(width=60, height=40, singles=(a, b))), 350)
    pos = sim.trace.ped_pos
    gap = np.hypot(*(pos[:, 0] - pos[:, 1]).T)
    # Both reach their goals (no stall) and keep apart: the sideways Moussaid term makes them swerve
    # to opposite sides. The reference model lets passers brush by closely; 0.5 m centre distance is
    # about a shoulder width, so the two bodies do not overlap (and it is well above zero: no pass-through).
    assert np.hypot(*(pos[-1, 0] - [40, 20])) < 0.3 and np.hypot(*(pos[-1, 1] - [10, 20])) < 0.3
    assert gap.min() > 0.5
    k = gap.argmin()
    # they pass side by side; only the westbound walker swerves: for the eastbound one the interaction
    # direction straddles the +-pi cut, and the reference's unwrapped theta makes its force vanish
    assert abs(pos[k, 0, 1] - pos[k, 1, 1]) > 0.4


def _wall_scene(constraint: bool, speed: float):
    wall = ((9.0, 11.0), (11.0, 11.0), (11.0, 11.2), (9.0, 11.2))  # a thin 0.2 m wall across x 9..11
    m = open_map(
        width=20,
        height=20,
        obstacles=(wall,),
        robot_start=(9.5, 6.9, 1.0, 0.2),
        robot_goal=(18, 1),
        singles=(walker("p", (10.0, 9.5), (10.0, 18.0), speed=speed),),
    )
    cp = CrowdParams(wall_constraint=constraint)
    sim = run_still(scenario(m), 120, sim=Simulator(crowd_params=cp))
    return sim, np.asarray(wall)


@pytest.mark.parametrize("speed", [0.5, 5.0])
def test_walker_pushed_towards_a_wall_never_enters_it(speed):
    # its goal lies behind the wall and the robot below pushes it up as well; the fast one is driven
    # hard enough (6.5 m/s desired) to beat the obstacle force
    sim, wall = _wall_scene(True, speed)
    pos = sim.trace.ped_pos[:, 0]
    assert not points_in_polygons(pos, [wall]).any()
    assert pos[:, 1].max() < 11.0
    if speed > 1:
        assert pos[-1, 1] > 10.99  # pressed against the wall, sliding at most along it


def test_without_the_constraint_a_fast_walker_goes_through():
    sim, wall = _wall_scene(False, 5.0)
    assert sim.trace.ped_pos[:, 0, 1].max() > 11.2  # the reference's soft force alone lets it through


def test_start_delay_ped_moves_after_its_delay_at_scripted_speed():
    m = open_map(
        width=60, height=40, singles=(walker("d", (10, 20), (40, 20), speed=1.0, start_delay_s=2.0),)
    )
    sim = run_still(scenario(m), 150)
    x = sim.trace.ped_pos[:, 0, 0]
    assert np.all(abs(x[:20] - 10.0) < 0.02)  # held at the start for 2 s (only nudged by the map bounds)
    assert x[-1] > 20.0  # then walks (the reference froze it: vmax from the zero spawn velocity)
    assert np.hypot(*sim.trace.ped_vel[-1, 0]) == pytest.approx(1.3, abs=0.01)


def test_trajectory_with_wait_holds_at_the_waypoint():
    p = walker(
        "t",
        (10, 20),
        None,
        speed=1.0,
        trajectory=((20, 20), (20, 30)),
        wait_at=(WaitRule(waypoint_index=0, wait_s=3.0),),
    )
    sim = run_still(scenario(open_map(width=60, height=40, singles=(p,))), 300)
    pos = sim.trace.ped_pos[:, 0]
    near = np.nonzero(np.hypot(*(pos - [20, 20]).T) <= 0.2)[0]
    first = near[0]
    assert np.hypot(*(pos[first + 25] - [20, 20])) < 0.3  # still waiting 2.5 s later
    assert np.hypot(*(pos[-1] - [20, 30])) < 0.3  # then went on to the last waypoint


def test_route_groups_respawn_with_new_ids_and_slots_never_share_ids():
    scen = scenario(street_map(), ped_density=0.08, max_peds_per_group=3, max_episode_steps=900)
    sim = run_still(scen, 900)
    ids = sim.trace.ped_ids
    n = ids.shape[1]
    assert ids.max() >= n  # somebody respawned with a fresh id
    for slot in range(n):
        others = np.delete(ids, slot, axis=1)
        assert not np.isin(np.unique(ids[:, slot]), others).any()
    # a track keeps its id only while it moves continuously (no teleports under one id)
    pos = sim.trace.ped_pos
    same = ids[1:] == ids[:-1]
    jump = np.hypot(*(pos[1:] - pos[:-1]).transpose(2, 0, 1))
    assert jump[same].max() < 0.2


def test_crowded_zone_peds_stay_in_their_zone():
    m = open_map(width=40, height=30, crowded=(Zone.from_rect(20, 10, 10, 10),))
    sim = run_still(scenario(m, population_size=12, zone_sampling="full"), 300)
    pos = sim.trace.ped_pos.reshape(-1, 2)
    assert pos.shape[0] == 301 * 12
    assert (
        (pos[:, 0] > 18).all() and (pos[:, 0] < 32).all() and (pos[:, 1] > 8).all() and (pos[:, 1] < 22).all()
    )


def test_a_group_waits_at_the_route_end_while_its_spawn_zone_is_blocked():
    sim = Simulator()
    sim.reset(scenario(street_map(), ped_density=0.08), 0)
    routes, crowd = sim.routes, sim.crowd
    k = 0
    rows = routes.members[k]
    crowd.pos[rows] = routes.end[k]  # the whole group arrived at its route's last waypoint
    before_ids, before_pos = crowd.ids.copy(), crowd.pos.copy()
    blocked = lambda pts: np.zeros(len(pts), dtype=bool)  # noqa: E731 (e.g. the robot fills the zone)
    assert routes.step(crowd, crowd.centroids(), sim.rng, blocked) is False
    assert np.array_equal(crowd.ids, before_ids) and np.array_equal(crowd.pos, before_pos)
    free = lambda pts: np.ones(len(pts), dtype=bool)  # noqa: E731
    assert routes.step(crowd, crowd.centroids(), sim.rng, free) is True
    assert (crowd.ids[rows] >= len(crowd.ids)).all()  # respawned with fresh ids
