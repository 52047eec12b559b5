"""grid_distance (tiled, pruned) against every point measured against every segment."""

from __future__ import annotations

import numpy as np
import pytest

from foresight.core.sim.geometry import SegmentSet, grid_distance


@pytest.mark.parametrize("seed", range(5))
def test_grid_distance_equals_brute_force_bit_for_bit(seed: int) -> None:
    rng = np.random.default_rng(seed)
    segs = rng.uniform(0, 20, size=(int(rng.integers(1, 80)), 4))
    segs[0, 2:] = segs[0, :2]  # a degenerate segment (a point) too
    walls = SegmentSet(segs)
    xs, ys = np.arange(0, 20.05, 0.25), np.arange(-1, 21, 0.3)  # tiles cut at odd sizes, points outside too
    pts = np.stack(np.meshgrid(xs, ys, indexing="ij"), axis=-1)
    expected = walls.distance(pts)
    for tile in (1, 5, 16):
        assert np.array_equal(grid_distance(walls, xs, ys, tile=tile), expected)


def test_grid_distance_without_segments_is_infinite() -> None:
    assert np.isinf(grid_distance(SegmentSet(np.zeros((0, 4))), np.arange(3.0), np.arange(2.0))).all()
