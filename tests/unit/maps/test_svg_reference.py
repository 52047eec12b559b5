"""The reference's SVG maps: golden counts from its registry and the classic map facts (reference-simulation.md 5.5)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import yaml

from foresight.core.maps.svg import read_svg

CLASSIC = [
    "classic_bottleneck",
    "classic_bottleneck_medium",
    "classic_bottleneck_high",
    "classic_crossing",
    "classic_doorway",
    "classic_group_crossing",
    "classic_head_on_corridor",
    "classic_merging",
    "classic_overtaking",
    "classic_realworld_bottleneck",
    "classic_station_platform",
    "classic_t_intersection",
    "classic_urban_crossing",
]
ALL_SVGS = [*CLASSIC, "issue_5303_classic_group_crossing_medium_v2"]
#: Registry rows whose SVG is among the copied files (classic_cross_trap reads classic_crossing.svg).
REGISTRY_IDS = [*ALL_SVGS, "classic_cross_trap"]

BOTTLENECK = (
    (40, 40),
    (17.9, 29.45, 4, 4),
    (18.02, 5.87, 4, 4),
    [(20, 29.2), (20, 21.5), (20, 10.7)],
    [14.71],
)
#: svg -> ((W, H), robot spawn rect, robot goal rect, robot route points or their count, ped route lengths [m], single ped ids)
FACTS = {
    "classic_bottleneck": (*BOTTLENECK, []),
    "classic_bottleneck_medium": (*BOTTLENECK, ["h1"]),
    "classic_bottleneck_high": (*BOTTLENECK, ["h1", "h2", "h3"]),
    "classic_crossing": ((40, 40), (4, 4, 4, 4), (32, 32, 4, 4), [(10.7, 21.1), (18.9, 29.5)], [49.78], []),
    "classic_doorway": (
        (44, 28),
        (26.9, 13.64, 4, 4),
        (14.44, 9.41, 4, 4),
        [(26.5, 15.4), (18.7, 12.5)],
        [35.78],
        [],
    ),
    "classic_group_crossing": (
        (40, 40),
        (8.91, 17.96, 4, 4),
        (27.63, 18.21, 4, 4),
        [(15.0, 20.1), (26.8, 20.3)],
        [9.40],
        [],
    ),
    "classic_head_on_corridor": (
        (32, 40),
        (12.32, 2.82, 4, 4),
        (17.11, 33.04, 4, 4),
        [(14.3, 8.3), (19.2, 31.8)],
        [23.95],
        [],
    ),
    "classic_merging": ((44, 40), (6, 6, 4, 4), (34, 32, 4, 4), 8, [56.12], []),
    "classic_overtaking": ((60, 27.69), (14.4, 3.61, 4.62, 4.62), (40.84, 21.29, 4.62, 4.62), 4, [39.52], []),
    "classic_realworld_bottleneck": (
        (60, 30),
        (4, 13.5, 3, 3),
        (53, 13.5, 3, 3),
        6,
        [46, 46],
        ["l1", "l2", "l3", "l4", "r1", "r2", "r3", "r4"],
    ),
    "classic_station_platform": (
        (84, 28),
        (2, 3, 4, 3),
        (77, 21, 4, 3),
        9,
        [72, 72],
        ["p1", "p2", "p3", "p4"],
    ),
    "classic_t_intersection": ((44, 40), (20.61, 31.84, 4, 4), (34.89, 16.78, 4, 4), 3, [18.42], []),
    "classic_urban_crossing": ((50, 50), (7, 23, 4, 4), (39, 23, 4, 4), [(11, 25), (39, 25)], [28.0], []),
}


@pytest.fixture(scope="module")
def svg_dir(reference_dir: Path) -> Path:
    return reference_dir / "maps" / "svg_maps"


@pytest.fixture(scope="module")
def registry_rows(reference_dir: Path) -> dict[str, dict]:
    doc = yaml.safe_load((reference_dir / "maps" / "registry.yaml").read_text())
    return {row["map_id"]: row for row in doc["maps"]}


def as_rect(zone) -> tuple[float, float, float, float]:
    (ax, ay), (bx, _), (_, cy) = zone.corners
    return (ax, ay, bx - ax, cy - ay)


def test_copied_svgs_are_the_expected_ones(svg_dir: Path, registry_rows):
    assert set(ALL_SVGS) <= {p.stem for p in svg_dir.glob("*.svg")}
    copied = {mid for mid, row in registry_rows.items() if (svg_dir.parent / row["path"]).is_file()}
    assert set(REGISTRY_IDS) <= copied


@pytest.mark.parametrize("name", ALL_SVGS)
def test_every_reference_svg_parses_cleanly(svg_dir: Path, name: str):
    result = read_svg(svg_dir / f"{name}.svg")
    assert result.map.name == name
    assert result.map.robot_routes and result.map.robot_spawn_zones and result.map.robot_goal_zones
    assert result.report.warnings == []


@pytest.mark.parametrize("map_id", REGISTRY_IDS)
def test_parser_metadata_matches_registry(svg_dir: Path, registry_rows, map_id: str):
    row = registry_rows[map_id]
    expected = {k: v for k, v in row["parser_metadata"].items() if k != "schema_version"}
    result = read_svg(svg_dir.parent / row["path"])
    got = result.report.parser_metadata()
    assert set(got) == set(expected)
    assert got == expected
    m = result.map  # the counts are also what the map holds
    assert len(m.obstacles) == expected["obstacle_count"]
    assert len(m.robot_routes) == expected["robot_routes"] and len(m.ped_routes) == expected["ped_routes"]
    assert (
        len(m.ped_spawn_zones) == expected["parsed_ped_spawn_zones"] + expected["synthetic_ped_spawn_zones"]
    )
    assert (
        len(m.robot_goal_zones)
        == expected["parsed_robot_goal_zones"] + expected["synthetic_robot_goal_zones"]
    )
    assert len(m.single_pedestrians) == expected["single_pedestrian_definitions"]


@pytest.mark.parametrize("name", CLASSIC)
def test_classic_map_facts(svg_dir: Path, name: str):
    size, spawn, goal, route, ped_lengths, singles = FACTS[name]
    m = read_svg(svg_dir / f"{name}.svg").map
    assert (m.width, m.height) == pytest.approx(size)
    assert as_rect(m.robot_spawn_zones[0]) == pytest.approx(spawn, abs=0.0051)
    assert as_rect(m.robot_goal_zones[0]) == pytest.approx(goal, abs=0.0051)
    (robot_route,) = m.robot_routes
    if isinstance(route, int):
        assert len(robot_route.waypoints) == route
    else:
        assert [pytest.approx(p, abs=0.051) for p in route] == list(robot_route.waypoints)
    assert [r.length for r in m.ped_routes] == [pytest.approx(v, abs=0.0051) for v in ped_lengths]
    assert [p.id for p in m.single_pedestrians] == singles


def test_realworld_bottleneck_route_runs_along_y15(svg_dir: Path):
    m = read_svg(svg_dir / "classic_realworld_bottleneck.svg").map
    assert {y for _, y in m.robot_routes[0].waypoints} == {15.0}
    assert [(r.spawn_id, r.goal_id) for r in m.ped_routes] == [(0, 0), (1, 1)]
    assert m.ped_spawn_zones[1].corners[0] == (53.0, 11.0)  # ped_spawn_zone_1 placed by its index


def test_cross_trap_is_route_only_with_plus_obstacle(svg_dir: Path):
    m = read_svg(svg_dir / "classic_crossing.svg").map
    (spawn,), (goal,) = m.ped_spawn_zones, m.ped_goal_zones
    x, y = m.ped_routes[0].waypoints[0]
    assert (x, y) == pytest.approx((3.1, 2.7), abs=0.05)
    assert spawn.corners == ((x, y), (x + 1.0, y), (x + 1.0, y + 1.0))  # 1 m route-only triangle
    assert goal.corners[0] == m.ped_routes[0].waypoints[-1]
    boxes = {
        (min(p[0] for p in o), min(p[1] for p in o), max(p[0] for p in o), max(p[1] for p in o))
        for o in m.obstacles
    }
    assert {(19, 12, 21, 28), (12, 19, 28, 21)} <= boxes


def test_doorway_gap(svg_dir: Path):
    m = read_svg(svg_dir / "classic_doorway.svg").map
    walls = sorted((o for o in m.obstacles if o[0][0] == 21 and o[1][0] == 23), key=lambda o: o[0][1])
    assert len(walls) == 2
    assert walls[0][2][1] == pytest.approx(12.24, abs=0.005)  # upper wall ends at the opening
    assert walls[1][0][1] == pytest.approx(15.54, abs=0.005)


def test_urban_crossing_ped_route_is_route_only_at_x25(svg_dir: Path):
    result = read_svg(svg_dir / "classic_urban_crossing.svg")
    (route,) = result.map.ped_routes
    assert {x for x, _ in route.waypoints} == {25.0}
    assert result.report.ped_route_only_mode
    assert result.map.pois == {}


@pytest.mark.parametrize(
    "name", ["classic_bottleneck", "classic_bottleneck_medium", "classic_bottleneck_high"]
)
def test_transform_option_moves_bottleneck_pedestrians(svg_dir: Path, name: str):
    raw = read_svg(svg_dir / f"{name}.svg").map
    drawn = read_svg(svg_dir / f"{name}.svg", apply_transforms=True).map
    for a, b in zip(raw.ped_routes[0].waypoints, drawn.ped_routes[0].waypoints, strict=True):
        assert (b[0] - a[0], b[1] - a[1]) == pytest.approx((0, -4.365), abs=5e-4)
    for kind in ("ped_spawn_zones", "ped_goal_zones"):
        (za,), (zb,) = getattr(raw, kind), getattr(drawn, kind)
        assert zb.centre[1] - za.centre[1] == pytest.approx(-4.3651647)
    assert drawn.robot_routes == raw.robot_routes and drawn.obstacles == raw.obstacles
    assert drawn.single_pedestrians == raw.single_pedestrians  # their group has no transform


def test_transform_option_moves_t_intersection_routes(svg_dir: Path):
    raw = read_svg(svg_dir / "classic_t_intersection.svg").map
    drawn = read_svg(svg_dir / "classic_t_intersection.svg", apply_transforms=True).map
    for kind in ("robot_routes", "ped_routes"):
        a, b = getattr(raw, kind)[0].waypoints[0], getattr(drawn, kind)[0].waypoints[0]
        assert math.dist(a, b) == pytest.approx(math.hypot(0.36645698, 0.15705299))
        assert (b[0] - a[0], b[1] - a[1]) == pytest.approx((0.366, -0.157), abs=5e-4)
    assert drawn.robot_spawn_zones == raw.robot_spawn_zones


@pytest.mark.parametrize("name", [n for n in ALL_SVGS if "bottleneck" not in n and "t_intersection" not in n])
def test_transform_option_changes_nothing_elsewhere(svg_dir: Path, name: str):
    raw = read_svg(svg_dir / f"{name}.svg").map
    assert read_svg(svg_dir / f"{name}.svg", apply_transforms=True).map == raw
