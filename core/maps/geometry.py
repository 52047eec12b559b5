"""Small polygon checks the importer needs, without a shapely dependency.

Used to flag (never repair) self-intersecting obstacle rings and routes that run through an
obstacle's interior, the two geometry problems the reference registry reports.
"""

from __future__ import annotations

from collections.abc import Sequence

Point = tuple[float, float]
EPS = 1e-9  #: geometric tolerance [m]


def _cross(o: Point, a: Point, b: Point) -> float:
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


def _segments_cross_properly(p1: Point, p2: Point, q1: Point, q2: Point) -> bool:
    """True when the two segments cross at one point interior to both (touching does not count)."""
    d1, d2 = _cross(q1, q2, p1), _cross(q1, q2, p2)
    d3, d4 = _cross(p1, p2, q1), _cross(p1, p2, q2)
    return d1 * d2 < -EPS * EPS and d3 * d4 < -EPS * EPS


def ring_self_intersects(ring: Sequence[Point]) -> bool:
    """True when two non-adjacent edges of the closed ring cross (a bow-tie or worse)."""
    n = len(ring)
    edges = [(ring[i], ring[(i + 1) % n]) for i in range(n)]
    for i in range(n):
        for j in range(i + 2, n):
            if i == 0 and j == n - 1:
                continue  # adjacent through the closing edge
            if _segments_cross_properly(*edges[i], *edges[j]):
                return True
    return False


def _on_segment(p: Point, a: Point, b: Point) -> bool:
    if abs(_cross(a, b, p)) > EPS * max(1.0, abs(b[0] - a[0]) + abs(b[1] - a[1])):
        return False
    return (
        min(a[0], b[0]) - EPS <= p[0] <= max(a[0], b[0]) + EPS
        and min(a[1], b[1]) - EPS <= p[1] <= max(a[1], b[1]) + EPS
    )


def point_strictly_inside(p: Point, ring: Sequence[Point]) -> bool:
    """Even-odd point-in-polygon test; points on the boundary are not inside."""
    n = len(ring)
    inside = False
    for i in range(n):
        a, b = ring[i], ring[(i + 1) % n]
        if _on_segment(p, a, b):
            return False
        if (a[1] > p[1]) != (b[1] > p[1]):
            x = a[0] + (p[1] - a[1]) * (b[0] - a[0]) / (b[1] - a[1])
            if x > p[0]:
                inside = not inside
    return inside


def _crossing_params(p: Point, q: Point, ring: Sequence[Point]) -> list[float]:
    """Parameters t in [0, 1] along p->q where it meets any ring edge (or its end points)."""
    ts = [0.0, 1.0]
    dx, dy = q[0] - p[0], q[1] - p[1]
    length2 = dx * dx + dy * dy
    n = len(ring)
    for i in range(n):
        a, b = ring[i], ring[(i + 1) % n]
        ex, ey = b[0] - a[0], b[1] - a[1]
        den = dx * ey - dy * ex
        if abs(den) > EPS:
            t = ((a[0] - p[0]) * ey - (a[1] - p[1]) * ex) / den
            if -EPS <= t <= 1 + EPS:
                ts.append(min(1.0, max(0.0, t)))
        elif length2 > 0:  # parallel: the edge's end points split the segment
            ts.extend(((v[0] - p[0]) * dx + (v[1] - p[1]) * dy) / length2 for v in (a, b))
    return sorted(t for t in ts if 0.0 <= t <= 1.0)


def polyline_enters_interior(points: Sequence[Point], ring: Sequence[Point]) -> bool:
    """True when any part of the polyline lies strictly inside the polygon (touching edges is fine)."""
    for p, q in zip(points, points[1:], strict=False):
        ts = _crossing_params(p, q, ring)
        for t0, t1 in zip(ts, ts[1:], strict=False):
            if t1 - t0 <= EPS:
                continue
            tm = (t0 + t1) / 2
            if point_strictly_inside((p[0] + tm * (q[0] - p[0]), p[1] + tm * (q[1] - p[1])), ring):
                return True
    return False
