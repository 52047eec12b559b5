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
    g = goal - pos
    d = np.sqrt(g[:, 0] ** 2 + g[:, 1] ** 2)
    speed = np.where(d > p.goal_threshold, vmax / np.maximum(d, 1e-300), 0.0)  # vmax e = vmax g / d
    return (p.desired_factor / p.relaxation_time) * (g * speed[:, None] - vel)


def as_complex(xy: np.ndarray) -> np.ndarray:
    """An (N, 2) float array as (N,) complex x + iy: one array operation then handles both components."""
    xy = np.ascontiguousarray(xy, dtype=float)
    return xy.view(np.complex128)[:, 0]


def as_xy(z: np.ndarray) -> np.ndarray:
    """(N,) complex back to a new (N, 2) float array."""
    return np.ascontiguousarray(z).view(float).reshape(-1, 2).copy()


def _norm(z: np.ndarray) -> np.ndarray:
    """|z|: one hypot call for small arrays (op count dominates), sqrt(re^2 + im^2) for large ones (faster per element)."""
    if z.size <= 4096:
        return np.abs(z)
    return np.sqrt(z.real * z.real + z.imag * z.imag)


def _moussaid(r: np.ndarray, dv: np.ndarray, p: ForceParams, cutoff: float | None) -> np.ndarray:
    """Moussaid pair forces (complex) from r = x_i - x_j and dv = v_j - v_i (complex), any matching shapes.

    A pair with zero distance (including i == j on a dense grid) contributes exactly zero,
    because its interaction direction t is the zero vector. ``cutoff`` None = no pair is beyond it.
    Complex numbers keep the operation count low: each costs ~1 µs however small the crowd.
    """
    d = _norm(r)
    w = p.social_lambda * dv + r * (1.0 / np.maximum(d, 1e-300))  # e = r / d (zero for coincident peds)
    wn = _norm(w)
    t = w * (1.0 / np.maximum(wn, 1e-300))
    b = p.social_gamma * wn + 1e-8
    theta = np.arctan2(w.imag, w.real) - np.arctan2(r.imag, r.real)  # angles of t and e
    if p.social_wrap_theta:
        theta = (theta + np.pi) % (2 * np.pi) - np.pi
    base = -d / b
    if cutoff is not None:
        base = np.where(d <= cutoff, base, -np.inf)  # beyond the cutoff both exponentials vanish
    bt2 = np.square(b * theta)
    decel = np.exp(base - p.social_n_prime**2 * bt2)
    side = np.exp(base - p.social_n**2 * bt2)
    # f = decel t + (-s) side n(t), n(t) = (-t_y, t_x) = i t, s = +1 for theta >= 0
    return t * (decel + 1j * np.where(theta >= 0, -side, side))


def social_force(
    pos: np.ndarray, vel: np.ndarray, i: np.ndarray | None, j: np.ndarray | None, p: ForceParams,
    cutoff: float | None,
) -> np.ndarray:
    """Moussaid ped-ped force: factor * sum over neighbours j with centre distance <= cutoff (None: all given).

    ``i, j`` are ordered candidate pairs (i != j); None means all pairs, computed on the dense
    (N, N) grid without index gathers (faster for small crowds). Reproduces the reference kernel
    including its unwrapped angle difference theta (unless ``social_wrap_theta``), so a neighbour
    whose interaction direction straddles the +-pi cut is nearly ignored, as in robot_sf.
    """
    n = len(pos)
    if n < 2:
        return np.zeros((n, 2))
    z, v = as_complex(pos), as_complex(vel)
    if i is None:
        f = _moussaid(z[:, None] - z, v - v[:, None], p, cutoff).sum(axis=1)
    elif len(i):
        fp = _moussaid(z[i] - z[j], v[j] - v[i], p, cutoff)
        f = np.bincount(i, weights=fp.real, minlength=n) + 1j * np.bincount(i, weights=fp.imag, minlength=n)
    else:
        return np.zeros((n, 2))
    return as_xy(p.social_factor * f)


def obstacle_force(pos: np.ndarray, walls: SegmentSet, p: ForceParams) -> tuple[np.ndarray, np.ndarray]:
    """Repulsion factor (x - c) / (|x - c| - offset)^4 summed over every segment (obstacle edges and map
    bounds, no distance cutoff, as the reference); also returns each ped's distance to the nearest segment (N,)."""
    if len(walls) == 0:
        return np.zeros_like(pos), np.full(len(pos), np.inf)
    off, dist = walls.complex_offsets(as_complex(pos))
    s = dist - p.obstacle_offset if p.obstacle_offset <= 0 else np.maximum(dist - p.obstacle_offset, 1e-5)
    s2 = s * s
    return as_xy((p.obstacle_factor * off / (s2 * s2)).sum(axis=1)), dist.min(axis=1)


def group_centroids(pos: np.ndarray, group: np.ndarray, size: np.ndarray) -> np.ndarray:
    """Group centroids (G, 2) [m] of ``group`` (N,) indices with member counts ``size`` (G,)."""
    g = len(size)
    out = np.empty((g, 2))
    out[:, 0] = np.bincount(group, weights=pos[:, 0], minlength=g) / size
    out[:, 1] = np.bincount(group, weights=pos[:, 1], minlength=g) / size
    return out


def group_coherence_force(pos: np.ndarray, centroid: np.ndarray, n: np.ndarray, p: ForceParams) -> np.ndarray:
    """Pull members towards their group centroid once farther than (n - 1) / 2 [m] (pedsim variant).

    ``centroid`` (N, 2) is each ped's group centroid, ``n`` (N,) its group size; singletons feel nothing.
    """
    u = centroid - pos
    dist = np.sqrt(u[:, 0] ** 2 + u[:, 1] ** 2)
    return p.group_coherence_factor * u * ((np.tanh(dist - (n - 1) / 2.0) + 1.0) / 2.0)[:, None]


def group_repulsion_force(pos: np.ndarray, i: np.ndarray, j: np.ndarray, p: ForceParams) -> np.ndarray:
    """Push group members apart: sum of raw (x_i - x_j) over same-group pairs (i, j) closer than the range."""
    n = len(pos)
    if len(i) == 0:
        return np.zeros((n, 2))
    r = pos[i] - pos[j]
    near = (r[:, 0] ** 2 + r[:, 1] ** 2) <= p.group_repulsion_range**2
    return p.group_repulsion_factor * _accumulate(i, r * near[:, None], n)


def group_gaze_force(
    pos: np.ndarray, goal: np.ndarray, centroid: np.ndarray, n: np.ndarray, p: ForceParams
) -> np.ndarray:
    """Turn members towards the centroid c' of the others: e_i |c' - x_i| (e_i . g) / d_i (pedsim variant).

    ``centroid`` (N, 2) and ``n`` (N,) are each ped's full group centroid and size; groups of one feel nothing.
    """
    rel = (centroid * n[:, None] - pos) / np.maximum(n - 1, 1)[:, None] - pos  # c' - x_i
    g = goal - pos
    d2 = g[:, 0] ** 2 + g[:, 1] ** 2
    # e |c'| (e . c'/|c'|) / d = g (g . c') / d^3: one square root instead of two normalisations
    active = (n >= 2) & (d2 > 1e-12)
    dot = g[:, 0] * rel[:, 0] + g[:, 1] * rel[:, 1]
    k = np.where(active, dot / np.maximum(d2, 1e-12) ** 1.5, 0.0)
    return p.group_gaze_factor * g * k[:, None]


def robot_force(pos: np.ndarray, robot_xy: np.ndarray, robot_radius: float, p: ForceParams) -> np.ndarray:
    """Repulsion from the robot centre: factor * unit(x - x_robot) / d^3 within the hard cutoff."""
    r = pos - robot_xy
    d2 = r[:, 0] ** 2 + r[:, 1] ** 2
    cut = p.robot_cutoff(robot_radius)
    active = (d2 <= cut * cut) & (d2 > 0)
    if not active.any():
        return np.zeros_like(pos)
    k = np.where(active, p.robot_factor / np.maximum(d2, 1e-12) ** 2, 0.0)  # unit(r) / d^3 = r / d^4
    return r * k[:, None]
