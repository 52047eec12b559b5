"""Cost of rolled-out robot trajectories (lower is better), vectorised over candidates x peds x steps.

Pedestrian terms compare robot and forecast positions at the SAME instants (the forecast's time
grid) with the TRUE contact distance r_robot + r_ped (+ optional extra margins): the reference
compared 0.2 s robot steps with 0.1 s forecast steps and used 0.25 m radii for a 1.0 m robot.
Static terms use the distance to obstacle edges and map bounds at every simulator step of the
rollout (the reference had no static term at all; walls were its biggest failure class).
Progress is measured along the route (waypoints), not straight to the goal, so the robot follows
the route around obstacles between it and the goal.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.planners.predictive.config import PredictivePlannerConfig
from core.sim.observation import StaticGeometry

TERMS = (
    "progress", "collision", "near_miss", "ttc", "progress_risk", "hard_clearance",
    "static", "static_collision", "velocity", "turn", "smoothness", "heading",
)


class RoutePotential:
    """Remaining route length [m] from a point: distance to the active waypoint plus the route after it.

    The active waypoint advances along a rollout as the simulator does (within ``switch_radius``),
    so passing a waypoint is never penalised; the final goal counts as reached inside ``goal_tolerance``.
    """

    def __init__(self, route: np.ndarray, switch_radius: float, goal_tolerance: float, lookahead: int = 3):
        full = np.asarray(route, dtype=float).reshape(-1, 2)
        seg = np.linalg.norm(np.diff(full, axis=0), axis=1)
        after = np.concatenate([np.cumsum(seg[::-1])[::-1], [0.0]])  # (K,) route length after waypoint j
        self.waypoints = full[:lookahead]  #: (J, 2) the active waypoint and the next ones
        self.after = after[:lookahead]  #: (J,)
        self.goal = full[-1]
        self.switch_radius = switch_radius
        self.goal_tolerance = goal_tolerance

    def __call__(self, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Potential (B, T) [m] and the active waypoint (B, T, 2) along rollouts ``pts`` (B, T, 2).

        Zero from the first step inside the goal tolerance on (the episode ends there, whichever
        waypoint is active, as in the simulator).
        """
        d = np.linalg.norm(pts[:, :, None, :] - self.waypoints, axis=-1)  # (B, T, J)
        idx = np.zeros(pts.shape[:2], dtype=np.int64)
        reached = np.ones(pts.shape[:2], dtype=bool)
        for j in range(len(self.waypoints) - 1):
            reached = np.logical_or.accumulate(reached & (d[..., j] <= self.switch_radius), axis=1)
            idx += reached
        dj = np.take_along_axis(d, idx[..., None], axis=-1)[..., 0]
        d_goal = np.linalg.norm(pts - self.goal, axis=-1)
        done = np.logical_or.accumulate(d_goal <= self.goal_tolerance, axis=1)
        phi = np.where(done, 0.0, dj + self.after[idx])
        return phi, self.waypoints[idx]

    def start(self, p0: np.ndarray) -> float:
        """Potential at the current position (the active waypoint is the observation's)."""
        return float(self(np.asarray(p0, dtype=float).reshape(1, 1, 2))[0][0, 0])


class StaticClearance:
    """Distance [m] to the nearest obstacle edge or map bound; points outside the map get -1.

    ``resolution`` > 0 tabulates ``static.distance`` once per map on a grid and interpolates
    bilinearly, subtracting the interpolation error bound (resolution / sqrt 2, the distance is
    1-Lipschitz) so the estimate never exceeds the true distance; 0 queries ``static.distance``
    directly on every rolled-out point.
    """

    def __init__(self, static: StaticGeometry, resolution: float):
        self.static = static
        self.width, self.height = float(static.width), float(static.height)
        self.resolution = resolution
        if resolution > 0:
            nx = int(np.ceil(self.width / resolution)) + 1
            ny = int(np.ceil(self.height / resolution)) + 1
            gx, gy = np.meshgrid(np.arange(nx) * resolution, np.arange(ny) * resolution, indexing="ij")
            self.field = np.asarray(static.distance(np.stack([gx, gy], axis=-1)), dtype=float)  # (nx, ny)
            self.bound = resolution / np.sqrt(2.0)

    def __call__(self, pts: np.ndarray) -> np.ndarray:
        x, y = pts[..., 0], pts[..., 1]
        outside = (x < 0) | (x > self.width) | (y < 0) | (y > self.height)
        if self.resolution <= 0:
            d = np.asarray(self.static.distance(pts), dtype=float)
        else:
            d = self._interpolate(x, y) - self.bound
        return np.where(outside, -1.0, d)

    def _interpolate(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        f = self.field
        gx = np.clip(x / self.resolution, 0, f.shape[0] - 1.000001)
        gy = np.clip(y / self.resolution, 0, f.shape[1] - 1.000001)
        i, j = gx.astype(np.int64), gy.astype(np.int64)
        ax, ay = gx - i, gy - j
        return ((f[i, j] * (1 - ax) + f[i + 1, j] * ax) * (1 - ay)
                + (f[i, j + 1] * (1 - ax) + f[i + 1, j + 1] * ax) * ay)


@dataclass(frozen=True)
class Scene:
    """Everything one decision's costs need besides the rollouts."""

    ped_future: np.ndarray  #: (N, K, 2) forecast positions at ``times`` [m] (relevant peds only)
    times: np.ndarray  #: (K,) seconds ahead [s]
    contact: float  #: centre distance of contact: robot radius + ped radius + extra margins [m]
    robot_radius: float  #: true robot radius [m] (static clearance)
    route: RoutePotential
    static: StaticClearance
    start: np.ndarray  #: (3,) x, y, heading now
    prev_command: np.ndarray  #: (2,) last command (v, omega)
    max_speed: float
    max_turn_rate: float


@dataclass(frozen=True)
class Rollouts:
    """Rolled-out robot states for B candidate sequences."""

    states: np.ndarray  #: (B, S, 5) x, y, heading, v, omega after each simulator step
    eval_index: np.ndarray  #: (K,) simulator step index of each forecast time
    commands: np.ndarray  #: (B, S, 2) commanded (v, omega) per simulator step


def pedestrian_terms(pos: np.ndarray, speed: np.ndarray, scene: Scene, cfg: PredictivePlannerConfig) -> dict[str, np.ndarray]:
    """Collision, near-miss, TTC and clearance terms, each (B,), from robot positions (B, K, 2) at forecast times."""
    B = pos.shape[0]
    s = cfg.safety
    if scene.ped_future.shape[0] == 0:
        z = np.zeros(B)
        return {"collision": z, "near_miss": z, "ttc": z, "hard_clearance": z, "min_clearance": np.full(B, np.inf)}
    diff = pos[:, None, :, :] - scene.ped_future[None]  # (B, N, K, 2)
    clear = np.sqrt(diff[..., 0] ** 2 + diff[..., 1] ** 2) - scene.contact  # (B, N, K)
    margin = s.collision_margin + s.margin_growth * scene.times + s.speed_clearance_gain * speed  # (B, K)
    w = s.discount ** np.arange(len(scene.times))  # (K,)
    # passive safety: a pedestrian predicted to walk into a robot standing still is discounted, because
    # pedestrians avoid a standing robot while constant-velocity forecasts cannot; without it the robot flees
    resp = s.passive_floor + (1.0 - s.passive_floor) * np.minimum(1.0, speed / s.passive_speed)  # (B, K)
    m, wk = margin[:, None, :], (resp * w)[:, None, :]
    collision = (np.maximum(0.0, m - clear) * wk).sum(axis=(1, 2))
    near = (np.maximum(0.0, m + s.near_distance - clear) * wk).sum(axis=(1, 2))
    ttc = (np.maximum(0.0, m + s.ttc_distance - clear) * (resp / scene.times)[:, None, :]).sum(axis=(1, 2))
    hard = (np.maximum(0.0, s.hard_clearance_distance - clear) * resp[:, None, :]).max(axis=(1, 2))
    return {"collision": collision, "near_miss": near, "ttc": ttc, "hard_clearance": hard,
            "min_clearance": clear.min(axis=(1, 2))}


def evaluate(roll: Rollouts, scene: Scene, cfg: PredictivePlannerConfig) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Total cost (B,) and every term (B,) for the rollouts; ``progress`` is in metres (counted negatively)."""
    s, wt = cfg.safety, cfg.weights
    st = roll.states
    ev = st[:, roll.eval_index]  # (B, K, 5)
    terms = pedestrian_terms(ev[..., :2], np.abs(ev[..., 3]), scene, cfg)
    phi, target = scene.route(st[..., :2])
    progress = scene.route.start(scene.start[:2]) - phi[:, -1]
    min_c = terms.pop("min_clearance")
    terms["progress"] = progress
    terms["progress_risk"] = np.maximum(0.0, progress) * np.maximum(0.0, s.progress_risk_distance - min_c)
    sc = scene.static(st[..., :2]) - scene.robot_radius  # (B, S)
    terms["static_collision"] = (sc < s.static_margin).sum(axis=1).astype(float)
    terms["static"] = np.maximum(0.0, s.static_margin + s.static_soft_distance - sc).mean(axis=1)
    cmd = roll.commands
    terms["velocity"] = np.abs(cmd[..., 0]).mean(axis=1) / scene.max_speed
    terms["turn"] = np.abs(cmd[..., 1]).mean(axis=1) / scene.max_turn_rate
    dv = (cmd[:, 0] - scene.prev_command) / np.array([scene.max_speed, scene.max_turn_rate])
    terms["smoothness"] = np.abs(dv).sum(axis=1)
    end = st[:, -1]
    bearing = np.arctan2(target[:, -1, 1] - end[:, 1], target[:, -1, 0] - end[:, 0])
    terms["heading"] = np.abs(np.angle(np.exp(1j * (bearing - end[:, 2])))) / np.pi
    total = (
        -wt.goal * terms["progress"] + wt.collision * terms["collision"] + wt.near_miss * terms["near_miss"]
        + wt.ttc * terms["ttc"] + wt.progress_risk * terms["progress_risk"]
        + wt.hard_clearance * terms["hard_clearance"] + wt.static * terms["static"]
        + wt.static_collision * terms["static_collision"] + wt.velocity * terms["velocity"]
        + wt.turn * terms["turn"] + wt.smoothness * terms["smoothness"] + wt.heading * terms["heading"]
    )
    return total, terms
