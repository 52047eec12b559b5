"""Social-force robot baseline, plus the world-velocity -> (v, omega) tracking shared with ORCA.

The robot is a social-force agent: it relaxes toward its preferred velocity (current route
waypoint, max speed) and is pushed by exponential repulsions from pedestrians (true contact
distance) and from obstacle edges and map bounds (true robot radius). The resulting desired
velocity is tracked by a forward-only unicycle.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from foresight.core.errors import ConfigError
from foresight.core.sim.observation import Observation
from foresight.core.sim.planner import EpisodeInfo


def limits_of(robot_limits: dict[str, float]) -> tuple[float, float]:
    """(max linear speed [m/s], max turn rate [rad/s]) from ``Observation.robot_limits``."""
    try:
        return float(robot_limits["v_max"]), float(robot_limits["w_max"])
    except KeyError as exc:
        raise ConfigError(
            f"observation robot_limits lacks {exc.args[0]!r} (have {sorted(robot_limits)})",
            item="robot_limits",
        ) from None


def command_for(
    u: np.ndarray, obs: Observation, max_speed: float, max_turn_rate: float, turn_gain: float
) -> tuple[float, float]:
    """The robot's command for a desired world velocity ``u``: (vx, vy) itself for a holonomic robot, else the
    (v, omega) that tracks it (``velocity_to_unicycle``)."""
    if obs.robot_limits.get("holonomic", 0.0):
        return float(u[0]), float(u[1])
    return velocity_to_unicycle(u, float(obs.robot_pose[2]), max_speed, max_turn_rate, turn_gain)


def cruise_speed(robot_limits: dict[str, float], speed_ratio: float) -> float:
    """The speed a baseline heads for its waypoint at [m/s]: the ratio of the max speed, at most the robot's
    preferred speed."""
    vmax = float(robot_limits["v_max"])
    return min(speed_ratio * vmax, float(robot_limits.get("v_pref", vmax)))


def velocity_to_unicycle(
    u: np.ndarray, heading: float, max_speed: float, max_turn_rate: float, turn_gain: float = 1.5
) -> tuple[float, float]:
    """Track a desired world velocity ``u`` (2,) [m/s] with a forward-only unicycle.

    omega steers toward u (proportional, clipped); v = |u| cos(error), zero when u points more than
    90 degrees away, so the robot turns on the spot instead of driving off course.
    """
    speed = float(np.hypot(u[0], u[1]))
    if speed < 1e-9:
        return 0.0, 0.0
    err = math.remainder(math.atan2(u[1], u[0]) - heading, 2 * math.pi)
    w = float(np.clip(turn_gain * err, -max_turn_rate, max_turn_rate))
    v = float(np.clip(speed * max(0.0, math.cos(err)), 0.0, max_speed))
    return v, w


class SocialForceConfig(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")

    speed_ratio: float = Field(default=1.0, gt=0, le=1)  #: preferred speed, ratio of the max speed
    relaxation_time: float = Field(default=0.5, gt=0)  #: [s]
    ped_strength: float = Field(default=3.0, ge=0)  #: [m/s^2] at contact
    ped_range: float = Field(default=0.6, gt=0)  #: decay length [m]
    wall_strength: float = Field(default=3.0, ge=0)  #: [m/s^2] at contact
    wall_range: float = Field(default=0.3, gt=0)  #: decay length [m]
    cutoff: float = Field(default=5.0, gt=0)  #: ignore pedestrians/edges farther than this beyond contact [m]
    turn_gain: float = Field(default=1.5, gt=0)  #: heading error -> turn rate [1/s]


class SocialForcePlanner:
    """A robot driven by the social force model (Helbing-style exponential repulsions)."""

    name = "social_force"

    def __init__(self, config: SocialForceConfig | None = None):
        self.config = config or SocialForceConfig()
        self._vel = np.zeros(2)
        self._diag: dict[str, Any] | None = None

    def reset(self, info: EpisodeInfo) -> None:
        self._vel = np.zeros(2)
        self._diag = None

    @property
    def diagnostics(self) -> dict[str, Any] | None:
        return self._diag

    def plan(self, obs: Observation) -> tuple[float, float]:
        c = self.config
        vmax, wmax = limits_of(obs.robot_limits)
        pos, th = np.asarray(obs.robot_pose[:2], dtype=float), float(obs.robot_pose[2])
        v = float(obs.robot_velocity[0])
        self._vel = np.array([v * math.cos(th), v * math.sin(th)])
        to_wp = np.asarray(obs.waypoint, dtype=float) - pos
        dist = float(np.hypot(*to_wp))
        pref = to_wp / dist * cruise_speed(obs.robot_limits, c.speed_ratio) if dist > 1e-9 else np.zeros(2)
        f_goal = (pref - self._vel) / c.relaxation_time
        f_ped = self._ped_force(obs, pos)
        f_wall = self._wall_force(obs, pos)
        u = self._vel + (f_goal + f_ped + f_wall) * obs.dt
        n = float(np.hypot(*u))
        if n > vmax:
            u *= vmax / n
        cmd = command_for(u, obs, vmax, wmax, c.turn_gain)
        self._diag = {
            "command": cmd,
            "desired_velocity": u.tolist(),
            "force_goal": f_goal.tolist(),
            "force_peds": f_ped.tolist(),
            "force_walls": f_wall.tolist(),
        }
        return cmd

    def _ped_force(self, obs: Observation, pos: np.ndarray) -> np.ndarray:
        c = self.config
        if len(obs.ped_positions) == 0:
            return np.zeros(2)
        diff = pos - np.asarray(obs.ped_positions, dtype=float)  # (N, 2)
        d = np.linalg.norm(diff, axis=1)
        gap = d - (obs.robot_radius + (obs.ped_radius if obs.ped_radii is None else obs.ped_radii))
        keep = (gap < c.cutoff) & (d > 1e-9)
        mag = c.ped_strength * np.exp(-gap[keep] / c.ped_range)
        return (mag[:, None] * diff[keep] / d[keep, None]).sum(axis=0)

    def _wall_force(self, obs: Observation, pos: np.ndarray) -> np.ndarray:
        c = self.config
        seg = np.asarray(obs.static.segments, dtype=float).reshape(-1, 4)
        if len(seg) == 0:
            return np.zeros(2)
        a, d = seg[:, :2], seg[:, 2:] - seg[:, :2]
        len2 = np.maximum((d**2).sum(axis=1), 1e-12)
        t = np.clip(((pos - a) * d).sum(axis=1) / len2, 0.0, 1.0)
        off = pos - (a + t[:, None] * d)  # (S, 2) from the nearest edge point to the robot
        dist = np.linalg.norm(off, axis=1)
        gap = dist - obs.robot_radius
        keep = (gap < c.cutoff) & (dist > 1e-9)
        mag = c.wall_strength * np.exp(-gap[keep] / c.wall_range)
        return (mag[:, None] * off[keep] / dist[keep, None]).sum(axis=0)
