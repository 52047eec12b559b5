"""Ordered neighbour pairs for the pairwise forces: all pairs for small crowds, a sorted cell list for large ones.

The cell list hashes positions into square cells of side ``cutoff``, sorts once, and finds for
each pedestrian the contiguous runs of the three cell columns around it with ``searchsorted``:
no Python loop over pedestrians, O(N log N + pairs). Pairs it returns may be farther than the
cutoff (the kernels mask by distance), but it never misses a pair within it.
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
    """Ordered candidate pairs (i, j), i != j, covering every pair with centre distance <= cutoff."""
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
    keep = i != j
    return i[keep], j[keep]
