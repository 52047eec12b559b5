"""Realistic crowds: measured walking speeds, pedestrians that ignore the robot or notice it late."""

from __future__ import annotations

import numpy as np

from foresight.core.scenarios.model import SimulationConfig
from foresight.core.sim.params import SPEED_TIERS, CrowdParams
from foresight.core.sim.population import desired_speeds
from foresight.core.sim.simulator import Simulator

from .scenes import open_map, scenario, street_map, walker

ROBOT = np.array([10.0, 10.0])


def test_realistic_tier_matches_measured_walking_speeds():
    cfg = SimulationConfig(ped_speed_tier="realistic")
    v = desired_speeds(40000, cfg, CrowdParams(), np.random.default_rng(3))
    assert SPEED_TIERS["realistic"] == (1.34, 0.26)  # Weidmann 1993
    assert abs(v.mean() - 1.34) < 0.005 and abs(v.std() - 0.26) < 0.005
    assert abs(np.median(v) - 1.34) < 0.01 and v.min() >= 0.1 and v.max() <= 3.0
    # about 95 % of free walkers between 0.83 and 1.85 m/s (mean +- 1.96 std)
    assert 0.94 < ((v > 0.83) & (v < 1.85)).mean() < 0.96
    again = desired_speeds(40000, cfg, CrowdParams(), np.random.default_rng(3))
    assert np.array_equal(v, again)


def test_realistic_tier_in_a_simulated_crowd():
    sim = Simulator()
    sim.reset(scenario(street_map(), ped_density=0.3, ped_speed_tier="realistic"), 0)
    v = sim.crowd.vmax
    assert len(v) > 30 and 1.2 < v.mean() < 1.5 and 0.15 < v.std() < 0.37


def _crossing(**sim_cfg):
    """A robot standing at (10, 10) and one pedestrian walking straight down through that spot."""
    m = open_map(
        robot_start=(10.0, 10.0, 0.01, 0.01),
        robot_goal=(30.0, 10.0),
        singles=(walker("p", (10.0, 16.0), (10.0, 2.0), speed=1.0),),
    )
    return scenario(m, name="crossing", max_episode_steps=150, **sim_cfg)


def _walk(scen, seed: int = 0) -> tuple[np.ndarray, str, int]:
    """(pedestrian positions per step, outcome, steps) with the robot commanded to stand still."""
    sim = Simulator()
    sim.reset(scen, seed)
    events = None
    while not sim.done:
        _, events = sim.step((0.0, 0.0))
    return sim.trace.ped_pos[:, 0].copy(), events.outcome, sim.trace.steps


def test_nonreactive_pedestrian_walks_through_the_robot_as_if_it_were_not_there():
    blind, outcome, steps = _walk(_crossing(nonreactive_fraction=1.0))
    assert outcome == "collision_pedestrian"
    ghost, _, _ = _walk(_crossing(peds_have_robot_repulsion=False))
    assert np.array_equal(blind, ghost[: len(blind)])  # exactly the path of a crowd without robot forces
    d = np.hypot(*(blind - ROBOT).T)
    assert d[-1] <= 1.4 and d[-2] > 1.4  # detected at the first step within r_robot + r_ped
    # a reacting pedestrian feels the robot within 3.35 m and its path departs from the blind one there
    seeing, _, _ = _walk(_crossing())
    n = min(len(seeing), len(blind))
    differs = np.nonzero(np.any(seeing[:n] != blind[:n], axis=1))[0]
    assert len(differs) and d[differs[0] - 1] <= 3.35 + 1.3 * 0.1
    assert (
        np.hypot(*(seeing[len(blind) - 1] - ROBOT)) > 1.4
    )  # it has not reached the robot where the blind one did


def test_late_pedestrian_reacts_only_within_its_distance():
    late, _, _ = _walk(_crossing(late_reaction_fraction=1.0, late_reaction_distance=2.0))
    blind, _, _ = _walk(_crossing(nonreactive_fraction=1.0))
    n = min(len(late), len(blind))
    d = np.hypot(*(blind[:n] - ROBOT).T)
    first = np.nonzero(np.any(late[:n] != blind[:n], axis=1))[0][0]
    assert d[first - 1] <= 2.0 < d[first - 2]  # the force acts on the state of the step before


def test_shares_are_exact_own_draws_and_deterministic():
    base = scenario(street_map(), ped_density=0.3)
    sim = Simulator()
    sim.reset(base, 7)
    pos, n = sim.crowd.pos.copy(), len(sim.crowd.pos)
    assert sim.trace.meta["n_nonreactive"] == 0 and sim.dynamics.robot_reach is None
    for share in (0.3, 1.0):
        scen = scenario(street_map(), ped_density=0.3, nonreactive_fraction=share, late_reaction_fraction=0.5)
        sim.reset(scen, 7)
        reach = sim.dynamics.robot_reach
        k = int(np.floor(share * n + 0.5))
        assert sim.trace.meta["n_nonreactive"] == k == int((reach == 0).sum())
        assert np.array_equal(sim.crowd.pos, pos)  # the same crowd: the shares use a generator of their own
    sim.reset(
        scenario(street_map(), ped_density=0.3, nonreactive_fraction=0.3, late_reaction_fraction=0.5), 7
    )
    reach = sim.dynamics.robot_reach.copy()
    k_non = int(np.floor(0.3 * n + 0.5))
    assert (reach == 0).sum() == k_non and (reach == 2.0).sum() == int(np.floor(0.5 * (n - k_non) + 0.5))
    sim.reset(
        scenario(street_map(), ped_density=0.3, nonreactive_fraction=0.3, late_reaction_fraction=0.5), 7
    )
    assert np.array_equal(sim.dynamics.robot_reach, reach)
