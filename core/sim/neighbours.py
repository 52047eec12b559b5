"""Ordered neighbour pairs for the pairwise forces: all pairs for small crowds, a sorted cell list for large ones.

The cell list hashes positions into square cells of side ``cutoff``, sorts once, and finds for
each pedestrian the contiguous runs of the three cell columns around it with ``searchsorted``:
no Python loop over pedestrians, O(N log N + pairs). It returns exactly the pairs within the
cutoff, so the force kernel runs on neighbours only.
"""

from __future__ import annotations

import functools

import numpy as np


@functools.lru_cache(maxsize=64)
def all_pairs(n: int) -> tuple[np.ndarray, np.ndarray]:
    """All ordered pairs (i, j), i != j, of n items as two (n (n - 1),) int arrays (cached, read-only)."""
    i, j = np.nonzero(~np.eye(n, dtype=bool))
    i.flags.writeable = False
    j.flags.writeable = False
    return i, j


def cell_pairs(pos: np.ndarray, cutoff: float) -> tuple[np.ndarray, np.ndarray]:
    """All ordered pairs (i, j), i != j, with centre distance <= cutoff [m], as two int arrays."""
    n = len(pos)
    if n < 2:
        return np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.intp)
    cell = np.floor((pos - pos.min(axis=0)) / cutoff).astype(np.int64) + 1  # >= 1, so -1 neighbours stay >= 0
    stride = int(cell[:, 1].max()) + 3
    key = cell[:, 0] * stride + cell[:, 1]
    order = np.argsort(key, kind="stable")
    skey = key[order]
    idx = np.arange(n)
    firsts, seconds = [], []
    for dx in (-1, 0, 1):
        base = key + dx * stride
        lo = np.searchsorted(skey, base - 1, side="left")
        hi = np.searchsorted(skey, base + 1, side="right")
        counts = hi - lo
        total = int(counts.sum())
        if total == 0:
            continue
        first = np.repeat(idx, counts)
        starts = np.repeat(lo - (np.cumsum(counts) - counts), counts)
        firsts.append(first)
        seconds.append(order[starts + np.arange(total)])
    i = np.concatenate(firsts)
    j = np.concatenate(seconds)
    d = pos[i] - pos[j]
    keep = (d[:, 0] ** 2 + d[:, 1] ** 2 <= cutoff * cutoff) & (i != j)  # ~35% of the 3 x 3 cell candidates
    return i[keep], j[keep]
