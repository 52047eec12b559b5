"""The route potential's distance around walls: exact in the open, the way round behind a wall."""

from __future__ import annotations

import math

import numpy as np
import pytest

from foresight.core.errors import ConfigError
from foresight.core.planners.predictive.config import PredictivePlannerConfig
from foresight.core.planners.predictive.cost import RoutePotential
from foresight.core.planners.predictive.geodesic import GeodesicDistance
from foresight.core.planners.predictive.planner import PredictivePlanner
from foresight.core.predict.forecaster import ConstantVelocityForecaster
from foresight.core.predict.timebase import PLANNER_TIMEBASE
from foresight.core.sim.geometry import StaticMap
from tests.unit.planners.scenes import corridor_map, info_for, observation

#: a wall across the map at x = 14..16 with a door at y = 14..18 (4 m: a 2 m robot fits with 1 m to spare)
WALL = (
    ((14.0, 0.0), (16.0, 0.0), (16.0, 14.0), (14.0, 14.0)),
    ((14.0, 18.0), (16.0, 18.0), (16.0, 20.0), (14.0, 20.0)),
)
TARGET = np.array([22.0, 10.0])
CLEAR = 1.05  # robot radius + static margin


def _door_map():
    return corridor_map(obstacles=WALL)


def _way_round(p: np.ndarray) -> float:
    """Shortest path from p (left of the wall, below the door) to TARGET for a disc of CLEAR: via both door corners."""
    a, b = np.array([14.0 - CLEAR * 0.0, 14.0 + CLEAR]), np.array([16.0, 14.0 + CLEAR])
    return float(np.hypot(*(p - a)) + np.hypot(*(b - a)) + np.hypot(*(TARGET - b)))


def test_in_the_open_it_is_the_straight_line():
    g = GeodesicDistance(StaticMap(corridor_map()), TARGET, CLEAR, 0.2)
    pts = np.random.default_rng(0).uniform([2, 2], [28, 18], size=(200, 2))
    pts = pts[np.hypot(*(pts - TARGET).T) > 1.0]  # nearer, the grid's node beside the target shows
    assert g(pts) == pytest.approx(np.hypot(*(pts - TARGET).T), abs=1e-9)


def test_behind_a_wall_it_is_the_way_round_through_the_door():
    g = GeodesicDistance(StaticMap(_door_map()), TARGET, CLEAR, 0.2)
    p = np.array([10.0, 10.0])
    straight = float(np.hypot(*(p - TARGET)))
    assert g(p) > straight + 1.0  # the straight line goes through the wall
    # within the grid's resolution and worst-case excess of the true way round (an upper bound on a shorter path)
    assert g(p) == pytest.approx(_way_round(p), rel=0.04)


def test_a_robot_beside_the_door_gains_by_moving_to_the_door_not_into_the_wall():
    """The local minimum the straight line has behind a wall is gone."""
    g = GeodesicDistance(StaticMap(_door_map()), TARGET, CLEAR, 0.2)
    here, towards_door, towards_target = (
        np.array([12.0, 10.0]),
        np.array([12.5, 12.0]),
        np.array([13.0, 10.0]),
    )
    assert g(towards_door) < g(here)
    assert np.hypot(*(towards_target - TARGET)) < np.hypot(
        *(towards_door - TARGET)
    )  # the straight line disagrees


def test_points_too_close_to_a_wall_get_finite_continuous_values():
    g = GeodesicDistance(StaticMap(_door_map()), TARGET, CLEAR, 0.2)
    xs = np.linspace(11.0, 14.5, 71)
    line = g(
        np.stack([xs, np.full_like(xs, 10.0)], axis=1)
    )  # up to the wall and into it, across its inflated band
    assert np.all(np.isfinite(line))
    assert np.max(np.abs(np.diff(line))) < 0.1  # no jumps between points 5 cm apart
    assert line[-1] > line[0]  # nearer the wall is no nearer the target: the way round is through the door


def test_route_potential_and_planner_use_it_when_asked():
    m = _door_map()
    obs = observation(m, pose=(12.0, 10.0, 0.0), velocity=(0.0, 0.0), route=(tuple(TARGET),))
    pot = RoutePotential(
        obs.route,
        switch_radius=2.0,
        goal_tolerance=2.0,
        distance=lambda w: GeodesicDistance(obs.static, w, CLEAR, 0.2),
    )
    assert pot.start(obs.robot_pose[:2]) == pytest.approx(
        float(GeodesicDistance(obs.static, TARGET, CLEAR, 0.2)(obs.robot_pose[:2]))
    )
    planner = PredictivePlanner(
        None, ConstantVelocityForecaster(PLANNER_TIMEBASE)
    )  # the default: around the walls
    planner.reset(info_for(m))
    planner.plan(obs)
    cfg = PredictivePlannerConfig.from_dict({"search": {"geodesic_resolution": 0.0}})
    straight = PredictivePlanner(cfg, ConstantVelocityForecaster(PLANNER_TIMEBASE))
    straight.reset(info_for(m))
    straight.plan(obs)
    # measured round the wall, the robot has further to go than in a straight line
    assert (
        planner._route(obs).start(obs.robot_pose[:2]) > straight._route(obs).start(obs.robot_pose[:2]) + 1.0
    )
    assert math.isclose(
        straight._route(obs).start(obs.robot_pose[:2]), float(np.hypot(*(obs.robot_pose[:2] - TARGET)))
    )


def test_a_walled_off_target_falls_back_to_the_straight_line():
    """No way round (a wall across the whole map): the straight line is all there is to measure, not a flat field."""
    full = corridor_map(obstacles=(((14.0, 0.0), (16.0, 0.0), (16.0, 20.0), (14.0, 20.0)),))
    g = GeodesicDistance(StaticMap(full), TARGET, CLEAR, 0.2)
    pts = np.array([[5.0, 10.0], [10.0, 10.0], [12.0, 4.0]])
    assert g(pts) == pytest.approx(np.hypot(*(pts - TARGET).T))


@pytest.mark.parametrize("resolution", [0.001, 0.04])
def test_a_grid_finer_than_the_bound_is_a_config_error_naming_the_field(resolution):
    with pytest.raises(ConfigError) as exc:
        PredictivePlannerConfig.from_dict({"search": {"geodesic_resolution": resolution}})
    assert exc.value.item == "search" and "geodesic_resolution" in str(exc.value)
    assert (
        PredictivePlannerConfig.from_dict({"search": {"geodesic_resolution": 0.0}}).search.geodesic_resolution
        == 0
    )
