"""What a planner sees each step, and what happened in the step (events).

This is the contract between the simulator and every controller (goal-seeking robot, baselines,
the predictive planner) and the feature extraction of data collection. World frame, metres,
seconds, radians; pedestrians carry the simulator's true, stable ids (a respawned pedestrian gets
a new id, so a track never jumps).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal, Protocol

import numpy as np

CollisionKind = Literal["pedestrian", "static", "out_of_bounds"]


class StaticGeometry(Protocol):
    """Static-obstacle queries for planners (obstacle edges plus map bounds)."""

    segments: np.ndarray  #: (S, 4) x1, y1, x2, y2 [m]
    width: float
    height: float

    def distance(self, points: np.ndarray) -> np.ndarray:
        """Distance [m] from each point (..., 2) to the nearest obstacle edge or map bound, shape (...)."""
        ...


@dataclass(frozen=True)
class Observation:
    step: int  #: steps taken so far in this episode (0 after reset)
    time: float  #: step * dt [s]
    dt: float  #: simulation step [s]
    robot_pose: np.ndarray  #: (3,) x, y, heading [m, m, rad], heading wrapped to [-pi, pi]
    robot_velocity: np.ndarray  #: (2,) v [m/s], omega [rad/s] (differential drive state)
    robot_radius: float  #: [m]
    waypoint: np.ndarray  #: (2,) current route waypoint [m]
    goal: np.ndarray  #: (2,) final goal [m]
    route: np.ndarray  #: (K, 2) remaining waypoints, current first, goal last [m]
    goal_tolerance: float  #: distance to the final goal that counts as reached [m]
    ped_ids: np.ndarray  #: (N,) int64 true pedestrian ids
    ped_positions: np.ndarray  #: (N, 2) world frame [m]
    ped_velocities: np.ndarray  #: (N, 2) world frame [m/s]
    ped_radius: float  #: [m]
    static: StaticGeometry = field(repr=False)
    robot_limits: dict[str, float] = field(
        default_factory=dict
    )  #: RobotLimits.as_dict(): v_max, v_min, w_max, accel, decel, alpha, radius; holonomic 1.0 = commands are (vx, vy)
    #: (N,) each pedestrian's radius [m] where they differ (randomised crowds); None = ``ped_radius`` for all
    ped_radii: np.ndarray | None = None
    #: (k, 2) commands issued but not yet (fully) in effect, oldest first (``robot_config.command_latency_s``,
    #: core.sim.latency); None = no latency
    pending_commands: np.ndarray | None = None
    pending_durations: np.ndarray | None = None  #: (k,) how long each pending command will still act [s]

    def radii(self) -> np.ndarray:
        """(N,) each pedestrian's collision radius [m]."""
        if self.ped_radii is not None:
            return self.ped_radii
        return np.full(len(self.ped_positions), float(self.ped_radius))


@dataclass(frozen=True)
class Events:
    collision: CollisionKind | None = None  #: first collision kind detected this step, if any
    goal_reached: bool = False
    timeout: bool = False  #: horizon reached (exactly max_episode_steps steps) without goal or collision

    @property
    def done(self) -> bool:
        return self.collision is not None or self.goal_reached or self.timeout

    @property
    def outcome(self) -> str | None:
        """Outcome label once done: collision_pedestrian | collision_static | success | timeout."""
        if self.collision == "pedestrian":
            return "collision_pedestrian"
        if self.collision is not None:
            return "collision_static"
        if self.goal_reached:
            return "success"
        if self.timeout:
            return "timeout"
        return None
