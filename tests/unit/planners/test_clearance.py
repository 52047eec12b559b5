"""Clearances computed only for the (row, step) pairs that can matter equal the dense ones, and no dropped pair could."""

from __future__ import annotations

import numpy as np

from foresight.core.planners.predictive.clearance import near_pairs, pair_clearance, reactive_clearance


def _scene(seed: int, rows: int = 40, steps: int = 20, rollouts: int = 90):
    rng = np.random.default_rng(seed)
    # rollouts fanning out from (10, 10); rows scattered over a 30 x 20 m map, walking
    heading = rng.uniform(-np.pi, np.pi, rollouts)
    speed = rng.uniform(0.0, 2.0, rollouts)
    t = 0.2 * np.arange(1, steps + 1)
    pos = np.stack(
        [
            10 + np.cos(heading)[:, None] * speed[:, None] * t,
            10 + np.sin(heading)[:, None] * speed[:, None] * t,
        ],
        -1,
    )
    start = rng.uniform([0, 0], [30, 20], (rows, 1, 2))
    fut = start + rng.normal(0, 1.0, (rows, 1, 2)) * t[None, :, None]
    return pos, fut


def test_pairs_keep_every_pair_within_the_cut_and_their_clearances_are_the_dense_ones_to_the_bit():
    for seed in range(5):
        pos, fut = _scene(seed)
        contact = 0.7
        cut = np.full(fut.shape[:2], 2.5)
        dense = reactive_clearance(pos, fut, contact, np.full(20, 0.2), np.zeros(len(fut)), 0.0)
        pairs = near_pairs(pos, fut, contact, cut)
        assert 0 < len(pairs) < fut.shape[0] * fut.shape[1]  # some pairs dropped, some kept
        flat = dense.reshape(-1, pos.shape[0])
        assert np.array_equal(pair_clearance(pos, fut, pairs, contact), flat[pairs])
        dropped = np.setdiff1d(np.arange(len(flat)), pairs)
        assert np.all(flat[dropped] >= 2.5)  # every dropped pair is beyond the cut-off for every rollout
        near = np.flatnonzero(np.any(flat < 2.5, axis=1))
        assert np.all(np.isin(near, pairs))
