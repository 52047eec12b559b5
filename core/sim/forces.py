"""The social-force terms of the pedestrian model, one function per term (reference §1.2).

Each term maps state arrays and ``ForceParams`` to an (N, 2) acceleration [m/s^2]; the crowd sums
them and integrates once. Pairwise terms take explicit ordered pair lists (i, j) so that the same
kernel serves all-pairs (small crowds) and a cell list (large crowds, see ``core.sim.neighbours``).
"""

from __future__ import annotations

import numpy as np

from core.sim.geometry import SegmentSet
from core.sim.params import ForceParams


def _unit(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit vectors (..., 2) and lengths (...); zero vectors stay zero (the reference's convention)."""
    n = np.sqrt(v[..., 0] ** 2 + v[..., 1] ** 2)
    safe = np.where(n > 0, n, 1.0)
    return v / safe[..., None], n


def _accumulate(idx: np.ndarray, f: np.ndarray, n: int) -> np.ndarray:
    """Sum pair forces f (P, 2) onto their first index idx (P,), giving (n, 2)."""
    out = np.empty((n, 2))
    out[:, 0] = np.bincount(idx, weights=f[:, 0], minlength=n)
    out[:, 1] = np.bincount(idx, weights=f[:, 1], minlength=n)
    return out


def desired_force(pos: np.ndarray, vel: np.ndarray, goal: np.ndarray, vmax: np.ndarray, p: ForceParams) -> np.ndarray:
    """Relax towards vmax along the goal direction; inside ``goal_threshold`` only brake."""
    e, d = _unit(goal - pos)
    far = (d > p.goal_threshold)[:, None]
    target = np.where(far, vmax[:, None] * e, 0.0)
    return p.desired_factor * (target - vel) / p.relaxation_time


def social_force(
    pos: np.ndarray, vel: np.ndarray, i: np.ndarray, j: np.ndarray, p: ForceParams, cutoff: float
) -> np.ndarray:
    """Moussaid ped-ped force summed over ordered pairs (i, j), i != j, with centre distance <= cutoff.

    Reproduces the reference kernel including its unwrapped angle difference theta (unless
    ``social_wrap_theta``), so a neighbour whose interaction direction straddles the +-pi cut is
    nearly ignored, as in robot_sf.
    """
    n = len(pos)
    if len(i) == 0:
        return np.zeros((n, 2))
    r = pos[i] - pos[j]
    e, d = _unit(r)
    w = p.social_lambda * (vel[j] - vel[i]) + e
    t, w_norm = _unit(w)
    b = p.social_gamma * w_norm + 1e-8
    theta = np.arctan2(t[:, 1], t[:, 0]) - np.arctan2(e[:, 1], e[:, 0])
    if p.social_wrap_theta:
        theta = (theta + np.pi) % (2 * np.pi) - np.pi
    base = -d / b
    bt = b * theta
    decel = np.exp(base - (p.social_n_prime * bt) ** 2)
    side = np.exp(base - (p.social_n * bt) ** 2) * np.where(theta >= 0, -1.0, 1.0)
    side = np.where(d <= cutoff, side, 0.0)
    decel = np.where(d <= cutoff, decel, 0.0)
    f = np.empty_like(r)
    f[:, 0] = decel * t[:, 0] - side * t[:, 1]
    f[:, 1] = decel * t[:, 1] + side * t[:, 0]
    return p.social_factor * _accumulate(i, f, n)


def obstacle_force_from_offsets(off: np.ndarray, dist: np.ndarray, p: ForceParams) -> np.ndarray:
    """Obstacle force from precomputed offsets (N, S, 2) and distances (N, S): sum of factor (x - c) / s^4."""
    s = np.maximum(dist - p.obstacle_offset, 1e-5)
    k = p.obstacle_factor / s**4
    return np.einsum("ns,nsk->nk", k, off)


def obstacle_force(pos: np.ndarray, walls: SegmentSet, p: ForceParams) -> np.ndarray:
    """Repulsion from every segment (obstacle edges and map bounds), no distance cutoff (as the reference)."""
    if len(walls) == 0:
        return np.zeros_like(pos)
    off, dist = walls.offsets(pos)
    return obstacle_force_from_offsets(off, dist, p)


def group_coherence_force(
    pos: np.ndarray, group: np.ndarray, size: np.ndarray, p: ForceParams
) -> np.ndarray:
    """Pull each member towards its group centroid once it is farther than (n - 1) / 2 [m] (pedsim variant).

    ``group`` (N,) is each ped's group index, ``size`` (G,) the group sizes; singletons feel nothing.
    """
    g = len(size)
    cx = np.bincount(group, weights=pos[:, 0], minlength=g) / size
    cy = np.bincount(group, weights=pos[:, 1], minlength=g) / size
    u = np.stack([cx[group] - pos[:, 0], cy[group] - pos[:, 1]], axis=1)
    thr = (size[group] - 1) / 2.0
    dist = np.sqrt(u[:, 0] ** 2 + u[:, 1] ** 2)
    return p.group_coherence_factor * u * ((np.tanh(dist - thr) + 1.0) / 2.0)[:, None]


def group_repulsion_force(pos: np.ndarray, i: np.ndarray, j: np.ndarray, p: ForceParams) -> np.ndarray:
    """Push group members apart: sum of raw (x_i - x_j) over same-group pairs (i, j) closer than the range."""
    n = len(pos)
    if len(i) == 0:
        return np.zeros((n, 2))
    r = pos[i] - pos[j]
    near = (r[:, 0] ** 2 + r[:, 1] ** 2) <= p.group_repulsion_range**2
    return p.group_repulsion_factor * _accumulate(i, r * near[:, None], n)


def group_gaze_force(
    pos: np.ndarray, goal: np.ndarray, group: np.ndarray, size: np.ndarray, p: ForceParams
) -> np.ndarray:
    """Turn members towards the centroid of the others: e_i |c' - x_i| (e_i . g) / d_i (pedsim variant)."""
    g = len(size)
    sx = np.bincount(group, weights=pos[:, 0], minlength=g)
    sy = np.bincount(group, weights=pos[:, 1], minlength=g)
    others = np.maximum(size[group] - 1, 1)[:, None]
    rel = np.stack([sx[group], sy[group]], axis=1)
    rel = (rel - pos) / others - pos  # centroid of the others minus x_i
    gdir, glen = _unit(rel)
    e, d = _unit(goal - pos)
    active = (size[group] >= 2) & (d > 1e-6)
    k = np.where(active, glen * np.einsum("nk,nk->n", e, gdir) / np.where(active, d, 1.0), 0.0)
    return p.group_gaze_factor * e * k[:, None]


def robot_force(pos: np.ndarray, robot_xy: np.ndarray, robot_radius: float, p: ForceParams) -> np.ndarray:
    """Repulsion from the robot centre: factor * unit(x - x_robot) / d^3 within the hard cutoff."""
    e, d = _unit(pos - robot_xy)
    active = (d <= p.robot_cutoff(robot_radius)) & (d > 0)
    k = np.where(active, p.robot_factor / np.where(active, d, 1.0) ** 3, 0.0)
    return e * k[:, None]
