"""Goal-seeking controller: drive at the current route waypoint; the data-collection robot.

It ignores pedestrians on purpose (collected crowds should react to a robot that does not plan
around them); optional Gaussian command noise, from its own generator seeded by the episode seed,
diversifies the robot's paths across episodes.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict

from foresight.core.sim.observation import Observation
from foresight.core.sim.planner import EpisodeInfo


class GoalSeekingConfig(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")

    speed: float = 1.0  #: cruise speed [m/s]
    turn_gain: float = 1.5  #: turn rate per heading error [1/s]
    max_turn_rate: float = 1.0  #: [rad/s]
    slow_angle: float = np.pi / 2  #: heading error at which the commanded speed reaches zero [rad]
    noise_v: float = 0.0  #: std of additive speed noise [m/s]
    noise_w: float = 0.0  #: std of additive turn-rate noise [rad/s]
    corner_reach: float = 0.6  #: keep steering to a passed waypoint until this close [m]; 0 = off


class GoalSeeking:
    """Proportional heading control towards the route waypoint; slows down linearly with the heading error.

    The simulator advances ``obs.waypoint`` as soon as the robot is within 2 m of it, so steering
    straight at the new one cuts every corner by up to 2 m, which puts the 1 m robot into the wall
    of a turning corridor. With ``corner_reach`` > 0 the controller keeps heading for the waypoint
    just passed until within that distance (on the 23 reference scenarios x 3 seeds: static
    collisions 31 -> 0 of 69, successes 20 -> 47).
    """

    name = "goal"

    def __init__(self, config: GoalSeekingConfig | None = None, **overrides: float):
        base = config or GoalSeekingConfig()
        self.config = (
            GoalSeekingConfig.model_validate({**base.model_dump(), **overrides}) if overrides else base
        )
        self._rng = np.random.default_rng(0)
        self._last: dict[str, Any] | None = None
        self._target: np.ndarray | None = None

    def reset(self, info: EpisodeInfo) -> None:
        # own stream, independent of the simulator's generators for the same seed
        self._rng = np.random.default_rng([int(info.seed), 0x60A1])
        self._last = None
        self._target = None

    def _steer_point(self, obs: Observation) -> np.ndarray:
        """The waypoint to head for: the one just passed until within ``corner_reach``, else the current one."""
        wp = np.asarray(obs.waypoint, dtype=float)
        held = self._target
        holding = self.config.corner_reach > 0 and held is not None and not np.array_equal(held, wp)
        if holding and np.hypot(*(obs.robot_pose[:2] - held)) > self.config.corner_reach:
            return held
        self._target = wp.copy()
        return wp

    def plan(self, obs: Observation) -> tuple[float, float]:
        c = self.config
        x, y, th = obs.robot_pose
        target = self._steer_point(obs)
        dx, dy = target[0] - x, target[1] - y
        if obs.robot_limits.get("holonomic", 0.0):
            return self._holonomic(dx, dy)
        err = (np.arctan2(dy, dx) - th + np.pi) % (2 * np.pi) - np.pi
        w = float(np.clip(c.turn_gain * err, -c.max_turn_rate, c.max_turn_rate))
        v = float(c.speed * max(0.0, 1.0 - abs(err) / c.slow_angle))
        if c.noise_v > 0 or c.noise_w > 0:
            nv, nw = self._rng.normal(0.0, 1.0, 2)
            v = max(0.0, v + c.noise_v * nv)
            w = w + c.noise_w * nw
        self._last = {"heading_error": float(err), "v": v, "w": w}
        return v, w

    def _holonomic(self, dx: float, dy: float) -> tuple[float, float]:
        """A holonomic robot takes a world-frame velocity (vx, vy): head straight for the waypoint."""
        n = float(np.hypot(dx, dy))
        scale = self.config.speed / n if n > 0 else 0.0
        vx, vy = dx * scale, dy * scale
        if self.config.noise_v > 0:
            vx, vy = (vx, vy) + self.config.noise_v * self._rng.normal(0.0, 1.0, 2)
        self._last = {"vx": float(vx), "vy": float(vy)}
        return float(vx), float(vy)

    @property
    def diagnostics(self) -> dict[str, Any] | None:
        return self._last
