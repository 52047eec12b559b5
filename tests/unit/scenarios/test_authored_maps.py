"""Our matrix (configs/scenarios/classic_interactions.yaml) and the maps we authored for it: complete,
current in the registry, and solvable (robot zones and route clear of obstacles, pedestrian flows
across or along the robot's route)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from foresight.core.maps.geometry import point_strictly_inside
from foresight.core.maps.io import file_sha256, load_map
from foresight.core.maps.model import MapDef, Zone
from foresight.core.scenarios.loader import load_matrix
from foresight.core.scenarios.model import ScenarioMatrix

REPO = Path(__file__).resolve().parents[3]
MAPS = REPO / "configs" / "maps"
MATRIX = REPO / "configs" / "scenarios" / "classic_interactions.yaml"
ARCHETYPES = [
    "crossing",
    "cross_trap",
    "head_on_corridor",
    "overtaking",
    "bottleneck",
    "doorway",
    "merging",
    "t_intersection",
    "group_crossing",
    "station_platform",
    "urban_crossing",
]
DENSITIES = {"low": 0.02, "medium": 0.05, "high": 0.08}
ROBOT_ZONE_CLEARANCE = 1.5  #: robot radius 1.0 plus margin [m]
ROBOT_ROUTE_CLEARANCE = 2.5  #: along the whole route [m]
PED_CLEARANCE = 0.5  #: ped radius 0.4 plus margin [m]
SIDEWALK_WIDTH = 3.0  #: reference spawnable width of a route [m]
MAP_FILES = sorted(p for p in MAPS.glob("*.yaml") if p.name != "registry.yaml")


@pytest.fixture(scope="module")
def matrix() -> ScenarioMatrix:
    return load_matrix(MATRIX)


def _sample_polyline(points: np.ndarray, step: float = 0.1) -> np.ndarray:
    pieces = [
        a + np.linspace(0.0, 1.0, max(2, math.ceil(np.linalg.norm(b - a) / step)))[:, None] * (b - a)
        for a, b in zip(points[:-1], points[1:], strict=True)
    ]
    return np.vstack(pieces)


def _sample_zone(zone: Zone, n: int = 9) -> np.ndarray:
    a, b, c = (np.asarray(p, dtype=float) for p in zone.corners)
    u, v = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    return b + u.reshape(-1, 1) * (a - b) + v.reshape(-1, 1) * (c - b)


def _obstacle_clearance(m: MapDef, pts: np.ndarray) -> np.ndarray:
    """Distance [m] from each point to the nearest obstacle edge, negative inside an obstacle."""
    s = m.obstacle_segments
    if len(s) == 0:
        return np.full(len(pts), np.inf)
    a, d = s[:, :2], s[:, 2:] - s[:, :2]
    t = np.clip(np.einsum("psk,sk->ps", pts[:, None] - a[None], d) / np.einsum("sk,sk->s", d, d), 0, 1)
    dist = np.linalg.norm(pts[:, None] - (a[None] + t[..., None] * d[None]), axis=2).min(axis=1)
    inside = np.array([any(point_strictly_inside(tuple(p), poly) for poly in m.obstacles) for p in pts])
    return np.where(inside, -dist, dist)


def _bound_clearance(m: MapDef, pts: np.ndarray) -> np.ndarray:
    return np.minimum.reduce([pts[:, 0], pts[:, 1], m.width - pts[:, 0], m.height - pts[:, 1]])


def test_matrix_has_every_archetype_at_three_densities(matrix: ScenarioMatrix) -> None:
    assert matrix.names == [f"{a}_{d}" for a in ARCHETYPES for d in DENSITIES]
    for s in matrix.scenarios:
        sc = s.scenario
        assert sc.archetype == sc.metadata["archetype"] == sc.map_id == s.map.name
        assert sc.simulation_config.ped_density == DENSITIES[sc.metadata["density"]]
        assert 500 <= sc.simulation_config.max_episode_steps <= 700
        assert sc.metadata["flow"] in {"bi", "uni", "crossing", "converging"}
        assert len(sc.seeds) >= 10 and len(set(sc.seeds)) == len(sc.seeds)


def test_seed_ranges_are_distinct_per_archetype(matrix: ScenarioMatrix) -> None:
    by_archetype: dict[str, set[int]] = {}
    for s in matrix.scenarios:
        by_archetype.setdefault(s.scenario.archetype, set()).update(s.scenario.seeds)
    seen: set[int] = set()
    for seeds in by_archetype.values():
        assert not seeds & seen
        seen |= seeds


def test_registry_lists_every_map_with_current_checksums() -> None:
    rows = yaml.safe_load((MAPS / "registry.yaml").read_text())["maps"]
    assert sorted(r["path"] for r in rows) == [p.name for p in MAP_FILES]
    stale = [r["map_id"] for r in rows if file_sha256(MAPS / r["path"]) != r["source_sha256"]]
    assert stale == [], "update source_sha256 in configs/maps/registry.yaml"


@pytest.mark.parametrize("path", MAP_FILES, ids=[p.stem for p in MAP_FILES])
def test_robot_zones_and_route_are_clear(path: Path) -> None:
    m = load_map(path)
    assert m.robot_spawn_zones and m.robot_goal_zones and m.robot_routes
    zones = np.vstack([_sample_zone(z) for z in (*m.robot_spawn_zones, *m.robot_goal_zones)])
    assert _obstacle_clearance(m, zones).min() >= ROBOT_ZONE_CLEARANCE
    assert _bound_clearance(m, zones).min() >= ROBOT_ZONE_CLEARANCE
    for route in m.robot_routes:
        spawn, goal = m.robot_spawn_zones[route.spawn_id], m.robot_goal_zones[route.goal_id]
        pts = _sample_polyline(np.vstack([spawn.centre, route.array, goal.centre]))  # the whole drive
        assert _obstacle_clearance(m, pts).min() >= ROBOT_ROUTE_CLEARANCE
        assert _bound_clearance(m, pts).min() >= ROBOT_ROUTE_CLEARANCE


@pytest.mark.parametrize("path", MAP_FILES, ids=[p.stem for p in MAP_FILES])
def test_pedestrians_start_and_walk_outside_obstacles(path: Path) -> None:
    m = load_map(path)
    assert m.ped_routes
    zones = np.vstack([_sample_zone(z) for z in (*m.ped_spawn_zones, *m.ped_goal_zones)])
    assert _obstacle_clearance(m, zones).min() >= PED_CLEARANCE
    for route in m.ped_routes:
        assert _obstacle_clearance(m, _sample_polyline(route.array)).min() >= PED_CLEARANCE
    for ped in m.single_pedestrians:
        pts = np.array([ped.start, *(p for p in (ped.goal,) if p), *ped.trajectory], dtype=float)
        assert _obstacle_clearance(m, pts).min() >= PED_CLEARANCE


@pytest.mark.parametrize("path", MAP_FILES, ids=[p.stem for p in MAP_FILES])
def test_pedestrian_routes_conflict_with_the_robot_route(path: Path) -> None:
    m = load_map(path)
    robot = np.vstack([_sample_polyline(r.array) for r in m.robot_routes])
    gaps = [
        np.linalg.norm(robot[:, None] - _sample_polyline(r.array)[None], axis=2).min() for r in m.ped_routes
    ]
    assert max(gaps) <= 3.0  # every stream passes through or right beside the robot's route
    assert min(gaps) <= 1.0  # at least one on a collision course (robot + ped radius = 1.4 m)
    length = sum(r.length for r in m.ped_routes)
    assert math.ceil(length * SIDEWALK_WIDTH * DENSITIES["low"]) >= 3  # even "low" has a crowd
