"""Candidate commands sampled directly in (v [m/s], omega [rad/s]).

The reference sampled heading deltas and divided by its 0.2 s rollout step, so nearly every delta
saturated at the turn-rate limit and the "lattice" held three turn rates. Sampling omega itself
gives as many distinct turn rates as asked for; the near field (a pedestrian predicted within
``near_field.distance`` of contact) adds finer turn rates and slow speeds, because that is where a
small steering difference decides between a near miss and a collision.
"""

from __future__ import annotations

import numpy as np

from foresight.core.planners.predictive.config import SamplingConfig, SearchConfig
from foresight.core.sim.robot import RobotLimits


def turn_rate_grid(count: int, max_turn_rate: float, extra: tuple[float, ...] = ()) -> np.ndarray:
    """``count`` evenly spaced turn rates over [-w_max, w_max] (0 included for odd counts) plus ``extra``, clipped, unique."""
    grid = np.linspace(-max_turn_rate, max_turn_rate, count)
    rates = np.concatenate([grid, np.clip(np.asarray(extra, dtype=float), -max_turn_rate, max_turn_rate)])
    return np.unique(np.round(rates, 6))


def _product(speeds: np.ndarray, rates: np.ndarray) -> np.ndarray:
    v, w = np.meshgrid(np.unique(np.round(speeds, 6)), rates, indexing="ij")
    return np.stack([v.ravel(), w.ravel()], axis=1)


def first_candidates(
    cfg: SamplingConfig, limits: RobotLimits, speed_ratio: float, near_field: bool
) -> np.ndarray:
    """(C, 2) first-segment commands, sorted by (v, omega); always contains the braking command (0, 0).

    ``speed_ratio`` caps every speed (the config's max_speed_ratio); inside the near field the cap
    is also ``near_field.speed_cap`` and the slow speeds and finer turn rates are added.
    """
    cap = min(speed_ratio, cfg.near_field.speed_cap) if near_field else speed_ratio
    ratios = list(cfg.speed_ratios) + (list(cfg.near_field.speed_ratios) if near_field else [])
    speeds = np.minimum(np.asarray(ratios, dtype=float), cap) * limits.v_max
    rates = turn_rate_grid(cfg.turn_rate_count, limits.w_max, cfg.turn_rates)
    if near_field:
        near = turn_rate_grid(cfg.near_field.turn_rate_count, limits.w_max, cfg.near_field.turn_rates)
        rates = np.unique(np.concatenate([rates, near]))
    speeds = np.concatenate([speeds, reverse_speeds(cfg, limits, cap)])
    cands = np.vstack([_product(speeds, rates), [[0.0, 0.0]]])
    return np.unique(cands, axis=0)


def reverse_speeds(cfg: SamplingConfig, limits: RobotLimits, speed_ratio: float) -> np.ndarray:
    """Backwards speeds [m/s] (negative) of ``cfg.reverse_speed_ratios``, capped like the forward ones; none for a
    robot that may not drive backwards (``limits.v_min`` 0)."""
    if limits.v_min >= 0:
        return np.zeros(0)
    ratios = np.minimum(np.asarray(cfg.reverse_speed_ratios, dtype=float), speed_ratio)
    return np.maximum(-ratios * limits.v_max, limits.v_min)


def branch_commands(
    cfg: SearchConfig, limits: RobotLimits, speed_ratio: float, reverse: np.ndarray | None = None
) -> np.ndarray:
    """(M, 2) commands tried for every later segment of a beam entry (a coarser set; braking included), with the
    ``reverse`` speeds [m/s] (``reverse_speeds``) too."""
    speeds = np.minimum(np.asarray(cfg.branch_speed_ratios, dtype=float), speed_ratio) * limits.v_max
    if reverse is not None:
        speeds = np.concatenate([speeds, reverse])
    count = cfg.branch_turn_rate_count
    rates = turn_rate_grid(count, limits.w_max) if count > 1 else np.zeros(1)
    cands = np.vstack([_product(speeds, rates), [[0.0, 0.0]]])
    return np.unique(cands, axis=0)


def turn_then_go(
    cfg: SamplingConfig, limits: RobotLimits, steps: int, dt: float, speed_ratio: float
) -> np.ndarray:
    """(P, steps, 2) sequences that turn in place by each of ``cfg.point_turns.angles`` [rad] at the full turn
    rate, then drive straight at each of ``cfg.point_turns.speed_ratios`` x v_max: how a robot backed into a
    corner beside a door faces it and goes in. A held (v, omega) is an arc, and an arc cannot do that."""
    rows = []
    for angle in cfg.point_turns.angles:
        turn = min(steps, max(1, int(round(abs(angle) / limits.w_max / dt))))
        for ratio in cfg.point_turns.speed_ratios:
            seq = np.zeros((steps, 2))
            seq[:turn, 1] = np.sign(angle) * limits.w_max
            seq[turn:, 0] = min(ratio, speed_ratio) * limits.v_max
            rows.append(seq)
    return np.array(rows).reshape(-1, steps, 2)


def veer_then_straight(
    cfg: SamplingConfig, limits: RobotLimits, steps: int, dt: float, speed_ratio: float
) -> np.ndarray:
    """(P, steps, 2) sequences that drive at each of ``cfg.veers.speed_ratios`` x v_max turning at each of
    ``cfg.veers.turn_rates`` x w_max for each of ``cfg.veers.durations_s``, then straight on at that speed: how a
    robot pulls out to pass slower walkers. Held to the horizon the same turn is a circle, which never enters the
    beam."""
    rows = []
    for duration in cfg.veers.durations_s:
        turn = min(steps, max(1, int(round(duration / dt))))
        for rate in cfg.veers.turn_rates:
            for ratio in cfg.veers.speed_ratios:
                seq = np.zeros((steps, 2))
                seq[:, 0] = min(ratio, speed_ratio) * limits.v_max
                seq[:turn, 1] = rate * limits.w_max
                rows.append(seq)
    return np.array(rows).reshape(-1, steps, 2)


def velocity_grid(speeds: np.ndarray, count: int) -> np.ndarray:
    """(C, 2) velocities (vx, vy) in the robot's frame (x ahead): each speed in ``count`` directions evenly around,
    the first straight ahead, plus standing still; unique."""
    angles = 2 * np.pi * np.arange(count) / count
    speeds = np.unique(np.round(speeds[speeds > 0], 6))
    v = speeds[:, None, None] * np.stack([np.cos(angles), np.sin(angles)], axis=-1)[None]  # (S, count, 2)
    return np.unique(np.round(np.vstack([v.reshape(-1, 2), [[0.0, 0.0]]]), 9), axis=0)


def holonomic_candidates(
    cfg: SamplingConfig, limits: RobotLimits, speed_ratio: float, near_field: bool
) -> np.ndarray:
    """A holonomic robot's first-segment commands: velocities in its frame (``velocity_grid``), speeds as
    ``first_candidates`` chooses them, directions ``direction_count`` (near field:
    ``near_field.direction_count``)."""
    cap = min(speed_ratio, cfg.near_field.speed_cap) if near_field else speed_ratio
    ratios = list(cfg.speed_ratios) + (list(cfg.near_field.speed_ratios) if near_field else [])
    speeds = np.minimum(np.asarray(ratios, dtype=float), cap) * limits.v_max
    return velocity_grid(speeds, cfg.near_field.direction_count if near_field else cfg.direction_count)


def holonomic_branches(cfg: SearchConfig, limits: RobotLimits, speed_ratio: float) -> np.ndarray:
    """A holonomic robot's later-segment commands: ``branch_speed_ratios`` x ``branch_direction_count`` velocities."""
    speeds = np.minimum(np.asarray(cfg.branch_speed_ratios, dtype=float), speed_ratio) * limits.v_max
    return velocity_grid(speeds, cfg.branch_direction_count)
