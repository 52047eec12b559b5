"""Robot kinematics: limits, command tracking, the reference lag, odometry, batching."""

from __future__ import annotations

import numpy as np
import pytest

from foresight.core.scenarios.model import RobotConfig
from foresight.core.sim.robot import (
    RobotLimits,
    holonomic_step,
    robot_rollout,
    unicycle_rollout,
    unicycle_step,
    wrap_angle,
)

DT = 0.1
DEFAULT = RobotLimits()


def drive(cmd, steps, limits=DEFAULT, state=None):
    s = np.zeros(5) if state is None else np.asarray(state, dtype=float)
    out = [s]
    for _ in range(steps):
        s = unicycle_step(s, np.asarray(cmd, dtype=float), limits, DT)
        out.append(s)
    return np.array(out)


def test_tracking_accelerates_at_the_limit_then_holds_the_target():
    traj = drive((2.0, 0.0), 30)
    assert traj[1, 3] == pytest.approx(0.1)  # 1 m/s^2 x 0.1 s
    assert traj[20, 3] == pytest.approx(2.0)
    assert traj[30, 3] == pytest.approx(2.0)
    assert np.all(np.diff(traj[:, 3]) <= 0.1 + 1e-12)


def test_speeds_are_clipped_to_the_limits_and_no_backwards_driving():
    traj = drive((5.0, 3.0), 40)
    assert traj[:, 3].max() == pytest.approx(2.0) and traj[:, 4].max() == pytest.approx(1.0)
    back = drive((-1.0, -3.0), 40, state=[0, 0, 0, 1.0, 0])
    assert back[:, 3].min() == 0.0 and back[-1, 4] == pytest.approx(-1.0)
    assert np.all(np.diff(back[:11, 3]) == pytest.approx(-0.1))  # decel limit 1 m/s^2


def test_reference_lag_realises_a_tenth_of_the_clipped_error():
    lag = RobotLimits(actuation="reference_lag")
    s = unicycle_step(np.array([0, 0, 0, 1.5, 0.0]), np.array([2.0, 0.3]), lag, DT)
    assert s[3] == pytest.approx(1.5 + 0.1 * 0.5) and s[4] == pytest.approx(0.03)
    s = unicycle_step(np.array([0, 0, 0, 0.0, 0.0]), np.array([2.0, 0.0]), lag, DT)
    assert s[3] == pytest.approx(0.1)  # error clipped to the 1 m/s^2 action bound


def test_midpoint_odometry_straight_and_circle():
    s = unicycle_step(np.array([0, 0, 0, 1.0, 0.0]), np.array([1.2, 0.0]), RobotLimits(), DT)
    assert s[0] == pytest.approx(0.5 * (1.0 + 1.1) * DT) and s[1] == 0.0
    # steady v = 1, omega = 1: a unit circle back to the start after 2 pi seconds
    traj = drive((1.0, 1.0), 63, state=[0, 0, 0, 1.0, 1.0])
    assert np.hypot(*(traj[:, :2] - [0, 1]).T) == pytest.approx(1.0, abs=1e-3)
    assert np.all(np.abs(traj[:, 2]) <= np.pi)


def test_batched_equals_single_bit_for_bit():
    rng = np.random.default_rng(0)
    states = rng.uniform(-3, 3, (4, 6, 5))
    cmds = rng.uniform(-3, 3, (4, 6, 2))
    for act in ("tracking", "reference_lag"):
        lim = RobotLimits(actuation=act)
        batch = unicycle_step(states, cmds, lim, DT)
        assert batch.shape == (4, 6, 5)
        one = np.array(
            [[unicycle_step(states[i, j], cmds[i, j], lim, DT) for j in range(6)] for i in range(4)]
        )
        assert np.array_equal(batch, one)
    # one state, many commands broadcasts
    assert unicycle_step(states[0, 0], cmds[0], RobotLimits(), DT).shape == (6, 5)


def test_limits_from_robot_config():
    lim = RobotLimits.from_config(
        RobotConfig(allow_backwards=True, max_linear_decel=2.0, actuation="reference_lag")
    )
    assert lim.v_min == -2.0 and lim.decel == 2.0 and lim.actuation == "reference_lag"
    assert lim.as_dict()["radius"] == 1.0


def test_holonomic_tracks_world_velocity_within_accel():
    lim = RobotLimits(kind="holonomic")
    s = np.zeros(5)
    for _ in range(30):
        s = holonomic_step(s, np.array([0.0, 1.0]), lim, DT)
    assert s[3] == pytest.approx(1.0) and s[2] == pytest.approx(np.pi / 2)
    assert s[1] > 1.5 and abs(s[0]) < 1e-9


def _stepped(state0, cmds, limits, step=unicycle_step):
    """Reference: ``step`` called once per step, (..., n, 5)."""
    out = np.empty(np.broadcast_shapes(state0.shape[:-1], cmds.shape[:-2]) + (cmds.shape[-2], 5))
    s = state0
    for k in range(cmds.shape[-2]):
        s = step(s, cmds[..., k, :], limits, DT)
        out[..., k, :] = s
    return out


def _assert_same_states(a, b, tol=1e-9):
    assert a.shape == b.shape
    d = np.abs(a - b)
    d[..., 2] = np.abs(wrap_angle(a[..., 2] - b[..., 2]))  # -pi and pi are the same heading
    assert d.max() <= tol


def _piecewise(rng, batch, n, changes):
    """Commands (batch, n, 2) constant between ``changes`` random steps, per sequence values over the limits."""
    cuts = np.sort(rng.choice(np.arange(1, n), changes, replace=False))
    values = rng.uniform(-3, 3, (batch, changes + 1, 2))
    return values[:, np.searchsorted(cuts, np.arange(n), side="right")]


LIMITS = [
    RobotLimits(),
    RobotLimits(v_min=-2.0),  # allow_backwards
    RobotLimits(accel=3.0, decel=0.5, alpha=2.5, w_max=0.7, v_min=-1.0, v_max=1.5),
    RobotLimits(actuation="reference_lag"),
    RobotLimits(actuation="reference_lag", v_min=-2.0, decel=2.0, alpha=0.4),
    RobotLimits(kind="holonomic"),  # unicycle_step ignores the kind; so does unicycle_rollout
]


@pytest.mark.parametrize("limits", LIMITS)
def test_rollout_equals_repeated_steps(limits):
    rng = np.random.default_rng(7)
    for trial in range(40):
        n = int(rng.integers(1, 45))
        # speeds also outside the limits (a state never produced by a step) and headings near +-pi
        state0 = np.column_stack(
            [
                rng.uniform(-5, 5, (25, 2)),
                rng.uniform(-3.2, 3.2, 25),
                rng.uniform(-3, 3, 25),
                rng.uniform(-2, 2, 25),
            ]
        )
        if trial % 4 == 0:
            cmds = rng.uniform(-3, 3, (25, n, 2))  # a new command every step
        else:
            cmds = _piecewise(rng, 25, n, int(rng.integers(0, min(4, n - 1) + 1)) if n > 1 else 0)
        _assert_same_states(unicycle_rollout(state0, cmds, limits, DT), _stepped(state0, cmds, limits))


def test_rollout_broadcasts_and_keeps_its_inputs():
    rng = np.random.default_rng(3)
    lim = RobotLimits()
    state = np.array([1.0, 2.0, 3.1, 1.5, -0.5])
    cmds = np.repeat(rng.uniform(-1, 2, (6, 1, 2)), 30, axis=1)
    s_copy, c_copy = state.copy(), cmds.copy()
    out = unicycle_rollout(state, cmds, lim, DT)  # one state, many sequences
    assert out.shape == (6, 30, 5)
    _assert_same_states(out, _stepped(state, cmds, lim))
    assert np.array_equal(state, s_copy) and np.array_equal(cmds, c_copy)
    one = unicycle_rollout(state, cmds[2], lim, DT)  # one state, one sequence
    assert one.shape == (30, 5)
    _assert_same_states(one, out[2], tol=0.0)
    states = np.stack([state, state * [1, 1, -1, 0.5, 1]])[:, None]  # (2, 1, 5) x (6, 30, 2) -> (2, 6, 30, 5)
    _assert_same_states(unicycle_rollout(states, cmds, lim, DT), _stepped(states, cmds, lim))
    assert unicycle_rollout(state, np.zeros((4, 0, 2)), lim, DT).shape == (4, 0, 5)


def test_rollout_reaches_and_holds_the_command():
    out = unicycle_rollout(np.zeros(5), np.tile([2.0, 0.3], (30, 1)), RobotLimits(), DT)
    assert out[0, 3] == pytest.approx(0.1) and out[19:, 3] == pytest.approx(2.0)
    assert out[2, 4] == pytest.approx(0.3) and np.all(np.abs(out[:, 2]) < np.pi)


def test_robot_rollout_dispatches_on_the_kind():
    rng = np.random.default_rng(5)
    state0 = np.column_stack([rng.uniform(-5, 5, (8, 3)), rng.uniform(0, 2, 8), np.zeros(8)])
    cmds = _piecewise(rng, 8, 20, 2)
    hol = RobotLimits(kind="holonomic")
    _assert_same_states(
        robot_rollout(state0, cmds, hol, DT), _stepped(state0, cmds, hol, holonomic_step), tol=0.0
    )
    _assert_same_states(robot_rollout(state0, cmds, RobotLimits(), DT), _stepped(state0, cmds, RobotLimits()))


def test_wrap_angle_is_the_floor_remainder_bit_for_bit():
    """The array fast path (one period added or subtracted) gives exactly (a + pi) % 2 pi - pi."""
    rng = np.random.default_rng(3)
    edges = []
    for c in (
        -3 * np.pi,
        -np.pi,
        0.0,
        np.pi,
        3 * np.pi,
    ):  # each boundary and 40 representable numbers either side
        for side in (-np.inf, np.inf):
            x = c
            for _ in range(40):
                x = np.nextafter(x, side)
                edges.append(x)
        edges.append(c)
    near = [
        np.array(edges),
        rng.uniform(-3 * np.pi, 3 * np.pi, 100_000),
        rng.uniform(-1e-9, 1e-9, 1000) + np.pi,
    ]
    far = [rng.uniform(-50.0, 50.0, 1000), np.array([np.nan, 1.0] * 10), np.array([np.inf, 0.5] * 10)]
    for a in near + far + [x.astype(np.float32) for x in near]:
        with np.errstate(invalid="ignore"):  # inf % 2 pi is nan
            expected = (a + np.pi) % (2 * np.pi) - np.pi
            got = wrap_angle(a)
        assert got.dtype == expected.dtype
        np.testing.assert_array_equal(got.view(f"i{got.itemsize}"), expected.view(f"i{got.itemsize}"))
    assert wrap_angle(3 * np.pi) == (3 * np.pi + np.pi) % (2 * np.pi) - np.pi  # scalars as before
