"""One decision's scene: the forecast with the crowd assumptions (``crowd``) applied, culled to what matters.

The forecast is extended past its horizon (``search.extra_horizon_s``), people lingering by the robot are held
where they are, and after a long enough stall those taken to wait for the robot are trusted to stand and step
back (``COMMIT_ASSERTIVENESS``); pedestrians no rollout can bring within any cost term's range are dropped.
"""

from __future__ import annotations

import numpy as np

from foresight.core.planners.predictive import cost as C
from foresight.core.planners.predictive.config import PredictivePlannerConfig
from foresight.core.planners.predictive.crowd import COMMIT_ASSERTIVENESS, COMMIT_SIGMA, CrowdAssumptions
from foresight.core.planners.predictive.rollout import extend_forecast
from foresight.core.planners.predictive.traffic import TrafficMap
from foresight.core.sim.observation import Observation
from foresight.core.sim.robot import RobotLimits

NO_LINES = np.zeros(0, dtype=np.int64)  #: no pedestrian held to a straight line


def contact_distance(obs: Observation, cfg: PredictivePlannerConfig) -> float:
    """Centre distance of contact [m]: humans of different sizes count as the largest present (the cost has one
    contact distance), plus the extra margins."""
    ped_r = obs.ped_radius
    if obs.ped_radii is not None and len(obs.ped_radii):
        ped_r = max(ped_r, float(obs.ped_radii.max()))
    margins = cfg.safety.pedestrians
    return obs.robot_radius + ped_r + margins.extra_robot_margin + margins.extra_ped_margin


def crowd_scene(
    cfg: PredictivePlannerConfig,
    limits: RobotLimits,
    crowd: CrowdAssumptions,
    obs: Observation,
    forecast: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray | None],
    route: C.RoutePotential,
    static: C.StaticClearance,
    prev_command: np.ndarray,
    traffic: TrafficMap | None,
) -> tuple[C.Scene, bool, int]:
    """The scene, whether the robot is in the near field and how many forecast steps were added past the horizon.

    ``forecast`` is (positions, sigma, times, ids, weights): rows of positions are pedestrians, or modes of them
    with ``weights`` (R,)."""
    positions, sigma, times, fc_ids, weights = forecast
    p0 = obs.robot_pose[:2]
    phi0 = route.start(p0)
    assertive = crowd.stall(phi0, obs.time, obs.dt)
    contact = contact_distance(obs, cfg)
    times = np.asarray(times, dtype=float)
    fut = np.asarray(positions, dtype=float).reshape(-1, len(times), 2)
    sigma = np.asarray(sigma, dtype=float).reshape(-1, len(times))
    # ufunc reductions: ndarray.sum/min without their Python wrappers (the same reductions)
    dist = np.sqrt(np.sum((fut - p0) ** 2, axis=-1))  # (N, K) to the robot's current position
    near = bool(dist.size) and float(np.min(dist, axis=None)) - contact <= cfg.sampling.near_field.distance
    dt_f = float(times[1] - times[0]) if len(times) > 1 else float(times[0])
    extra_s = cfg.search.extra_horizon_s + (
        cfg.search.horizon_boost_s if cfg.search.adaptive_horizon and near else 0.0
    )
    extra = int(round(extra_s / dt_f))
    speed = abs(float(obs.robot_velocity[0]))  # a robot that may back off drives backwards at negative v
    room = crowd.waiting_room(fut, times, assertive) + crowd.receding_room(fut, times, p0, speed)
    waiting = crowd.waits(obs, fc_ids, contact)
    yielding = np.zeros(len(fut))
    lingering = crowd.lingers(obs, fc_ids, contact)
    if (
        lingering.any()
    ):  # lingered by the robot for a while: not making room for it, whatever the model expects
        row = np.argmax(fc_ids[lingering, None] == obs.ped_ids[None, :], axis=1)
        fut = fut.copy()
        fut[lingering] = (
            obs.ped_positions[row, None, :] + times[None, :, None] * obs.ped_velocities[row, None, :]
        )
    if assertive >= COMMIT_ASSERTIVENESS and waiting.any():  # yielded long enough: commit (see WaitsForRobot)
        fut, sigma = fut.copy(), sigma.copy()
        fut[waiting], sigma[waiting] = fut[waiting, :1], np.minimum(sigma[waiting, :1], COMMIT_SIGMA)
        yielding[waiting] = cfg.safety.crowd.yielding.speed
    fut, sigma, times = extend_forecast(fut, sigma, times, extra)
    straight = crowd.walks_straight(obs, fc_ids, times, p0, speed)
    if len(fut):  # exact culling: pedestrians no rollout can bring within any term's range
        if extra:
            dist = np.sqrt(np.sum((fut - p0) ** 2, axis=-1))
        if straight is not None:  # either way a pedestrian may walk counts
            mask, lines = straight
            dist[mask] = np.minimum(dist[mask], np.sqrt(np.sum((lines - p0) ** 2, axis=-1)))
        gap = dist - contact - reach(speed, limits, times)
        keep = gap.min(axis=1) <= C.influence_range(cfg, float(times[-1]), limits.v_max, float(sigma.max()))
        fut, sigma, room, yielding = fut[keep], sigma[keep], room[keep], yielding[keep]
        if weights is not None:
            weights = weights[keep]
        if straight is not None:
            straight = np.flatnonzero(mask[keep]), lines[keep[mask]]
    line_ids, lines = straight or (NO_LINES, np.zeros((0, len(times), 2)))
    scene = C.Scene(
        ped_future=fut,
        ped_sigma=sigma,
        ped_room=room,
        ped_yield=yielding,
        ped_straight=line_ids,
        ped_lines=lines,
        times=times,
        contact=contact,
        robot_radius=obs.robot_radius,
        route=route,
        phi0=phi0,
        assertiveness=assertive,
        static=static,
        start=np.asarray(obs.robot_pose, dtype=float),
        prev_command=prev_command,
        max_speed=limits.v_max,
        max_turn_rate=limits.w_max,
        traffic=traffic,
        ped_weight=weights,
    )
    return scene, near, extra


def reach(v0: float, limits: RobotLimits, times: np.ndarray) -> np.ndarray:
    """Farthest the robot can travel [m] by each time (K,) from speed v0 >= 0 (a magnitude, either way) under its
    acceleration and speed limits (a robot that may drive backwards speeds up backwards at its braking rate)."""
    rate = limits.accel if limits.v_min >= 0 else max(limits.accel, limits.decel)
    top = max(limits.v_max, -limits.v_min)
    t_acc = max(0.0, top - v0) / rate
    ta = np.minimum(times, t_acc)
    return v0 * ta + 0.5 * rate * ta**2 + top * np.maximum(0.0, times - t_acc)
