"""Population size, groups, zone sampling and spawning rules."""

from __future__ import annotations

import math

import numpy as np

from foresight.core.maps.model import Zone
from foresight.core.scenarios.model import SimulationConfig
from foresight.core.sim.params import CrowdParams
from foresight.core.sim.population import group_sizes, population_counts
from foresight.core.sim.simulator import Simulator
from foresight.core.sim.zones import sample_zone

from .scenes import scenario, street_map


def test_counts_follow_density_rule():
    m = street_map()
    length = sum(r.length for r in m.ped_routes)
    n_zone, n_route = population_counts(m, SimulationConfig(ped_density=0.05), CrowdParams())
    assert n_route == math.ceil(length * 3.0 * 0.05) and n_zone == math.ceil(40 * 0.05)
    assert population_counts(m, SimulationConfig(population_size=11), CrowdParams()) == (5, 6)


def test_group_sizes_distribution_and_total():
    rng = np.random.default_rng(0)
    sizes = group_sizes(20000, 3, rng, 0.3)
    assert sum(sizes) == 20000 and max(sizes) == 3
    freq = np.bincount(sizes[:-1], minlength=4)[1:] / (len(sizes) - 1)
    assert np.allclose(freq, [0.719, 0.216, 0.065], atol=0.01)
    assert group_sizes(5, 1, rng, 0.3) == [1] * 5


def test_zone_sampling_triangle_is_the_reference_half_full_covers_all():
    z = Zone.from_rect(0, 0, 4, 2)  # corners a=(0,0), b=(4,0), c=(4,2)
    rng = np.random.default_rng(1)
    tri = sample_zone(z, 4000, rng, "triangle")
    assert np.all(tri[:, 1] <= tri[:, 0] / 2 + 1e-9)  # triangle a-b-c: below the diagonal a-c
    full = sample_zone(z, 4000, rng, "full")
    assert (full[:, 1] > full[:, 0] / 2).mean() > 0.4
    assert full[:, 0].min() >= 0 and full[:, 0].max() <= 4 and full[:, 1].max() <= 2


def test_spawns_avoid_obstacles_and_groups_share_goals():
    scen = scenario(street_map(), ped_density=0.1, max_peds_per_group=3)
    sim = Simulator()
    for seed in range(10):
        obs = sim.reset(scen, seed)
        assert not sim.static.inside_obstacle(obs.ped_positions).any()
        goal, group = sim.crowd.goal, sim.crowd.group
        for g in np.unique(group):
            assert np.all(goal[group == g] == goal[group == g][0])


def test_speed_tiers_give_per_ped_desired_speeds():
    sim = Simulator()
    sim.reset(scenario(street_map(), ped_density=0.2, ped_speed_tier="typical"), 0)
    v = sim.crowd.vmax
    assert 1.1 < v.mean() < 1.5 and v.std() > 0.05 and v.min() >= 0.1
    sim.reset(scenario(street_map(), ped_density=0.2), 0)
    assert np.all(sim.crowd.vmax == 0.65)
