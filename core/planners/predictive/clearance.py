"""Robot-pedestrian clearances of a decision's rollouts, dense (N, K, B) or only where they can matter.

The pedestrian terms of the cost (``cost.pedestrian_terms``) read the clearance between every forecast row (a
pedestrian, or one mode of one) and every rollout at every forecast step, but a (row, step) pair whose clearance is
beyond every term's range adds exact zeros to all of them. ``near_pairs`` bounds each pair's clearance from below by
the distance to the box around all rollouts' positions at that step (cheap: (N, K) against (K,) boxes) and keeps the
pairs that may come closer than the cut-off; ``pair_clearance`` computes the clearance of those pairs alone, with the
same float32 operations as the dense ``reactive_clearance``, so every value it computes is bit-identical. In a crowd
about a quarter of the pairs are kept, and with K forecast modes the rows are K times as many: the dense arrays were
the decision's largest cost. Rows whose clearance is not the plain one (pedestrians stepping away from the robot,
or also held to a straight line) keep all their steps and get ``reactive_clearance`` of those rows alone.
"""

from __future__ import annotations

import numpy as np

#: [m] kept beyond the cut-off: the float32 clearances differ from the float64 bound by ~1e-5 m on map coordinates
#: of tens of metres; a pair is dropped only when its clearance is certainly beyond the cut-off
CULL_SLACK = 1e-3


def near_pairs(pos: np.ndarray, fut: np.ndarray, contact: float, cut: np.ndarray) -> np.ndarray:
    """Flat indices n * K + k of the (row, step) pairs that some rollout may bring within ``cut`` (N, K) [m].

    ``pos`` (B, K, 2) rollout positions and ``fut`` (N, K, 2) forecast rows at the same K times; the clearance of
    a pair is at least the distance from the row's position to the box around every rollout's position at that
    step, less ``contact``."""
    lo = np.min(pos, axis=0)  # (K, 2)
    hi = np.max(pos, axis=0)
    gap = np.maximum(np.maximum(lo - fut, fut - hi), 0.0)  # (N, K, 2) outside the box, per axis
    bound = np.sqrt(gap[..., 0] * gap[..., 0] + gap[..., 1] * gap[..., 1]) - contact
    return np.flatnonzero(bound < cut + CULL_SLACK)


def pair_clearance(pos: np.ndarray, fut: np.ndarray, pairs: np.ndarray, contact: float) -> np.ndarray:
    """Clearance (P, B) [m, float32] of the ``pairs`` (flat (row, step) indices, ``near_pairs``) to every rollout:
    the rows of ``reactive_clearance``'s plain clearance at those pairs, to the bit."""
    K = fut.shape[1]
    step = pairs % K
    dx = np.ascontiguousarray(pos[..., 0].T, dtype=np.float32).take(step, axis=0)  # (P, B)
    dy = np.ascontiguousarray(pos[..., 1].T, dtype=np.float32).take(step, axis=0)
    dx -= fut[..., 0].reshape(-1).take(pairs).astype(np.float32)[:, None]
    dy -= fut[..., 1].reshape(-1).take(pairs).astype(np.float32)[:, None]
    dx *= dx
    dy *= dy
    dx += dy
    clear = np.sqrt(dx, out=dx)
    clear -= contact
    return clear


def reactive_clearance(
    pos: np.ndarray, fut: np.ndarray, contact: float, time_steps: np.ndarray, speed: np.ndarray, reach: float
) -> np.ndarray:
    """Clearance (N, K, B) [m, float32] between each forecast pedestrian and each rollout, the pedestrian stepping away.

    Pedestrians repelled by a robot closing in (the crowd model's robot force) step away from it,
    which a forecast made without the robot's plan cannot know: within ``reach`` metres of contact
    pedestrian n is displaced away from the rolled-out robot at up to ``speed[n]`` m/s, linearly more
    the closer it is, and the displacement accumulates along the forecast steps (``time_steps`` (K,) [s] apart).
    ``speed[n]`` 0 assumes nothing of the kind (a pedestrian who does not see the robot): the plain clearance.
    """
    # robot coordinates as contiguous (K, B) rows; the differences (N, K, B) are then squared, summed and rooted
    # in place: two large temporaries instead of seven (freed large arrays cost page faults on the next decision).
    # float32: the decision's largest arrays at half the memory traffic (~0.17 ms of 2.4 per decision); an error of
    # ~1e-6 m on map coordinates of tens of metres, which moves costs by ~1e-6 relative
    dx = np.ascontiguousarray(pos[..., 0].T, dtype=np.float32) - fut[..., 0, None].astype(np.float32)
    dy = np.ascontiguousarray(pos[..., 1].T, dtype=np.float32) - fut[..., 1, None].astype(np.float32)
    dx *= dx
    dy *= dy
    dx += dy
    clear = np.sqrt(dx, out=dx)
    clear -= contact
    K = clear.shape[1]
    if reach <= 0 or K < 2 or not np.any(speed > 0, axis=None):
        return clear
    pushed = np.any(clear[:, :-1] < reach, axis=1) & (speed > 0)[:, None]  # (N, B) ever within reach
    n, b = np.nonzero(pushed)
    if not len(n):  # every other pair is never pushed: its clearance is the plain one
        return clear
    speed = speed[n]  # (A,)
    rel = pos[b] - fut[n]  # (A, K, 2) robot minus pedestrian
    off = np.zeros((len(rel), 2))  # accumulated displacement of each pedestrian (x, y)
    out = np.empty(rel.shape[:2])
    for k in range(K):
        e = rel[:, k] - off  # robot minus displaced pedestrian
        d = np.sqrt(e[:, 0] ** 2 + e[:, 1] ** 2)
        out[:, k] = d - contact
        push = speed * time_steps[k] * np.clip(1.0 - out[:, k] / reach, 0.0, 1.0) / np.maximum(d, 1e-6)
        off -= push[:, None] * e
    clear[n, :, b] = out
    return clear
