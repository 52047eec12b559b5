"""Distance to a waypoint around the walls (a navigation function), for the route potential.

A straight-line distance to the next waypoint has local minima behind walls: a robot pushed off its
route beside a doorway (escaping a stream of people) measures its progress through the wall and
waits there, since every way round first moves it away. The geodesic distance (the shortest path
for the robot's centre through the free space, walls inflated by its radius and the static margin)
has no such minima. Computed once per (map, waypoint, radius) with Dijkstra on a grid of nodes
``resolution`` apart, 16-connected (the 8 neighbours and the knight moves: a path's length is then
within ~3 % of the true one in every direction), and read by bilinear interpolation.
A node too close to a wall takes its nearest free node's distance plus the step to it, so a point
there (a rollout that breaks the static margin, which its own term penalises) still gets a finite
value, continuous up to the middle of the wall, and no path cuts through a wall. Where no way
round exists (the target walled off), the straight line is all there is to measure.
"""

from __future__ import annotations

from collections import OrderedDict

import numpy as np
from scipy.ndimage import distance_transform_edt
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from foresight.core.planners.predictive.cost import distance_field
from foresight.core.sim.geometry import grid_interpolate
from foresight.core.sim.observation import StaticGeometry

#: node offsets of the 16-connected grid (the 8 neighbours and the 8 knight moves), one of each opposite pair: the
#: graph is undirected
_MOVES = np.array([(1, 0), (0, 1), (1, 1), (1, -1), (2, 1), (1, 2), (2, -1), (1, -2)])


class GeodesicDistance:
    """Shortest-path distance [m] from any point of the map to ``target`` for a disc of ``clearance``."""

    def __init__(self, static: StaticGeometry, target: np.ndarray, clearance: float, resolution: float):
        self.resolution = resolution
        self.target = np.asarray(target, dtype=float)
        self.field = _field(static, (float(self.target[0]), float(self.target[1])), clearance, resolution)
        self._walled_off = bool(
            np.isnan(self.field).any()
        )  #: some space has no way round to the target (nan there)

    def __call__(self, pts: np.ndarray) -> np.ndarray:
        """Distance (...) at points (..., 2): the straight line where the grid's path is no longer than its
        worst-case excess (``GRID_EXCESS``) over it, i.e. in sight of the target, else the grid's path less that
        excess. Continuous (the larger of two continuous functions) and exact in the open, where a bare grid
        metric would bend every rollout's progress towards the grid's directions."""
        x, y = pts[..., 0], pts[..., 1]
        straight = np.sqrt((x - self.target[0]) ** 2 + (y - self.target[1]) ** 2)
        way = np.maximum(straight, grid_interpolate(self.field, self.resolution, x, y) / (1.0 + GRID_EXCESS))
        return (
            np.where(np.isnan(way), straight, way) if self._walled_off else way
        )  # nan beside walled-off space


#: the 16-connected grid's longest path relative to the straight line, over all directions (2.75 %), rounded up
GRID_EXCESS = 0.03

_FIELDS: OrderedDict[tuple, np.ndarray] = OrderedDict()  # per process: a matrix repeats maps and waypoints
_GRAPHS: OrderedDict[tuple, tuple] = (
    OrderedDict()
)  # per process: one free-space graph per map serves every waypoint


def _field(
    static: StaticGeometry, target: tuple[float, float], clearance: float, resolution: float
) -> np.ndarray:
    segs = np.ascontiguousarray(static.segments, dtype=float)
    space = (segs.tobytes(), float(static.width), float(static.height), clearance, resolution)
    key = (*space, target)
    if key in _FIELDS:
        _FIELDS.move_to_end(key)
        return _FIELDS[key]
    graph, nearest, gap = _graph(space, static, clearance, resolution)
    nx, ny = gap.shape
    # the source: the free node nearest the target (a waypoint close to a wall still pulls from the free side)
    gi = np.clip(np.round(np.array(target) / resolution).astype(int), 0, [nx - 1, ny - 1])
    src = int(nearest[gi[0], gi[1]])
    sx, sy = divmod(src, ny)
    offset = float(np.hypot(sx * resolution - target[0], sy * resolution - target[1]))
    dist = dijkstra(graph, directed=False, indices=src) + offset
    dist[np.isinf(dist)] = (
        np.nan
    )  # no way round: nan interpolates quietly (inf x 0 would warn) and is read as such
    # a node too close to a wall: the way from its nearest free node plus the step to it (never through the wall)
    field = (dist[nearest.reshape(-1)] + gap.reshape(-1) * resolution).reshape(nx, ny)
    field.flags.writeable = False
    _FIELDS[key] = field
    while len(_FIELDS) > 32:
        _FIELDS.popitem(last=False)
    return field


def _graph(space: tuple, static: StaticGeometry, clearance: float, resolution: float) -> tuple:
    """The free nodes' 16-connected graph (CSR), each node's nearest free node (flat index) and the gap to it."""
    if space in _GRAPHS:
        _GRAPHS.move_to_end(space)
        return _GRAPHS[space]
    clear = distance_field(static, resolution)  # the static clearance term's own table, when on the same grid
    nx, ny = clear.shape
    free = (clear >= clearance).reshape(-1)
    index = np.arange(nx * ny).reshape(nx, ny)
    rows, cols, lengths = [], [], []
    for di, dj in _MOVES:
        a = index[max(0, -di) : nx - max(0, di), max(0, -dj) : ny - max(0, dj)].reshape(-1)
        b = a + di * ny + dj
        ok = free[a] & free[b]
        rows.append(a[ok])
        cols.append(b[ok])
        lengths.append(np.full(int(ok.sum()), resolution * float(np.hypot(di, dj))))
    graph = coo_matrix(
        (np.concatenate(lengths), (np.concatenate(rows), np.concatenate(cols))), shape=(nx * ny, nx * ny)
    ).tocsr()
    gap, (ni, nj) = distance_transform_edt(~free.reshape(nx, ny), return_indices=True)
    _GRAPHS[space] = out = (graph, ni * ny + nj, gap)
    while len(_GRAPHS) > 4:
        _GRAPHS.popitem(last=False)
    return out
