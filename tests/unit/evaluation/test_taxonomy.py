"""Each taxonomy label, and each tag, from an episode built to produce it (all hand-built traces)."""

from __future__ import annotations

import numpy as np
import pytest

from foresight.core.evaluation.metrics import derive
from foresight.core.evaluation.taxonomy import LABELS, TaxonomyConfig, classify, count_labels

from .traces import DT, R_PED, R_ROBOT, braking, geometry, make_trace, still, straight


def _classify(tr, outcome, **kw):
    return classify(derive(tr, geometry()), outcome, robot_radius=R_ROBOT, ped_radius=R_PED, **kw)


def test_robot_drives_into_a_standing_pedestrian_is_robot_fault() -> None:
    # contact when the centre distance reaches 0.6 m: x = 4.4 after 44 steps at 1 m/s
    tr = make_trace(straight(0.0, 1.0, 44), [still((5.0, 0.0), 44)])
    res = _classify(tr, "collision_pedestrian", collision_step=44)
    assert res.label == "collision_pedestrian_robot_fault"
    assert res.critical_ped_id == 0
    assert "late_reaction" in res.tags  # it never slowed down


def test_pedestrian_walks_into_a_standing_robot_is_pedestrian_fault() -> None:
    tr = make_trace(still((0.0, 0.0), 44), [straight(5.0, -1.0, 44)], v=0.0, heading=np.zeros(45))
    assert _classify(tr, "collision_pedestrian", collision_step=44).label == "collision_pedestrian_pedestrian_fault"


def test_slow_creep_into_a_pedestrian_is_below_the_fault_threshold() -> None:
    tr = make_trace(straight(4.0, 0.1, 14), [straight(6.0, -0.9, 14)])  # contact at step 14
    assert _classify(tr, "collision_pedestrian", collision_step=14).label == "collision_pedestrian_pedestrian_fault"
    strict = TaxonomyConfig(robot_fault_approach_speed=0.05)
    assert _classify(tr, "collision_pedestrian", collision_step=14, cfg=strict).label == (
        "collision_pedestrian_robot_fault")


def test_static_collision_and_out_of_bounds() -> None:
    tr = make_trace(straight(0.0, 1.0, 20))
    assert _classify(tr, "collision_static", collision_kind="static").label == "collision_static"
    assert _classify(tr, "collision_static", collision_kind="out_of_bounds").label == "out_of_bounds"


def test_planner_error() -> None:
    assert _classify(make_trace(still((0, 0), 3)), "error").label == "planner_error"


def test_success_has_no_label() -> None:
    assert _classify(make_trace(straight(0.0, 1.0, 20)), "success").label is None


def test_freeze_standing_next_to_a_pedestrian() -> None:
    # 5 s stopped with a pedestrian 2 m away (>= 3 s within 3 m)
    tr = make_trace(still((0, 0), 50), [still((2.0, 0.0), 50)], v=0.0, heading=np.zeros(51))
    res = _classify(tr, "timeout")
    assert res.label == "timeout_freeze"
    assert "deadlock" in res.tags


def test_standing_alone_is_not_a_freeze() -> None:
    tr = make_trace(still((0, 0), 50), [still((8.0, 0.0), 50)], v=0.0, heading=np.zeros(51))
    assert _classify(tr, "timeout").label == "timeout_slow_progress"


def test_oscillation_turn_rate_flips_without_progress() -> None:
    n = 81  # 8 s; omega flips sign every second, the robot creeps at 0.06 m/s (not "stopped")
    omega = np.where((np.arange(n) // 10) % 2 == 0, 0.5, -0.5)
    tr = make_trace(straight(0.0, 0.06, n - 1), omega=omega)
    res = _classify(tr, "timeout")
    assert res.label == "timeout_oscillation"


def test_flips_while_progressing_are_slow_progress_not_oscillation() -> None:
    n = 81
    omega = np.where((np.arange(n) // 10) % 2 == 0, 0.5, -0.5)
    tr = make_trace(straight(0.0, 0.3, n - 1), omega=omega)  # 1.5 m per 5 s window
    assert _classify(tr, "timeout").label == "timeout_slow_progress"


def test_small_turn_rates_do_not_count_as_flips() -> None:
    n = 81
    omega = np.where((np.arange(n) // 10) % 2 == 0, 0.15, -0.15)  # below 0.2 rad/s
    assert _classify(make_trace(straight(0.0, 0.06, n - 1), omega=omega), "timeout").label == (
        "timeout_slow_progress")


def test_slow_progress_without_deadlock() -> None:
    res = _classify(make_trace(straight(0.0, 0.3, 400)), "timeout")
    assert res.label == "timeout_slow_progress"
    assert "deadlock" not in res.tags


def test_freeze_takes_precedence_over_oscillation() -> None:
    n = 81
    omega = np.where((np.arange(n) // 10) % 2 == 0, 0.5, -0.5)
    tr = make_trace(still((0, 0), n - 1), [still((1.5, 0.0), n - 1)], v=0.0, heading=np.zeros(n), omega=omega)
    assert _classify(tr, "timeout").label == "timeout_freeze"


def test_early_braking_is_not_a_late_reaction() -> None:
    # braking starts 3.3 s before contact would occur; it stops 0.3 m short (a near miss)
    tr = braking(x_brake=1.1, stop_x=4.1, ped_x=5.0)
    res = _classify(tr, "timeout")
    assert "near_miss" in res.tags
    assert "late_reaction" not in res.tags


def test_late_braking_is_a_late_reaction() -> None:
    tr = braking(x_brake=3.6, stop_x=4.1, ped_x=5.0)  # TTC 0.8 s when braking began
    res = _classify(tr, "timeout")
    assert {"near_miss", "late_reaction"} <= set(res.tags)


def test_prediction_miss_on_the_involved_pedestrian() -> None:
    tr = make_trace(straight(0.0, 1.0, 44), [still((5.0, 0.0), 44), still((0.0, 9.0), 44)])
    hit = _classify(tr, "collision_pedestrian", collision_step=44, prediction_error={0: 1.6, 1: 0.1})
    assert "prediction_miss" in hit.tags
    other = _classify(tr, "collision_pedestrian", collision_step=44, prediction_error={0: 0.2, 1: 3.0})
    assert "prediction_miss" not in other.tags


def test_deadlock_window_is_configurable() -> None:
    tr = make_trace(straight(0.0, 0.03, 100))  # 0.045 m per 1.5 s
    assert "deadlock" in _classify(tr, "timeout").tags
    assert "deadlock" not in _classify(tr, "timeout", cfg=TaxonomyConfig(deadlock_window_s=3.0)).tags


def test_count_labels_has_every_key() -> None:
    counts = count_labels(["timeout_freeze", None, "timeout_freeze", "planner_error"])
    assert set(counts) == set(LABELS)
    assert counts["timeout_freeze"] == 2 and counts["planner_error"] == 1 and sum(counts.values()) == 3


def test_config_rejects_unknown_keys() -> None:
    with pytest.raises(ValueError):
        TaxonomyConfig(freeze_seconds=2)  # type: ignore[call-arg]
    assert DT == 0.1


def _swerve(turn_at: int, w: float, dur: int, n: int = 80):
    """Unicycle at 1 m/s toward a pedestrian standing at (5, 0), turning left at ``w`` for ``dur`` steps."""
    x = y = h = 0.0
    rows = [(0.0, 0.0, 0.0, 1.0, 0.0)]
    for k in range(n):
        om = w if turn_at <= k < turn_at + dur else 0.0
        h += om * DT
        x, y = x + np.cos(h) * DT, y + np.sin(h) * DT
        rows.append((x, y, h, 1.0, om))
    a = np.array(rows)
    return make_trace(a[:, :2], [still((5.0, 0.0), n)], heading=a[:, 2], v=a[:, 3], omega=a[:, 4])


def test_early_swerve_is_not_late_but_a_last_moment_swerve_is() -> None:
    early = _classify(_swerve(10, 0.3, 6), "timeout")  # turning began with TTC 3.4 s
    late = _classify(_swerve(36, 1.0, 8), "timeout")  # turning began with TTC 0.8 s
    assert "near_miss" in early.tags and "late_reaction" not in early.tags
    assert {"near_miss", "late_reaction"} <= set(late.tags)


def test_crossing_pedestrian_changing_the_line_of_sight_is_not_avoidance() -> None:
    # the robot keeps 1 m/s straight on; a pedestrian crosses its path and they collide
    robot, ped = straight(0.0, 1.0, 60), np.column_stack([np.full(61, 5.0), 4.5 - 0.1 * np.arange(61)])
    contact = int(np.flatnonzero(np.linalg.norm(robot - ped, axis=1) <= R_ROBOT + R_PED)[0])
    tr = make_trace(robot[: contact + 1], [ped[: contact + 1]])
    res = _classify(tr, "collision_pedestrian", collision_step=contact)
    assert "late_reaction" in res.tags
