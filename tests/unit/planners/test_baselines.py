"""ORCA and social-force baselines, and the planner registry."""

from __future__ import annotations

import numpy as np
import pytest

from foresight.core.errors import ConfigError, NotFoundError
from foresight.core.planners.orca import OrcaPlanner
from foresight.core.planners.registry import make_planner
from foresight.core.planners.social_force import SocialForcePlanner, velocity_to_unicycle
from foresight.core.sim.planner import Planner
from tests.unit.planners.scenes import corridor_map, info_for, observation

WALL = ((9.0, 8.0), (10.0, 8.0), (10.0, 12.0), (9.0, 12.0))  # a pillar on the route, 4 m ahead


@pytest.mark.parametrize("cls", [OrcaPlanner, SocialForcePlanner])
def test_baseline_returns_valid_commands(cls):
    m = corridor_map(obstacles=(WALL,))
    p = cls()
    assert isinstance(p, Planner)
    p.reset(info_for(m))
    for obs in (
        observation(m),
        observation(m, peds=[(7.5, 10.2)], ped_vels=[(-0.6, 0.0)]),
        observation(m, pose=(7.6, 10.0, 0.0), velocity=(0.5, 0.0)),
    ):
        v, w = p.plan(obs)
        assert np.isfinite(v) and np.isfinite(w)
        assert 0.0 <= v <= 2.0 and -1.0 <= w <= 1.0
        assert p.diagnostics["command"] == (v, w)


def test_orca_slows_for_a_pedestrian_head_on():
    m = corridor_map()
    p = OrcaPlanner()
    p.reset(info_for(m))
    v_free, _ = p.plan(observation(m, velocity=(2.0, 0.0)))
    v_ped, w_ped = p.plan(observation(m, velocity=(2.0, 0.0), peds=[(8.0, 10.0)], ped_vels=[(-0.6, 0.0)]))
    assert v_free == pytest.approx(2.0, abs=0.05)
    assert v_ped < v_free or abs(w_ped) > 0.1


def test_orca_respects_static_obstacles():
    """Driving straight at the pillar 0.6 m away, ORCA's velocity must not point into it."""
    m = corridor_map(obstacles=(WALL,))
    p = OrcaPlanner()
    p.reset(info_for(m))
    p.plan(observation(m, pose=(7.4, 10.0, 0.0), velocity=(1.0, 0.0)))
    u = np.asarray(p.diagnostics["orca_velocity"])
    assert u[0] < 0.8


def test_social_force_is_pushed_by_a_pedestrian():
    m = corridor_map()
    p = SocialForcePlanner()
    p.reset(info_for(m))
    p.plan(observation(m, peds=[(7.5, 9.5)]))
    assert p.diagnostics["force_peds"][1] > 0  # pushed away (+y) from a pedestrian below the path


def test_velocity_to_unicycle_turns_in_place_for_a_velocity_behind():
    assert velocity_to_unicycle(np.array([-1.0, 0.0]), 0.0, 2.0, 1.0) == (0.0, 1.0)
    v, w = velocity_to_unicycle(np.array([1.0, 0.0]), 0.0, 2.0, 1.0)
    assert v == pytest.approx(1.0) and w == pytest.approx(0.0)


def test_registry():
    assert make_planner("predictive", {"weights": {"goal": 3.0}}, model="cv").config.weights.goal == 3.0
    assert isinstance(make_planner("orca"), OrcaPlanner)
    assert isinstance(make_planner("social_force", {"speed_ratio": 0.5}), SocialForcePlanner)
    with pytest.raises(NotFoundError):
        make_planner("dwa")
    with pytest.raises(ConfigError):
        make_planner("predictive", None)  # the model must be explicit: never a silent constant velocity
    with pytest.raises(ConfigError):
        make_planner("orca", {"time_horizonn": 2.0})


def test_registry_builds_the_goal_seeking_robot():
    p = make_planner("goal", {"speed": 0.8})
    assert p.name == "goal" and p.config.speed == 0.8
    with pytest.raises(ConfigError):
        make_planner("goal", {"sped": 0.8})


def test_orca_is_deterministic_across_decisions_and_pedestrian_counts():
    """Same observations, same commands: no state leaks between decisions (pyrvo's clear_agents did)."""
    m = corridor_map(obstacles=(WALL,))
    rng = np.random.default_rng(3)
    seq = [
        observation(
            m,
            pose=(5.0 + 0.1 * k, 10.0, 0.0),
            peds=rng.uniform([6, 8], [14, 12], size=(n, 2)),
            ped_vels=rng.normal(0, 0.5, size=(n, 2)),
        )
        for k, n in enumerate([3, 3, 5, 5, 2, 4])
    ]

    def run():
        p = OrcaPlanner()
        p.reset(info_for(m))
        return [p.plan(o) for o in seq]

    assert run() == run()
