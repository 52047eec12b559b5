"""Each taxonomy label, and each tag, from an episode built to produce it (all hand-built traces)."""

from __future__ import annotations

import numpy as np
import pytest

from foresight.core.evaluation.metrics import EpisodeGeometry, derive
from foresight.core.evaluation.taxonomy import LABELS, TaxonomyConfig, classify, count_labels
from foresight.core.sim.robot import RobotLimits

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


def test_standing_still_while_a_walker_it_saw_for_seconds_walks_into_it_is_robot_fault() -> None:
    # (this case was labelled pedestrian fault before 2026-11-24: the robot never moved, yet it had 4.4 s to)
    tr = make_trace(still((0.0, 0.0), 44), [straight(5.0, -1.0, 44)], v=0.0, heading=np.zeros(45))
    res = _classify(tr, "collision_pedestrian", collision_step=44)
    assert res.label == "collision_pedestrian_robot_fault"
    assert res.avoidable is True and res.decision_step == 44 - 30  # the 3 s look-back, not the spawn


def test_slow_creep_into_a_pedestrian_is_below_the_fault_threshold() -> None:
    tr = make_trace(straight(4.0, 0.1, 14), [straight(6.0, -0.9, 14)])  # contact at step 14
    res = _classify(tr, "collision_pedestrian", collision_step=14)
    assert res.label == "collision_pedestrian_pedestrian_fault"
    assert res.avoidable is False  # 1.4 s from the first recorded step is too short to get out of the way
    strict = TaxonomyConfig(robot_fault_approach_speed=0.05)
    assert _classify(tr, "collision_pedestrian", collision_step=14, cfg=strict).label == (
        "collision_pedestrian_robot_fault"
    )


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
        "timeout_slow_progress"
    )


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


def _side_hit(visible_steps: int, ped_speed: float, n: int = 60):
    """Robot at 2 m/s along +x; a pedestrian running +y at ``ped_speed`` appears (spawns) ``visible_steps``
    before it hits the robot's right side at step n (line of centres perpendicular to the robot's motion)."""
    robot = straight(0.0, 2.0, n)
    t = np.arange(n + 1)
    ped = np.column_stack([np.full(n + 1, robot[n, 0]), -(R_ROBOT + R_PED) - ped_speed * DT * (n - t)])
    ids = np.where(t >= n - visible_steps, 7, -1)[:, None]
    return make_trace(robot, [ped], ped_ids=ids, v=2.0, heading=np.zeros(n + 1))


def test_unavoidable_side_hit_at_speed_is_pedestrian_fault() -> None:
    res = _classify(_side_hit(5, 2.0), "collision_pedestrian", collision_step=60)
    assert res.label == "collision_pedestrian_pedestrian_fault"
    assert res.avoidable is False and res.decision_step == 55  # visible from its spawn, 0.5 s before contact
    assert res.critical_ped_id == 7


def test_the_same_side_hit_seen_earlier_is_robot_fault() -> None:
    res = _classify(_side_hit(8, 1.5), "collision_pedestrian", collision_step=60)  # 0.8 s: braking clears it
    assert res.label == "collision_pedestrian_robot_fault"
    assert res.avoidable is True and res.decision_step == 52


def test_standing_robot_of_the_reference_size_in_the_path_of_a_slow_walker_is_robot_fault() -> None:
    # robot radius 1 m as the reference robot; a 0.5 m/s walker from 6 m, visible for 9.4 s
    contact = int(round((6.0 - 1.3) / 0.05))
    tr = make_trace(
        still((0.0, 0.0), contact), [straight(6.0, -0.5, contact)], v=0.0, heading=np.zeros(contact + 1)
    )
    geom = EpisodeGeometry(robot_radius=1.0, ped_radius=0.3, horizon=1000, route=np.array([[100.0, 0.0]]))
    res = classify(
        derive(tr, geom), "collision_pedestrian", robot_radius=1.0, ped_radius=0.3, collision_step=contact
    )
    assert res.label == "collision_pedestrian_robot_fault" and res.avoidable is True


def _head_on(visible_steps: int = 8):
    """A robot standing still facing +x; a walker at 1 m/s appears 0.8 s before it reaches the robot."""
    n = 40
    ped = straight(R_ROBOT + R_PED + 0.1 * n, -1.0, n)
    ids = np.where(np.arange(n + 1) >= n - visible_steps, 0, -1)[:, None]
    return make_trace(still((0.0, 0.0), n), [ped], ped_ids=ids, v=0.0, heading=np.zeros(n + 1)), n


def test_escape_uses_the_robot_kind_holonomic_can_sidestep_where_differential_drive_cannot() -> None:
    tr, n = _head_on()
    diff = _classify(tr, "collision_pedestrian", collision_step=n)
    holo = _classify(tr, "collision_pedestrian", collision_step=n, limits=RobotLimits(kind="holonomic"))
    assert diff.label == "collision_pedestrian_pedestrian_fault"  # turning in place first takes too long
    assert holo.label == "collision_pedestrian_robot_fault"  # a sideways step clears it


class _Corridor:
    """Static geometry of a dead-end corridor along +x: walls at y = +-half_width and x = -half_width
    (distance only, as the check needs)."""

    segments = np.zeros((0, 4))
    width = height = 100.0

    def __init__(self, half_width: float):
        self.half_width = half_width

    def distance(self, points: np.ndarray) -> np.ndarray:
        p = np.asarray(points)
        return np.minimum(self.half_width - np.abs(p[..., 1]), p[..., 0] + self.half_width)


def test_an_escape_through_a_wall_does_not_count() -> None:
    tr, n = _head_on()
    holo = RobotLimits(kind="holonomic")
    free = _classify(tr, "collision_pedestrian", collision_step=n, limits=holo, static=_Corridor(5.0))
    boxed = _classify(
        tr, "collision_pedestrian", collision_step=n, limits=holo, static=_Corridor(R_ROBOT + 0.05)
    )
    assert free.label == "collision_pedestrian_robot_fault"  # sideways or backwards
    assert boxed.label == "collision_pedestrian_pedestrian_fault" and boxed.avoidable is False


def test_fault_look_back_is_configurable() -> None:
    tr = make_trace(still((0.0, 0.0), 44), [straight(5.0, -1.0, 44)], v=0.0, heading=np.zeros(45))
    short = _classify(tr, "collision_pedestrian", collision_step=44, cfg=TaxonomyConfig(fault_lookback_s=0.5))
    assert short.decision_step == 39 and short.label == "collision_pedestrian_pedestrian_fault"
