"""A fixed plan driven with the robot's own limits: through via points, then (optionally) to a point where it stands
until a release time, then on through more points to the goal.

Why a planner: such a plan is what a *witness* is (``core.evaluation.witness``): one that reaches the goal without
contact proves that a robot with these limits could solve the episode, also where the crowd reacts to the robot
(where no reachability analysis can say). As a registered planner, a witness is reproduced like any run:
``foresight sim run --planner scripted --planner-config '{"hold": [24.5, 14.8], "release_s": 21, ...}'``.

The driver steers at its current target at up to three times the heading error [rad/s] (clipped to the turn-rate
limit) and drives at full speed times cos^2 of the heading error, so it turns on the spot and straightens out at
speed; a holonomic robot heads straight at the target at full speed. It ignores pedestrians by design.
"""

from __future__ import annotations

import math
from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from foresight.core.sim.observation import Observation
from foresight.core.sim.planner import EpisodeInfo

Point = tuple[float, float]
REACHED = 0.6  #: a target point counts as reached this close [m]
TURN_GAIN = 3.0  #: turn rate per radian of heading error [1/s], clipped to the robot's limit
MAX_POINTS = 1000  #: points a plan may name before and after its stand (a config is a bounded job input)


class ScriptedConfig(BaseModel):
    """The plan: ``via`` points in turn, then ``hold`` (stand there until ``release_s``), then ``after``, then the goal."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)

    via: tuple[Point, ...] = Field(default=(), max_length=MAX_POINTS)  #: [m] points driven through first
    hold: Point | None = None  #: [m] where to stand until the release time (None: no stand)
    release_s: float = Field(default=0.0, ge=0)  #: [s] episode time at which the stand ends
    after: tuple[Point, ...] = Field(
        default=(), max_length=MAX_POINTS
    )  #: [m] points driven through after the stand

    def describe(self) -> str:
        """One line, e.g. ``via (30.00, 16.00); wait at (24.50, 14.80) until 21 s; then (18.70, 12.46)``."""
        pts = lambda ps: ", ".join(f"({x:.2f}, {y:.2f})" for x, y in ps)  # noqa: E731
        parts = [f"via {pts(self.via)}"] if self.via else []
        if self.hold is not None:
            parts.append(f"wait at {pts([self.hold])} until {self.release_s:g} s")
        if self.after:
            parts.append(f"then {pts(self.after)}")
        return "; ".join(parts) or "straight at the goal"


class Scripted:
    """Drives a :class:`ScriptedConfig`, then the goal."""

    name = "scripted"

    def __init__(self, config: ScriptedConfig | None = None):
        self.config = config or ScriptedConfig()
        c = self.config
        self.stops: list[tuple[Point, float | None]] = (
            [(p, None) for p in c.via]
            + ([(c.hold, c.release_s)] if c.hold is not None else [])
            + [(p, None) for p in c.after]
        )
        self.i = 0

    def reset(self, info: EpisodeInfo) -> None:
        self.i = 0

    @property
    def diagnostics(self) -> dict[str, Any] | None:
        return {"stop": self.i}

    def plan(self, obs: Observation) -> tuple[float, float]:
        x, y, th = (float(v) for v in obs.robot_pose)
        while self.i < len(self.stops):
            (px, py), release = self.stops[self.i]
            if math.hypot(px - x, py - y) >= REACHED:
                break
            if release is not None and obs.time < release:
                return 0.0, 0.0
            self.i += 1
        tx, ty = (
            self.stops[self.i][0] if self.i < len(self.stops) else (float(obs.goal[0]), float(obs.goal[1]))
        )
        lim = obs.robot_limits
        if lim.get("holonomic", 0.0):  # a world-frame velocity (vx, vy): straight at the target
            d = max(math.hypot(tx - x, ty - y), 1e-9)
            return lim["v_max"] * (tx - x) / d, lim["v_max"] * (ty - y) / d
        err = (math.atan2(ty - y, tx - x) - th + math.pi) % (2 * math.pi) - math.pi
        return lim["v_max"] * max(0.0, math.cos(err)) ** 2, max(
            -lim["w_max"], min(lim["w_max"], TURN_GAIN * err)
        )
