"""Per-episode metrics on hand-built traces with answers computed by hand."""

from __future__ import annotations

import numpy as np
import pytest

from foresight.core.evaluation.metrics import (
    MetricsConfig,
    derive,
    efficiency,
    route_progress,
    safety,
    smoothness,
    time_to_collision,
    timing_summary,
)

from .traces import DT, geometry, make_trace, still, straight

CFG = MetricsConfig()


def test_passing_a_standing_pedestrian() -> None:
    # robot 0 -> 10 m at 1 m/s; pedestrian standing 1 m beside the path at x = 5; radii 0.3 + 0.3
    tr = make_trace(straight(0.0, 1.0, 100), [still((5.0, 1.0), 100)])
    d = derive(tr, geometry(goal=(10.0, 0.0)))
    s = safety(d, CFG)
    assert s.min_distance == pytest.approx(1.0)
    assert s.min_clearance == pytest.approx(0.4)
    assert s.near_misses == 9  # |x - 5| <= 0.4: clearance in [0, 0.5)
    assert s.intimate_intrusions == 7  # |x - 5| <= 0.3: clearance < 0.45
    assert s.min_ttc is None  # a standing pedestrian 1 m off the path is never on a collision course
    e = efficiency(d, geometry(goal=(10.0, 0.0)), CFG, success=True)
    assert e.path_length == pytest.approx(10.0)
    assert e.avg_speed == pytest.approx(1.0)
    assert e.path_efficiency == pytest.approx(1.0)
    assert e.stalled_time_s == 0.0
    assert e.no_progress_steps == 0


def test_detour_lowers_path_efficiency_and_failures_have_none() -> None:
    xy = np.array([[0.0, 0.0], [0.0, 3.0], [4.0, 3.0], [4.0, 0.0]])  # 10 m walked to a goal 4 m away
    tr = make_trace(xy)
    d = derive(tr, geometry(goal=(4.0, 0.0)))
    assert efficiency(d, geometry(goal=(4.0, 0.0)), CFG, success=True).path_efficiency == pytest.approx(0.4)
    assert efficiency(d, geometry(goal=(4.0, 0.0)), CFG, success=False).path_efficiency is None


def test_empty_slots_are_ignored_and_no_pedestrians_gives_none() -> None:
    tr = make_trace(straight(0.0, 1.0, 10), [still((0.5, 0.0), 10)], ped_ids=np.full((11, 1), -1))
    s = safety(derive(tr, geometry()), CFG)
    assert s.min_distance is None and s.min_clearance is None and s.near_misses == 0


def test_time_to_collision_cases() -> None:
    r = 0.6
    assert time_to_collision(np.array([5.0, 0.0]), np.array([-1.0, 0.0]), r) == pytest.approx(4.4)
    assert time_to_collision(np.array([5.0, 0.0]), np.array([-2.0, 0.0]), r) == pytest.approx(2.2)
    assert time_to_collision(np.array([5.0, 0.0]), np.array([1.0, 0.0]), r) == np.inf  # moving apart
    assert time_to_collision(np.array([0.5, 0.0]), np.array([1.0, 0.0]), r) == 0.0  # already overlapping
    assert time_to_collision(np.array([5.0, 1.0]), np.array([-1.0, 0.0]), r) == np.inf  # passes 1 m off


def test_min_ttc_of_a_head_on_approach() -> None:
    # both at 1 m/s toward each other, 10 m apart: TTC at the start = (10 - 0.6) / 2
    tr = make_trace(straight(0.0, 1.0, 20), [straight(10.0, -1.0, 20)])
    assert safety(derive(tr, geometry()), CFG).min_ttc == pytest.approx(
        min((10.0 - 2.0 * DT * k - 0.6) / 2.0 for k in range(21))
    )


def test_stalled_time_and_no_progress() -> None:
    xy = np.vstack([straight(0.0, 1.0, 10), still((1.0, 0.0), 30)[1:]])  # 1 s moving, 3 s standing
    v = np.concatenate([np.ones(11), np.zeros(30)])
    d = derive(make_trace(xy, v=v, heading=np.zeros(41)), geometry())
    e = efficiency(d, geometry(), CFG, success=False)
    assert e.stalled_time_s == pytest.approx(3.0)
    assert e.no_progress_steps == 30 - 15 + 1  # trailing 1.5 s windows entirely inside the stop


def test_smoothness_of_a_ramp() -> None:
    v = np.minimum(np.arange(21) * 0.1, 1.0)  # 1 m/s^2 for 1 s, then constant
    x = np.concatenate([[0.0], np.cumsum(v[1:] * DT)])
    d = derive(make_trace(np.column_stack([x, np.zeros(21)]), v=v, heading=np.zeros(21)), geometry())
    sm = smoothness(d)
    assert sm.accel_max == pytest.approx(1.0)
    assert sm.accel_mean == pytest.approx(0.5)
    assert sm.jerk_max == pytest.approx(10.0)  # the corner of the ramp in one 0.1 s step
    assert sm.omega_sign_changes == 0


def test_route_progress_along_a_corner() -> None:
    route = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]])
    pos = np.array([[0.0, 0.0], [5.0, 0.5], [10.0, 4.0], [11.0, 10.0]])
    assert route_progress(pos, route) == pytest.approx([0.0, 5.0, 14.0, 20.0])


def test_timing_summary() -> None:
    t = timing_summary(list(range(1, 101)))
    assert t["plan_ms_mean"] == pytest.approx(50.5)
    assert t["plan_ms_p95"] == pytest.approx(95.05)
    assert t["plan_ms_max"] == 100
    assert timing_summary([])["plan_ms_mean"] is None
