"""Command latency: a command takes effect ``latency`` seconds after it is issued (``robot_config.command_latency_s``).

With latency L = m dt + f (0 <= f < dt), the command issued at step t is in effect from time t dt + L on: during
step t the robot executes the command issued at step t - m - 1 for the first f seconds and the one issued at step
t - m for the remaining dt - f (before the first command arrives, the robot is commanded to stand: (0, 0)). The
simulator integrates each piece with the robot's own kinematics (``robot_step`` over f, then over dt - f; one
piece of dt when f = 0, so a latency of whole steps changes nothing but the order of commands, and latency 0
nothing at all).

What a planner needs to plan for the moment its command takes effect is the list of commands issued but not yet
(fully) in effect, oldest first, with how long each will still act (``CommandDelay.pending``); ``advance`` rolls a
state through them exactly as the simulator will (when nothing else, such as a collision, intervenes).
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from foresight.core.sim.robot import RobotLimits, robot_step

_EPS = 1e-9


def split(latency: float, dt: float) -> tuple[int, float]:
    """(m, f): latency = m dt + f with 0 <= f < dt (f snapped to 0 within 1e-9 s of a whole step)."""
    m = math.floor(latency / dt + _EPS)
    f = latency - m * dt
    return (m, 0.0) if f < _EPS else (m, f)


class CommandDelay:
    """The commands in flight between a planner and the robot's actuators."""

    def __init__(self, latency: float, dt: float):
        self.latency, self.dt = float(latency), float(dt)
        self.m, self.f = split(self.latency, self.dt)
        n = self.m + (1 if self.f > 0 else 0)  #: commands that are issued but not (fully) in effect
        self._queue: deque[np.ndarray] = deque(np.zeros(2) for _ in range(n))

    def push(self, cmd: np.ndarray) -> list[tuple[np.ndarray, float]]:
        """Issue ``cmd``; the (command, duration) pieces the robot executes during this step, in order."""
        self._queue.append(np.asarray(cmd, dtype=float).reshape(2).copy())
        if self.f > 0:
            first, second = self._queue.popleft(), self._queue[0]
            return [(first, self.f), (second, self.dt - self.f)]
        return [(self._queue.popleft(), self.dt)]

    def pending(self) -> tuple[np.ndarray, np.ndarray]:
        """Commands (k, 2) issued but not (fully) in effect, oldest first, and how long each will still act (k,) [s];
        their durations sum to the latency."""
        cmds = np.array(list(self._queue), dtype=float).reshape(-1, 2)
        durations = np.full(len(cmds), self.dt)
        if self.f > 0 and len(durations):
            durations[0] = self.f
        return cmds, durations


def advance(state: np.ndarray, cmds: np.ndarray, durations: np.ndarray, limits: RobotLimits) -> np.ndarray:
    """The robot state (5,) after executing ``cmds`` (k, 2) for ``durations`` (k,) [s] from ``state``: where the robot
    will be when a command issued now takes effect."""
    s = np.asarray(state, dtype=float)
    for cmd, d in zip(np.asarray(cmds, dtype=float), np.asarray(durations, dtype=float), strict=True):
        s = robot_step(s, cmd, limits, float(d))
    return s
