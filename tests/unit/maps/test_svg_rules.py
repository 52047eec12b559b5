"""SVG importer rules on hand-written documents: labels, zone indexing, synthetic zones/routes, errors."""

from __future__ import annotations

import math

import pytest

from foresight.core.errors import ConfigError
from foresight.core.maps.svg import load_svg_map, parse_svg_text, read_svg
from foresight.core.maps.svgreport import (
    PED_ROUTE_ONLY_MODE,
    ROBOT_ROUTE_ONLY_MODE,
    ROUTE_CROSSES_OBSTACLE_INTERIOR,
    ROUTE_USES_RISKY_PATH_COMMANDS,
)

from .svgdocs import ROBOT, circle, path, rect, svg_text, write_svg


def imp(body: str, attrs: str = 'width="20" height="10"', **kw):
    return parse_svg_text(svg_text(body, attrs), name="t", source="t.svg", **kw)


def test_size_units_are_stripped_not_converted():
    m = imp(ROBOT, 'width="20mm" height="10px" viewBox="0 0 200 100"').map
    assert (m.width, m.height) == (20.0, 10.0)


def test_size_from_viewbox_and_origin_shift():
    body = rect("obstacle", 6, 7, 2, 1) + rect("robot_spawn_zone", 5, 5) + rect("robot_goal_zone", 9, 9)
    m = imp(body, 'viewBox="5 5 20 10"').map
    assert (m.width, m.height) == (20.0, 10.0)
    assert m.obstacles == (((1.0, 2.0), (3.0, 2.0), (3.0, 3.0), (1.0, 3.0)),)  # TL, TR, BR, BL
    assert m.robot_spawn_zones[0].corners == ((0.0, 0.0), (1.0, 0.0), (1.0, 1.0))


def test_missing_size_is_an_error():
    with pytest.raises(ConfigError, match="t.svg.*width/height"):
        imp(ROBOT, "")


def test_labels_fall_back_to_id_and_unknown_labels_are_ignored():
    body = (
        ROBOT
        + '<rect id="obstacle" x="3" y="3" width="1" height="1"/>'
        + '<rect id="hall_bg" x="0" y="0" width="20" height="10"/>'
        + path("decoration", "M 0 0 L 1 1")
        + '<ellipse inkscape:label="obstacle" cx="1" cy="1" rx="1" ry="1"/>'
    )
    r = imp(body)
    assert len(r.map.obstacles) == 1
    assert any("hall_bg" in s for s in r.report.ignored) and any("decoration" in s for s in r.report.ignored)


def test_zone_lists_follow_explicit_indices_then_fill_gaps():
    body = (
        ROBOT
        + "".join(
            rect(label, x, 0)
            for label, x in [
                ("ped_spawn_zone_2", 2),
                ("ped_spawn_zone", 10),
                ("ped_spawn_zone_0", 0),
                ("ped_spawn_zone", 11),
            ]
        )
        + rect("ped_goal_zone", 5, 5)
        + path("ped_route_2_0", "M 2 0 L 5 5")
    )
    m = imp(body).map
    assert [z.corners[0][0] for z in m.ped_spawn_zones] == [0, 10, 2, 11]
    assert m.ped_routes[0].spawn_id == 2


def test_zone_without_any_index_keeps_document_order():
    body = ROBOT + rect("ped_goal_zone", 3, 0) + rect("ped_goal_zone", 1, 0) + rect("ped_spawn_zone", 0, 0)
    assert [z.corners[0][0] for z in imp(body).map.ped_goal_zones] == [3, 1]


def test_route_indices_are_the_first_two_integers():
    zones = "".join(rect(f"ped_spawn_zone_{i}", i, 0) + rect(f"ped_goal_zone_{i}", i, 5) for i in range(3))
    body = ROBOT + zones + path("ped_route_2_1_7", "M 0 0 L 1 1") + path("my ped_route", "M 0 0 L 1 2")
    r1, r2 = imp(body).map.ped_routes
    assert (r1.spawn_id, r1.goal_id) == (2, 1)
    assert (r2.spawn_id, r2.goal_id) == (0, 0)


def test_route_label_with_one_integer_is_an_error():
    with pytest.raises(ConfigError, match=r"t\.svg.*ped_route_3.*one integer"):
        imp(
            ROBOT
            + rect("ped_spawn_zone", 0, 0)
            + rect("ped_goal_zone", 5, 5)
            + path("ped_route_3", "M 0 0 L 1 1")
        )


def test_route_only_mode_makes_one_metre_zones_at_route_ends():
    r = imp(ROBOT + path("ped_route_0_0", "M 2 3 L 8 3 L 8 9") + path("ped_route", "M 1 1 L 4 4"))
    m = r.map
    assert m.ped_spawn_zones[0].corners == ((2, 3), (3, 3), (3, 4))
    assert m.ped_goal_zones[0].corners == ((8, 9), (9, 9), (9, 10))
    assert [(x.spawn_id, x.goal_id) for x in m.ped_routes] == [(0, 0), (1, 1)]  # one zone pair per route
    meta = r.report.parser_metadata()
    assert (
        meta["ped_route_only_mode"]
        and meta["synthetic_ped_spawn_zones"] == 2
        and meta["parsed_ped_spawn_zones"] == 0
    )
    assert meta["parser_limitation_codes"] == [PED_ROUTE_ONLY_MODE]


def test_robot_route_only_mode():
    r = imp(path("robot_route", "M 1 1 L 9 9"))
    assert r.report.robot_route_only_mode
    assert ROBOT_ROUTE_ONLY_MODE in r.report.parser_metadata()["parser_limitation_codes"]
    assert r.map.robot_spawn_zones[0].corners == ((1, 1), (2, 1), (2, 2))


def test_out_of_range_index_gets_a_tenth_metre_zone_and_a_warning():
    body = (
        ROBOT
        + rect("ped_spawn_zone", 0, 0)
        + rect("ped_goal_zone", 5, 5)
        + path("ped_route_0_4", "M 0 0 L 6 6")
    )
    r = imp(body)
    (route,) = r.map.ped_routes
    assert route.goal_id == 1
    (x0, y0), (x1, _), _ = r.map.ped_goal_zones[1].corners
    assert (x0, y0) == (6, 6) and x1 - x0 == pytest.approx(0.1)
    assert r.report.synthetic_zones["ped_goal_zone"] == 1
    assert any("index 4 out of range" in w for w in r.report.warnings)


def test_synthetic_robot_routes_between_zone_centres():
    body = (
        rect("robot_spawn_zone", 0, 0, 3, 3)
        + rect("robot_goal_zone", 9, 0, 3, 3)
        + rect("robot_goal_zone", 0, 6, 3, 3)
    )
    r = imp(body)
    assert [(x.spawn_id, x.goal_id) for x in r.map.robot_routes] == [(0, 0), (0, 1)]
    assert r.map.robot_routes[0].waypoints == (
        (2.0, 1.0),
        (11.0, 1.0),
    )  # mean of 3 corners: (x + 2w/3, y + h/3)
    assert r.report.synthetic_robot_routes == 2


def test_obstacle_path_is_closed_ring_without_repeat():
    r = imp(ROBOT + path("obstacle", "M 3 3 h 2 v 2 h -2 z"))
    assert r.map.obstacles == (((3, 3), (5, 3), (5, 5), (3, 5)),)


def test_self_intersecting_obstacle_is_kept_with_a_warning():
    r = imp(ROBOT + path("obstacle", "M 3 3 L 5 5 L 5 3 L 3 5 Z"))
    assert r.map.obstacles == (((3, 3), (5, 5), (5, 3), (3, 5)),)
    assert any("intersects itself" in w for w in r.report.warnings)


def test_obstacle_path_with_two_points_is_an_error():
    with pytest.raises(ConfigError, match="obstacle path has 2 distinct vertices"):
        imp(ROBOT + path("obstacle", "M 3 3 L 5 5"))


def test_crowded_zones_from_rect_and_three_point_path():
    body = ROBOT + rect("ped_crowded_zone", 2, 2, 3, 1) + path("crowded_zone", "M 0 0 L 2 0 L 2 2 Z")
    body += path("crowded_zone", "M 0 0 L 2 0 L 2 2 L 0 2")
    r = imp(body)
    assert [z.corners for z in r.map.ped_crowded_zones] == [
        ((2, 2), (5, 2), (5, 3)),
        ((0, 0), (2, 0), (2, 2)),
    ]
    assert any("exactly 3 points" in w for w in r.report.warnings)


def test_semantic_boundaries_are_metadata_only():
    r = imp(ROBOT + path("semantic_boundary_kerb__vehicle_blocking__pedestrian_passable", "M 0 5 L 20 5"))
    (b,) = r.report.semantic_boundaries
    assert (b.name, b.flags) == ("kerb", ("vehicle_blocking", "pedestrian_passable"))
    assert r.map.obstacles == ()


def test_single_pedestrians_and_pois():
    body = ROBOT + circle("single_ped_a_b_start", 1, 2) + circle("single_ped_a_b_goal", 3, 4)
    body += circle("single_ped_a_b_start", 9, 9)  # duplicate: first wins
    body += circle("single_ped_lonely_goal", 5, 5)  # no start: skipped
    body += circle("single_ped_s_start", 6, 6)  # goal optional
    body += '<circle class="poi marker" id="poi_door" cx="7" cy="8" r="1"/>' + circle("poi", 2, 2, 'id="c9"')
    r = imp(body)
    assert [(p.id, p.start, p.goal) for p in r.map.single_pedestrians] == [
        ("a_b", (1, 2), (3, 4)),
        ("s", (6, 6), None),
    ]
    assert r.map.pois == {"poi_door": (7, 8), "c9": (2, 2)}
    meta = r.report.parser_metadata()
    assert (
        meta["single_ped_start_markers"],
        meta["single_ped_goal_markers"],
        meta["single_pedestrian_definitions"],
    ) == (2, 2, 2)


def test_circle_label_falls_back_to_class_then_id():
    body = (
        ROBOT
        + '<circle id="single_ped_q_start" cx="1" cy="1" r="1"/>'
        + '<circle class="single_ped_q_goal" cx="2" cy="2" r="1"/>'
    )
    (p,) = imp(body).map.single_pedestrians
    assert (p.start, p.goal) == ((1, 1), (2, 2))


def test_transforms_ignored_by_default_and_applied_on_request():
    body = (
        rect("robot_spawn_zone", 0, 0)
        + rect("robot_goal_zone", 5, 5)
        + '<g transform="translate(10,0)"><g transform="rotate(90)">'
        + path("robot_route_0_0", "M 1 0 L 2 0")
        + rect("obstacle", 0, 0, 2, 1, 'transform="scale(2)"')
        + "</g></g>"
    )
    raw, drawn = imp(body).map, imp(body, apply_transforms=True).map
    assert raw.robot_routes[0].waypoints == ((1, 0), (2, 0))
    assert list(drawn.robot_routes[0].waypoints) == [pytest.approx(p) for p in ((10, 1), (10, 2))]
    assert list(drawn.obstacles[0]) == [pytest.approx(p) for p in ((10, 0), (10, 4), (8, 4), (8, 0))]


def test_bad_transform_is_an_error_only_when_applied():
    body = ROBOT + '<g id="grp" transform="wobble(3)">' + rect("obstacle", 0, 0) + "</g>"
    assert len(imp(body).map.obstacles) == 1
    with pytest.raises(ConfigError, match="grp.*wobble"):
        imp(body, apply_transforms=True)


def test_risky_commands_and_route_through_obstacle_are_flagged():
    r = imp(ROBOT + rect("obstacle", 8, 0, 2, 10) + path("ped_route", "M 1 5 H 19"))
    codes = r.report.parser_metadata()["parser_limitation_codes"]
    assert codes == [PED_ROUTE_ONLY_MODE, ROUTE_USES_RISKY_PATH_COMMANDS, ROUTE_CROSSES_OBSTACLE_INTERIOR]


def test_route_along_obstacle_edge_is_not_flagged():
    body = ROBOT + rect("obstacle", 12, 0, 2, 5) + rect("ped_spawn_zone", 0, 0) + rect("ped_goal_zone", 1, 1)
    r = imp(body + path("ped_route_0_0", "M 1 5 L 19 5"))  # runs along the obstacle's lower edge
    assert r.report.parser_metadata()["parser_limitation_codes"] == []


def test_bound_rect_is_counted():
    r = imp(ROBOT + rect("bound", 0, 0, 5, 5))
    assert r.report.parser_metadata()["bounds_count"] == 5


@pytest.mark.parametrize(
    ("body", "pattern"),
    [
        (ROBOT + rect("obstacle", 0, 0, "x", 1), r"<rect.*width='x'"),
        (ROBOT + path("obstacle", "M 0 0 L 1"), r"obstacle.*path data"),
        (
            rect("robot_spawn_zone", 0, 0) + rect("robot_goal_zone", 5, 5) + path("robot_route_0_0", "M 1 1"),
            "route has 1 distinct",
        ),
    ],
)
def test_bad_elements_name_the_element(body, pattern):
    with pytest.raises(ConfigError, match=pattern) as info:
        imp(body)
    assert info.value.source == "t.svg" and info.value.item


def test_malformed_xml_names_the_file(tmp_path):
    p = tmp_path / "broken.svg"
    p.write_text("<svg><rect></svg>")
    with pytest.raises(ConfigError, match="broken.svg.*malformed XML") as info:
        load_svg_map(p)
    assert info.value.item == "xml"


def test_missing_file_names_the_file(tmp_path):
    with pytest.raises(ConfigError, match="nope.svg.*not found"):
        read_svg(tmp_path / "nope.svg")


def test_non_svg_root_is_an_error():
    with pytest.raises(ConfigError, match="expected <svg>"):
        parse_svg_text("<html/>", name="x", source="x.svg")


def test_written_file_reads_like_text(tmp_path):
    p = write_svg(tmp_path, ROBOT + path("ped_route", "M 0 0 A 2 2 0 0 1 4 0"))
    m = load_svg_map(p)
    assert m.name == "m" and m.source == str(p)
    assert all(math.dist(q, (2, 0)) == pytest.approx(2) for q in m.ped_routes[0].waypoints)
