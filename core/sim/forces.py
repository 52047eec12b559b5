"""The social-force terms of the pedestrian model, one function per term (reference §1.2).

Each term maps state arrays and ``ForceParams`` to an acceleration [m/s^2] per pedestrian; the
crowd sums them and integrates once. Vectors are complex numbers x + iy, shape (N,): one array
operation then handles both components, which matters because a step of a classic scenario is
a few hundred operations on arrays of a few dozen elements, each costing ~1 µs of overhead.
``as_complex``/``as_xy`` convert from/to (N, 2) float arrays (zero-copy one way).
Pairwise terms take explicit ordered pair lists (i, j) so that the same kernel serves all pairs
(small crowds) and a cell list (large crowds, see ``core.sim.neighbours``).
"""

from __future__ import annotations

import numpy as np

from foresight.core.sim.geometry import SegmentSet
from foresight.core.sim.params import ForceParams


def as_complex(xy: np.ndarray) -> np.ndarray:
    """An (N, 2) float array as (N,) complex x + iy (a view when the input is contiguous float64)."""
    xy = np.ascontiguousarray(xy, dtype=float).reshape(-1, 2)
    return xy.view(np.complex128)[:, 0]


def as_xy(z: np.ndarray) -> np.ndarray:
    """(N,) complex as an (N, 2) float array (a view of contiguous input)."""
    return np.ascontiguousarray(z, dtype=np.complex128).view(np.float64).reshape(-1, 2)


def norm(z: np.ndarray) -> np.ndarray:
    """|z|: one hypot call for small arrays (op count dominates), sqrt(re^2 + im^2) for large ones (faster per element)."""
    if z.size <= 4096:
        return np.abs(z)
    return np.sqrt(z.real * z.real + z.imag * z.imag)


def _accumulate(idx: np.ndarray, f: np.ndarray, n: int) -> np.ndarray:
    """Sum complex pair forces f (P,) onto their first index idx (P,), giving (n,)."""
    return np.bincount(idx, weights=f.real, minlength=n) + 1j * np.bincount(idx, weights=f.imag, minlength=n)


def desired_force(
    z: np.ndarray, v: np.ndarray, goal: np.ndarray, vmax: np.ndarray, p: ForceParams
) -> np.ndarray:
    """Relax towards vmax along the goal direction; inside ``goal_threshold`` only brake."""
    g = goal - z
    d = norm(g)
    speed = np.where(d > p.goal_threshold, vmax / np.maximum(d, 1e-300), 0.0)  # vmax e = vmax g / d
    return (p.desired_factor / p.relaxation_time) * (g * speed - v)


def _moussaid(r: np.ndarray, dv: np.ndarray, p: ForceParams, cutoff: float | None) -> np.ndarray:
    """Moussaid pair forces from r = x_i - x_j and dv = v_j - v_i, any matching shapes.

    A pair with zero distance (including i == j on a dense grid) contributes exactly zero,
    because its interaction direction t is the zero vector. ``cutoff`` None = no pair is beyond it.
    """
    d = norm(r)
    w = p.social_lambda * dv + r * (1.0 / np.maximum(d, 1e-300))  # e = r / d (zero for coincident peds)
    wn = norm(w)
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
    z: np.ndarray,
    v: np.ndarray,
    i: np.ndarray | None,
    j: np.ndarray | None,
    p: ForceParams,
    cutoff: float | None,
) -> np.ndarray:
    """Moussaid ped-ped force: factor * sum over neighbours j with centre distance <= cutoff (None: all given).

    ``i, j`` are ordered candidate pairs (i != j); None means all pairs, computed on the dense
    (N, N) grid without index gathers (faster for small crowds). Reproduces the reference kernel
    including its unwrapped angle difference theta (unless ``social_wrap_theta``), so a neighbour
    whose interaction direction straddles the +-pi cut is nearly ignored, as in robot_sf.
    """
    n = len(z)
    if n < 2 or (i is not None and len(i) == 0):
        return np.zeros(n, dtype=complex)
    if i is None:
        f = _moussaid(z[:, None] - z, v - v[:, None], p, cutoff).sum(axis=1)
    else:
        f = _accumulate(i, _moussaid(z[i] - z[j], v[j] - v[i], p, cutoff), n)
    return p.social_factor * f


def obstacle_force(z: np.ndarray, walls: SegmentSet, p: ForceParams) -> tuple[np.ndarray, np.ndarray]:
    """Repulsion factor (x - c) / (|x - c| - offset)^4 summed over every segment (obstacle edges and map
    bounds, no distance cutoff, as the reference); also returns each ped's distance to the nearest segment (N,)."""
    if len(walls) == 0:
        return np.zeros(len(z), dtype=complex), np.full(len(z), np.inf)
    off, dist = walls.complex_offsets(z)
    s = dist - p.obstacle_offset if p.obstacle_offset <= 0 else np.maximum(dist - p.obstacle_offset, 1e-5)
    s2 = s * s
    return (off * (p.obstacle_factor / (s2 * s2))).sum(axis=1), dist.min(axis=1)


def group_centroids(z: np.ndarray, group: np.ndarray, size: np.ndarray) -> np.ndarray:
    """Group centroids (G,) [m] of ``group`` (N,) indices with member counts ``size`` (G,)."""
    return _accumulate(group, z, len(size)) / size


def group_coherence_force(z: np.ndarray, centroid: np.ndarray, n: np.ndarray, p: ForceParams) -> np.ndarray:
    """Pull members towards their group centroid once farther than (n - 1) / 2 [m] (pedsim variant).

    ``centroid`` (N,) is each ped's group centroid, ``n`` (N,) its group size; singletons feel nothing.
    """
    u = centroid - z
    return u * ((np.tanh(norm(u) - (n - 1) / 2.0) + 1.0) * (p.group_coherence_factor / 2.0))


def group_repulsion_force(z: np.ndarray, i: np.ndarray, j: np.ndarray, p: ForceParams) -> np.ndarray:
    """Push group members apart: sum of raw (x_i - x_j) over same-group pairs (i, j) closer than the range."""
    if len(i) == 0:
        return np.zeros(len(z), dtype=complex)
    r = z[i] - z[j]
    return p.group_repulsion_factor * _accumulate(i, r * (norm(r) <= p.group_repulsion_range), len(z))


def group_gaze_force(
    z: np.ndarray, goal: np.ndarray, centroid: np.ndarray, n: np.ndarray, p: ForceParams
) -> np.ndarray:
    """Turn members towards the centroid c' of the others: e_i |c' - x_i| (e_i . g) / d_i (pedsim variant).

    ``centroid`` (N,) and ``n`` (N,) are each ped's full group centroid and size; groups of one feel nothing.
    """
    rel = (centroid * n - z) / np.maximum(n - 1, 1) - z  # c' - x_i
    g = goal - z
    d = norm(g)
    # e |c'| (e . c'/|c'|) / d = g (g . c') / d^3: no normalisation needed
    active = (n >= 2) & (d > 1e-6)
    dot = (g * np.conj(rel)).real
    k = np.where(active, dot / np.maximum(d, 1e-6) ** 3, 0.0)
    return g * (p.group_gaze_factor * k)


def robot_force(
    z: np.ndarray, robot: complex, robot_radius: float, p: ForceParams, reach: np.ndarray | None = None
) -> np.ndarray:
    """Repulsion from the robot centre x_r: factor * unit(x - x_r) / d^3 within the hard cutoff.

    ``reach`` (N,): each ped's own cutoff instead [m] (``core.sim.attention``; 0 = ignores the robot).
    """
    r = z - robot
    d = norm(r)
    active = (d <= (p.robot_cutoff(robot_radius) if reach is None else reach)) & (d > 0)
    if not active.any():
        return np.zeros(len(z), dtype=complex)
    return r * np.where(active, p.robot_factor / np.maximum(d, 1e-6) ** 4, 0.0)  # unit(r) / d^3 = r / d^4
