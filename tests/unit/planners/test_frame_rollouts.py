"""``FrameRollouts``: rollouts done once in the robot's frame, then placed, are the simulator's rollouts."""

from __future__ import annotations

import numpy as np

from foresight.core.planners.predictive.rollout import FrameRollouts, rollout
from foresight.core.sim.robot import RobotLimits, wrap_angle


def _commands(rng: np.random.Generator, b: int = 12, n: int = 30) -> np.ndarray:
    cmds = np.empty((b, n, 2))
    cmds[..., 0] = rng.uniform(0.0, 2.0, size=(b, 1))
    cmds[..., 1] = rng.uniform(-1.0, 1.0, size=(b, 1))
    cmds[:, n // 2 :, 1] *= -1.0  # a second segment: not every sequence holds one command
    return cmds


def test_placed_rollouts_equal_the_simulators_from_any_pose():
    rng = np.random.default_rng(3)
    limits, dt = RobotLimits(), 0.1
    cmds = _commands(rng)
    frames = FrameRollouts(limits, dt)
    starts = np.column_stack(
        [
            rng.uniform(-20, 20, (5, 2)),
            rng.uniform(-np.pi, np.pi, 5),
            rng.uniform(0, 2, 5),
            rng.uniform(-1, 1, 5),
        ]
    )
    got = frames(starts, cmds, "set").reshape(5, len(cmds), cmds.shape[1], 5)
    for p, s0 in enumerate(starts):
        want = rollout(np.repeat(s0[None], len(cmds), axis=0), cmds, limits, dt)
        np.testing.assert_allclose(got[p, ..., :2], want[..., :2], atol=1e-9)
        np.testing.assert_allclose(wrap_angle(got[p, ..., 2] - want[..., 2]), 0.0, atol=1e-9)
        np.testing.assert_allclose(got[p, ..., 3:], want[..., 3:], atol=1e-12)


def test_the_same_speeds_reuse_the_stored_rollout_and_other_commands_do_not():
    rng = np.random.default_rng(4)
    limits, dt = RobotLimits(), 0.1
    frames = FrameRollouts(limits, dt)
    cmds, other = _commands(rng), _commands(rng)
    a = frames(np.array([[1.0, 2.0, 0.3, 0.5, 0.1]]), cmds, "a")
    b = frames(np.array([[-4.0, 7.0, -2.0, 0.5, 0.1]]), cmds, "a")  # another pose, the same speeds
    assert len(frames._local) == 1
    assert not np.allclose(a[..., :2], b[..., :2])
    c = frames(np.array([[1.0, 2.0, 0.3, 0.5, 0.1]]), other, "b")
    assert len(frames._local) == 2
    want = rollout(np.repeat(np.array([[1.0, 2.0, 0.3, 0.5, 0.1]]), len(other), axis=0), other, limits, dt)
    np.testing.assert_allclose(c[..., :2], want[..., :2], atol=1e-9)


def test_speeds_that_differ_in_their_last_bits_share_one_stored_rollout():
    """A ramp reaches 0.3 m/s as 0.1 + 0.2 = 0.30000000000000004 and as 0.3: one speed, one rollout."""
    rng = np.random.default_rng(5)
    limits, dt = RobotLimits(), 0.1
    frames = FrameRollouts(limits, dt)
    cmds = _commands(rng)
    a = frames(np.array([[0.0, 0.0, 0.0, 0.1 + 0.2, 0.1]]), cmds, "a")
    b = frames(np.array([[0.0, 0.0, 0.0, 0.3, 0.1]]), cmds, "a")
    assert 0.1 + 0.2 != 0.3 and len(frames._local) == 1
    np.testing.assert_array_equal(a, b)
    frames(np.array([[0.0, 0.0, 0.0, 0.31, 0.1]]), cmds, "a")  # another speed: another rollout
    assert len(frames._local) == 2


def test_the_least_recently_used_rollout_makes_room():
    rng = np.random.default_rng(6)
    limits, dt = RobotLimits(), 0.1
    frames = FrameRollouts(limits, dt, capacity=2)
    cmds = _commands(rng)
    start = {v: np.array([[0.0, 0.0, 0.0, v, 0.0]]) for v in (0.5, 1.0, 1.5)}
    frames(start[0.5], cmds, "a")
    frames(start[1.0], cmds, "a")
    frames(start[0.5], cmds, "a")  # used again: 1.0 is now the least recently used
    frames(start[1.5], cmds, "a")
    assert sorted(v for _, v, _ in frames._local) == [0.5, 1.5]
