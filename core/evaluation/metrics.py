"""Per-episode metrics computed from a simulator trace (definitions: shared metrics-and-taxonomy.md).

Everything is derived from the trace's per-step arrays (robot state, commands, pedestrian slots), so the
same numbers come out whether the trace was recorded live or rebuilt by hand in a test. Units: metres,
seconds, radians. Distances to pedestrians use the true collision radii; "clearance" is the surface gap
(centre distance - robot radius - pedestrian radius).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from foresight.core.sim.observation import StaticGeometry
from foresight.core.sim.robot import RobotLimits


class TraceLike(Protocol):
    """The parts of ``core.sim.trace.Trace`` the metrics read (see docs/architecture.md)."""

    robot: np.ndarray  #: (T+1, 5) x, y, heading, v, omega
    command: np.ndarray  #: (T, 2) v, omega commanded
    ped_ids: np.ndarray  #: (T+1, N) int, -1 = empty slot
    ped_pos: np.ndarray  #: (T+1, N, 2)
    ped_vel: np.ndarray  #: (T+1, N, 2)
    dt: float


class MetricsConfig(BaseModel):
    """Thresholds of the continuous metrics (reported with every evaluation)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    near_miss_clearance: float = Field(default=0.5, gt=0)  #: near miss: clearance in [0, this) [m]
    intimate_clearance: float = Field(
        default=0.45, gt=0
    )  #: intimate-space intrusion below this clearance [m]
    personal_clearance: float = Field(default=1.2, gt=0)  #: personal-space intrusion below this clearance [m]
    stalled_speed: float = Field(default=0.05, ge=0)  #: "nearly stopped" below this speed [m/s]
    progress_window_s: float = Field(default=1.5, gt=0)  #: failure-to-progress window [s]
    progress_min: float = Field(
        default=0.05, ge=0
    )  #: route progress at most this over the window = no progress [m]


@dataclass(frozen=True)
class EpisodeGeometry:
    """What the metrics need from the scenario besides the trace."""

    robot_radius: float  #: [m]
    ped_radius: float  #: [m]
    horizon: int  #: max_episode_steps
    route: np.ndarray  #: (K, 2) robot route waypoints, goal last [m]
    goal_tolerance: float = 0.0  #: [m]
    limits: RobotLimits = RobotLimits()  #: the robot's dynamics (the taxonomy's escape check)
    static: StaticGeometry | None = None  #: the map's obstacles and bounds, when known (escape check)
    #: CrowdNav's social metrics, where the scenario defines them: discomfort below this clearance [m], and
    #: intrusion = the robot inside the contact distance of where a pedestrian will be within ``intrusion_steps``
    discomfort_clearance: float | None = None
    intrusion_steps: int = 0


@dataclass(frozen=True)
class Derived:
    """Per-state arrays (index 0..T) shared by the metrics and the taxonomy."""

    steps: int
    dt: float
    robot: np.ndarray  #: (T+1, 5) the trace's robot states x, y, heading, v, omega
    pos: np.ndarray  #: (T+1, 2)
    speed: np.ndarray  #: (T+1,) |v| state [m/s]
    omega: np.ndarray  #: (T+1,) [rad/s]
    vel: np.ndarray  #: (T+1, 2) robot velocity in the world frame [m/s]
    dist: np.ndarray  #: (T+1, N) centre distance per slot, inf for empty slots [m]
    nearest: np.ndarray  #: (T+1,) min centre distance, inf without pedestrians [m]
    clearance: np.ndarray  #: (T+1,) nearest - radii [m]
    ttc: np.ndarray  #: (T+1,) min time to collision under constant velocity, inf when none [s]
    progress: np.ndarray  #: (T+1,) arc length along the route of the projected position [m]
    ped_ids: np.ndarray  #: (T+1, N)
    ped_pos: np.ndarray  #: (T+1, N, 2)
    ped_vel: np.ndarray  #: (T+1, N, 2)


class Safety(BaseModel):
    min_distance: float | None  #: closest centre distance to any pedestrian [m]; None without pedestrians
    min_clearance: float | None  #: closest surface gap [m]
    mean_clearance: float | None  #: mean over steps of the per-step closest gap [m]
    near_misses: int  #: steps with clearance in [0, near_miss_clearance)
    min_ttc: float | None  #: [s]; None when never on a collision course
    intimate_intrusions: int  #: steps with clearance < intimate_clearance
    personal_intrusions: int  #: steps with clearance < personal_clearance
    first_collision_step: int | None = None
    #: CrowdNav scenarios: steps with clearance below its discomfort distance; steps the robot stood where a
    #: pedestrian will be within the intrusion horizon (CrowdNav++'s intrusion); None elsewhere
    discomfort_steps: int | None = None
    intrusion_steps: int | None = None


class Efficiency(BaseModel):
    path_length: float  #: [m]
    path_efficiency: float | None  #: min(1, shortest route / travelled) for successes
    avg_speed: float  #: path length / duration [m/s]
    stalled_time_s: float  #: time with |v| < stalled_speed [s]
    no_progress_steps: int  #: steps whose trailing window made <= progress_min route progress


class Smoothness(BaseModel):
    accel_mean: float  #: mean |dv/dt| [m/s^2]
    accel_max: float
    jerk_mean: float  #: mean |d^2v/dt^2| [m/s^3]
    jerk_max: float
    omega_change_mean: float  #: mean |d omega/dt| [rad/s^2]
    omega_sign_changes: int  #: sign flips of omega where |omega| > 0.2 rad/s


def n_steps(trace: Any) -> int:
    """Steps actually taken (the trace may be preallocated beyond the end)."""
    steps = getattr(trace, "steps", None)
    if isinstance(steps, (int, np.integer)):
        return int(steps)
    return int(np.asarray(trace.command).shape[0])


def time_to_collision(rel_pos: np.ndarray, rel_vel: np.ndarray, radius: float) -> np.ndarray:
    """Constant-velocity time until the centre distance reaches ``radius`` (0 if overlapping, inf if never).

    ``rel_pos``/``rel_vel``: other minus robot, shape (..., 2).
    """
    a = np.einsum("...i,...i->...", rel_vel, rel_vel)
    b = 2.0 * np.einsum("...i,...i->...", rel_pos, rel_vel)
    c = np.einsum("...i,...i->...", rel_pos, rel_pos) - radius * radius
    disc = b * b - 4.0 * a * c
    ok = (a > 1e-12) & (b < 0) & (disc >= 0)
    with np.errstate(invalid="ignore", divide="ignore"):
        tau = (-b - np.sqrt(np.where(ok, disc, 0.0))) / np.where(ok, 2.0 * a, 1.0)
    out = np.where(ok, np.maximum(tau, 0.0), np.inf)
    return np.where(c <= 0, 0.0, out)


def route_progress(pos: np.ndarray, route: np.ndarray) -> np.ndarray:
    """Arc length [m] along the polyline ``route`` (start first) of each position's closest point."""
    route = np.asarray(route, dtype=float).reshape(-1, 2)
    if route.shape[0] < 2:
        goal = route[-1]
        d = np.linalg.norm(pos - goal, axis=1)
        return d[0] - d
    a, b = route[:-1], route[1:]
    seg = b - a
    seg_len = np.linalg.norm(seg, axis=1)
    cum = np.concatenate([[0.0], np.cumsum(seg_len)])[:-1]
    rel = pos[:, None, :] - a[None, :, :]
    t = np.clip(np.einsum("tsi,si->ts", rel, seg) / np.maximum(seg_len**2, 1e-12), 0.0, 1.0)
    closest = a[None] + t[..., None] * seg[None]
    d = np.linalg.norm(pos[:, None, :] - closest, axis=2)
    best = np.argmin(d, axis=1)
    rows = np.arange(pos.shape[0])
    return cum[best] + t[rows, best] * seg_len[best]


def _full_route(start: np.ndarray, route: np.ndarray) -> np.ndarray:
    route = np.asarray(route, dtype=float).reshape(-1, 2)
    if route.size == 0:
        return start[None]
    if np.linalg.norm(route[0] - start) < 1e-9:
        return route
    return np.vstack([start[None], route])


def derive(trace: TraceLike, geom: EpisodeGeometry) -> Derived:
    """Per-state arrays of an episode: robot motion, distances, clearance, TTC and route progress."""
    T = n_steps(trace)
    robot = np.asarray(trace.robot, dtype=float)[: T + 1]
    ids = np.asarray(trace.ped_ids)[: T + 1]
    ped_pos = np.asarray(trace.ped_pos, dtype=float)[: T + 1]
    ped_vel = np.asarray(trace.ped_vel, dtype=float)[: T + 1]
    pos = robot[:, :2]
    heading, v = robot[:, 2], robot[:, 3]
    vel = np.stack([v * np.cos(heading), v * np.sin(heading)], axis=1)
    valid = ids >= 0
    radius = geom.robot_radius + geom.ped_radius
    rel = ped_pos - pos[:, None, :]
    dist = np.where(valid, np.linalg.norm(rel, axis=2), np.inf)
    ttc = np.where(valid, time_to_collision(rel, ped_vel - vel[:, None, :], radius), np.inf)
    nearest = dist.min(axis=1) if dist.shape[1] else np.full(T + 1, np.inf)
    return Derived(
        steps=T,
        dt=float(trace.dt),
        robot=robot,
        pos=pos,
        speed=np.abs(v),
        omega=robot[:, 4],
        vel=vel,
        dist=dist,
        nearest=nearest,
        clearance=nearest - radius,
        ttc=ttc.min(axis=1) if ttc.shape[1] else np.full(T + 1, np.inf),
        progress=route_progress(pos, _full_route(pos[0], geom.route)),
        ped_ids=ids,
        ped_pos=ped_pos,
        ped_vel=ped_vel,
    )


def _finite_or_none(x: float) -> float | None:
    return float(x) if np.isfinite(x) else None


def safety(d: Derived, cfg: MetricsConfig, first_collision_step: int | None = None) -> Safety:
    has_peds = bool(np.isfinite(d.nearest).any())
    clr = d.clearance[np.isfinite(d.clearance)]
    return Safety(
        min_distance=float(d.nearest.min()) if has_peds else None,
        min_clearance=float(clr.min()) if has_peds else None,
        mean_clearance=float(clr.mean()) if has_peds else None,
        near_misses=int(((d.clearance >= 0) & (d.clearance < cfg.near_miss_clearance)).sum()),
        min_ttc=_finite_or_none(d.ttc.min()),
        intimate_intrusions=int((d.clearance < cfg.intimate_clearance).sum()),
        personal_intrusions=int((d.clearance < cfg.personal_clearance).sum()),
        first_collision_step=first_collision_step,
    )


def social_steps(d: Derived, geom: EpisodeGeometry) -> dict[str, int | None]:
    """``Safety.discomfort_steps`` and ``intrusion_steps`` of an episode (None where the scenario defines none).

    Both count the states after each step (1..T). Intrusion at state t: some pedestrian slot, the same id, at
    t + 1 .. t + ``intrusion_steps`` within robot radius + pedestrian radius of the robot's position at t (CrowdNav++
    uses the humans' true future, which the trace holds where nobody reacts to the robot).
    """
    if geom.discomfort_clearance is None:
        return {"discomfort_steps": None, "intrusion_steps": None}
    discomfort = int((d.clearance[1:] < geom.discomfort_clearance).sum())
    contact = geom.robot_radius + geom.ped_radius
    T, hit = d.steps, np.zeros(d.steps + 1, dtype=bool)
    for k in range(1, geom.intrusion_steps + 1):
        if k > T:
            break
        same = (d.ped_ids[k:] == d.ped_ids[:-k]) & (d.ped_ids[k:] >= 0)  # (T+1-k, N)
        gap = np.linalg.norm(d.ped_pos[k:] - d.pos[:-k, None, :], axis=2)
        hit[:-k] |= (same & (gap < contact)).any(axis=1)
    return {"discomfort_steps": discomfort, "intrusion_steps": int(hit[1:].sum())}


def window_steps(seconds: float, dt: float) -> int:
    return max(1, int(round(seconds / dt)))


def no_progress_mask(d: Derived, window_s: float, progress_min: float) -> np.ndarray:
    """(T+1,) True at states whose trailing ``window_s`` made at most ``progress_min`` route progress."""
    w = window_steps(window_s, d.dt)
    mask = np.zeros(d.steps + 1, dtype=bool)
    if d.steps >= w:
        mask[w:] = (d.progress[w:] - d.progress[:-w]) <= progress_min
    return mask


def efficiency(d: Derived, geom: EpisodeGeometry, cfg: MetricsConfig, success: bool) -> Efficiency:
    length = float(np.linalg.norm(np.diff(d.pos, axis=0), axis=1).sum())
    duration = d.steps * d.dt
    path_eff = None
    if success and length > 1e-9:
        full = _full_route(d.pos[0], geom.route)
        shortest = float(np.linalg.norm(np.diff(full, axis=0), axis=1).sum()) - geom.goal_tolerance
        path_eff = float(min(1.0, max(shortest, 0.0) / length))
    return Efficiency(
        path_length=length,
        path_efficiency=path_eff,
        avg_speed=length / duration if duration > 0 else 0.0,
        stalled_time_s=float((d.speed[1:] < cfg.stalled_speed).sum() * d.dt),
        no_progress_steps=int(no_progress_mask(d, cfg.progress_window_s, cfg.progress_min).sum()),
    )


def sign_change_steps(omega: np.ndarray, min_abs: float) -> np.ndarray:
    """State indices where omega's sign differs from the previous sample with |omega| > min_abs."""
    idx = np.flatnonzero(np.abs(omega) > min_abs)
    if idx.size < 2:
        return np.zeros(0, dtype=int)
    signs = np.sign(omega[idx])
    return idx[1:][signs[1:] != signs[:-1]]


def smoothness(d: Derived, omega_min_abs: float = 0.2) -> Smoothness:
    v = d.speed
    acc = np.abs(np.diff(v)) / d.dt
    jerk = np.abs(np.diff(v, n=2)) / (d.dt**2) if v.size > 2 else np.zeros(0)
    dw = np.abs(np.diff(d.omega)) / d.dt

    def stat(x: np.ndarray, f: Any) -> float:
        return float(f(x)) if x.size else 0.0

    return Smoothness(
        accel_mean=stat(acc, np.mean),
        accel_max=stat(acc, np.max),
        jerk_mean=stat(jerk, np.mean),
        jerk_max=stat(jerk, np.max),
        omega_change_mean=stat(dw, np.mean),
        omega_sign_changes=int(sign_change_steps(d.omega, omega_min_abs).size),
    )


def timing_summary(plan_ms: list[float] | np.ndarray) -> dict[str, float | None]:
    """Planner decision time per step [ms]: mean, p95, max (None without decisions)."""
    arr = np.asarray(plan_ms, dtype=float)
    if arr.size == 0:
        return {"plan_ms_mean": None, "plan_ms_p95": None, "plan_ms_max": None}
    return {
        "plan_ms_mean": float(arr.mean()),
        "plan_ms_p95": float(np.percentile(arr, 95)),
        "plan_ms_max": float(arr.max()),
    }
