"""Robot kinematics: limits, command tracking, the reference lag, odometry, batching."""

from __future__ import annotations

import numpy as np
import pytest

from core.scenarios.model import RobotConfig
from core.sim.robot import RobotLimits, holonomic_step, unicycle_step

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
        one = np.array([[unicycle_step(states[i, j], cmds[i, j], lim, DT) for j in range(6)] for i in range(4)])
        assert np.array_equal(batch, one)
    # one state, many commands broadcasts
    assert unicycle_step(states[0, 0], cmds[0], RobotLimits(), DT).shape == (6, 5)


def test_limits_from_robot_config():
    lim = RobotLimits.from_config(RobotConfig(allow_backwards=True, max_linear_decel=2.0, actuation="reference_lag"))
    assert lim.v_min == -2.0 and lim.decel == 2.0 and lim.actuation == "reference_lag"
    assert lim.as_dict()["radius"] == 1.0


def test_holonomic_tracks_world_velocity_within_accel():
    lim = RobotLimits(kind="holonomic")
    s = np.zeros(5)
    for _ in range(30):
        s = holonomic_step(s, np.array([0.0, 1.0]), lim, DT)
    assert s[3] == pytest.approx(1.0) and s[2] == pytest.approx(np.pi / 2)
    assert s[1] > 1.5 and abs(s[0]) < 1e-9
