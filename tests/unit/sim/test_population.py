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

from .scenes import open_map, scenario, street_map


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


class _Stop(Exception):
    pass


def test_a_crowd_over_the_limit_is_refused_before_anything_spawns():
    import pytest

    from foresight.core.errors import ConfigError
    from foresight.core.sim.population import MAX_PEDESTRIANS

    m = street_map()
    calls = []
    n = sum(population_counts(m, SimulationConfig(ped_density=2.0), CrowdParams()))
    assert n < MAX_PEDESTRIANS  # a street is no bomb: its routes made 10^6 m long are
    from foresight.core.maps.model import Route

    routes = tuple(
        Route(spawn_id=r.spawn_id, goal_id=r.goal_id, waypoints=(*r.waypoints, (3, 1e6)))
        for r in m.ped_routes
    )
    far = m.model_copy(update={"ped_routes": routes})
    with pytest.raises(ConfigError, match=r"pedestrians .* at most 5000: lower ped_density"):
        Simulator().reset(scenario(far, ped_density=2.0), 1, check=lambda: calls.append(1))
    assert calls == []  # refused from the areas and lengths alone
    with pytest.raises(ConfigError, match="MiB trace"):  # horizon x crowd over the trace limit
        Simulator().reset(scenario(m, population_size=4000), 1, max_steps=100_000)


def test_cancellation_is_checked_while_the_crowd_spawns():
    import pytest

    calls = []

    def check() -> None:
        calls.append(1)
        if len(calls) == 3:
            raise _Stop

    big = open_map(width=100, height=100, crowded=(Zone.from_rect(10, 10, 80, 80),))
    with pytest.raises(_Stop):
        Simulator().reset(scenario(big, population_size=3000, max_peds_per_group=1), 1, check=check)
    assert len(calls) == 3  # stopped mid-spawn: 3000 groups would have called it 47 times
