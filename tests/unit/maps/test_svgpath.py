"""Path ``d`` parser: every command, absolute and relative, on hand-written data with known answers."""

from __future__ import annotations

import math

import pytest

from foresight.core.maps.svgpath import PathDataError, parse_path, path_commands, segment_count


def approx_pts(points):
    return [pytest.approx(p, abs=1e-9) for p in points]


def shifted(points, dx, dy):
    return [(x + dx, y + dy) for x, y in points]


@pytest.mark.parametrize(
    ("d", "expected"),
    [
        ("M 1 2 L 3 4", [(1, 2), (3, 4)]),
        ("m 1 2 l 3 4", [(1, 2), (4, 6)]),
        ("M 0,0 1,1 2,0", [(0, 0), (1, 1), (2, 0)]),  # implicit lineto after M
        ("m 1 1 2 0 0 2", [(1, 1), (3, 1), (3, 3)]),  # implicit relative lineto after m
        ("M 0 0 H 5 V 3 h -2 v 1", [(0, 0), (5, 0), (5, 3), (3, 3), (3, 4)]),
        ("M 0 0 H 1 2 3", [(0, 0), (1, 0), (2, 0), (3, 0)]),  # repeated parameters
        ("M 0 0 L 4 0 L 4 3 Z", [(0, 0), (4, 0), (4, 3), (0, 0)]),
        (
            "M0 0L4 0L4 3z m 1 1 l 1 0",
            [(0, 0), (4, 0), (4, 3), (0, 0), (1, 1), (2, 1)],
        ),  # after z: from start
        ("M1e1-2L.5.5", [(10, -2), (0.5, 0.5)]),  # exponents, glued signs and decimals
        ("M 0 0 L 0 0 L 1 1 L 1 1", [(0, 0), (1, 1)]),  # duplicates dropped
        ("", []),
    ],
)
def test_lines(d, expected):
    assert parse_path(d) == approx_pts(expected)


def test_cubic_absolute_and_relative():
    pts = parse_path("M 0 0 C 0 3 3 3 3 0")
    assert len(pts) == 13  # control polygon 9 m -> ceil(9 / 0.75) = 12 segments
    assert pts[6] == pytest.approx((1.5, 2.25))
    assert pts[-1] == pytest.approx((3, 0))
    assert parse_path("M 1 1 c 0 3 3 3 3 0") == approx_pts(shifted(pts, 1, 1))


def test_smooth_cubic_reflects_previous_control():
    pts = parse_path("M 0 0 C 0 1 1 1 1 0 S 2 -1 2 0")
    assert len(pts) == 9  # 4 + 4 segments (control polygons of 3 m each)
    assert pts[6] == pytest.approx((1.5, -0.75))  # reflected control (1, -1)
    assert parse_path("M 0 0 c 0 1 1 1 1 0 s 1 -1 1 0") == approx_pts(pts)


def test_smooth_cubic_without_previous_curve_uses_current_point():
    pts = parse_path("M 0 0 S 3 3 3 0")  # equals C 0 0 3 3 3 0
    assert pts == approx_pts(parse_path("M 0 0 C 0 0 3 3 3 0"))


def test_quadratic_and_smooth_quadratic():
    pts = parse_path("M 0 0 Q 1 2 2 0")
    assert len(pts) == 7  # 2 * sqrt(5) = 4.47 m -> 6 segments
    assert pts[3] == pytest.approx((1, 1))
    both = parse_path("M 0 0 Q 1 2 2 0 T 4 0")
    assert both[len(pts) - 1 + 3] == pytest.approx((3, -1))  # reflected control (3, -2)
    assert parse_path("M 0 0 q 1 2 2 0 t 2 0") == approx_pts(both)


def test_arc_semicircle_sweep_direction():
    up = parse_path("M 0 0 A 1 1 0 0 1 2 0")
    down = parse_path("M 0 0 A 1 1 0 0 0 2 0")
    assert len(up) == 6  # arc length pi -> ceil(pi / 0.75) = 5 segments
    assert up[-1] == (2.0, 0.0)
    for pts, sign in ((up, -1), (down, 1)):
        assert all(math.dist(p, (1, 0)) == pytest.approx(1) for p in pts)
        assert all(sign * p[1] >= -1e-12 for p in pts)
    assert parse_path("M 1 1 a 1 1 0 0 1 2 0") == approx_pts(shifted(up, 1, 1))


def test_arc_large_flag_and_radius_scaling():
    large = parse_path("M 0 0 A 2 2 0 1 1 2 0")
    centre = (1, -math.sqrt(3))
    assert all(math.dist(p, centre) == pytest.approx(2) for p in large)
    assert max(abs(p[1]) for p in large) > 3.5  # goes round the far side (apex at 3.73 m)
    scaled = parse_path("M 0 0 A 0.5 0.5 0 0 1 4 0")  # radii too small: scaled up to 2
    assert all(math.dist(p, (2, 0)) == pytest.approx(2) for p in scaled)


def test_arc_rotated_ellipse():
    pts = parse_path("M 0 0 A 2 1 90 0 1 0 4")  # major axis (2 m) turned vertical, centre (0, 2)
    assert len(pts) > 3
    assert all(p[0] ** 2 + ((p[1] - 2) / 2) ** 2 == pytest.approx(1) for p in pts)


def test_arc_degenerate_cases_and_glued_flags():
    assert parse_path("M 0 0 A 0 1 0 0 1 2 0") == [(0, 0), (2, 0)]  # zero radius: straight line
    assert parse_path("M 0 0 A 1 1 0 0 1 0 0") == [(0, 0)]  # same end point: nothing drawn
    assert parse_path("M0 0a1 1 0 012 0") == approx_pts(parse_path("M 0 0 a 1 1 0 0 1 2 0"))


def test_segment_count_is_clamped():
    assert segment_count(0.0) == 2
    assert segment_count(0.3) == 2
    assert segment_count(7.6) == 11
    assert segment_count(1000.0) == 256
    assert len(parse_path("M 0 0 C 0 0.1 0.1 0.1 0.1 0")) == 3
    assert len(parse_path("M 0 0 C 0 500 500 500 500 0")) == 257


@pytest.mark.parametrize(
    "d", ["M 0", "X 1 2", "1 2 L 3 4", "M 0 0 A 1 1 0 2 1 3 3", "M 0 0 L 1 1 #", "M 0 0 A 1 1 0 1e3 1 2 0"]
)
def test_malformed_data_raises(d):
    with pytest.raises(PathDataError):
        parse_path(d)


def test_path_commands_keeps_case():
    assert path_commands("M 0 0 h 1 V 2 z") == {"M", "h", "V", "z"}
