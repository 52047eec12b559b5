"""The SVG path ``d`` mini-language, flattened into a polyline.

Supports M/L/H/V/C/S/Q/T/A/Z, absolute and relative, with implicit lineto after a moveto and
repeated parameter groups. Curves and arcs become straight segments whose count follows the
reference: ``clamp(ceil(length / 0.75), 2, 256)`` where length is the control-polygon length
(Bezier) or the arc length (arcs). Consecutive duplicate points (< 1e-9 m apart) are dropped and
``Z`` appends the subpath start, so routes and obstacle rings come out as the reference reads them.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import dataclass, field

Point = tuple[float, float]

MAX_STEP = 0.75  #: target flattening step [m]
MIN_SEGMENTS = 2
MAX_SEGMENTS = 256
_DUPLICATE_EPS = 1e-9  #: points closer than this [m] are one point

_TOKEN = re.compile(
    r"(?P<cmd>[MmLlHhVvCcSsQqTtAaZz])|(?P<num>[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)|(?P<sep>[\s,]+)|(?P<bad>.)"
)
COMMAND_LETTERS = frozenset("MmLlHhVvCcSsQqTtAaZz")
_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


class PathDataError(ValueError):
    """Path data that does not follow the SVG grammar."""


def tokenize(d: str) -> list[str]:
    """Split path data into command letters and number strings."""
    tokens = []
    for m in _TOKEN.finditer(d):
        if m.lastgroup == "bad":
            raise PathDataError(f"unexpected character {m.group()!r} at position {m.start()}")
        if m.lastgroup != "sep":
            tokens.append(m.group())
    return tokens


def path_commands(d: str) -> frozenset[str]:
    """The command letters used in path data (case kept: lower case = relative)."""
    return frozenset(t for t in tokenize(d) if t in COMMAND_LETTERS)


class _Tokens:
    """A cursor over path tokens."""

    def __init__(self, tokens: list[str]):
        self.tokens = tokens
        self.i = 0

    def has_number(self) -> bool:
        return self.i < len(self.tokens) and self.tokens[self.i] not in COMMAND_LETTERS

    def number(self) -> float:
        if not self.has_number():
            got = self.tokens[self.i] if self.i < len(self.tokens) else "end of data"
            raise PathDataError(f"expected a number, got {got!r}")
        self.i += 1
        return float(self.tokens[self.i - 1])

    def flag(self) -> bool:
        """An arc flag: one character 0/1, which may be glued to what follows (``a1 1 0 0110 10``)."""
        if not self.has_number() or self.tokens[self.i][0] not in "01":
            raise PathDataError(f"expected an arc flag 0 or 1 at token {self.i}")
        tok = self.tokens[self.i]
        if len(tok) > 1:
            rest = tok[1:]
            if _NUMBER.fullmatch(rest) is None:
                raise PathDataError(f"expected an arc flag 0 or 1, got {tok!r}")
            self.tokens[self.i] = rest
        else:
            self.i += 1
        return tok[0] == "1"


@dataclass
class _Pen:
    """Drawing state: the polyline so far, the current point and the last curve control points."""

    points: list[Point] = field(default_factory=list)
    current: Point = (0.0, 0.0)
    start: Point | None = None
    cubic_ctrl: Point | None = None
    quad_ctrl: Point | None = None

    def add(self, p: Point) -> None:
        if not self.points or math.dist(self.points[-1], p) > _DUPLICATE_EPS:
            self.points.append((float(p[0]), float(p[1])))

    def point(self, t: _Tokens, rel: bool) -> Point:
        x, y = t.number(), t.number()
        return (self.current[0] + x, self.current[1] + y) if rel else (x, y)

    def move(self, p: Point) -> None:
        self.add(p)
        self.current = p
        self.cubic_ctrl = self.quad_ctrl = None


def segment_count(length: float) -> int:
    """Straight segments for a curve of (estimated) length [m]."""
    if length <= 0:
        return MIN_SEGMENTS
    return max(MIN_SEGMENTS, min(MAX_SEGMENTS, math.ceil(length / MAX_STEP)))


def _cubic(pen: _Pen, p1: Point, p2: Point, p3: Point) -> None:
    p0 = pen.current
    n = segment_count(math.dist(p0, p1) + math.dist(p1, p2) + math.dist(p2, p3))
    for i in range(1, n + 1):
        s = i / n
        u = 1.0 - s
        w = (u**3, 3 * u * u * s, 3 * u * s * s, s**3)
        pen.add(
            (
                w[0] * p0[0] + w[1] * p1[0] + w[2] * p2[0] + w[3] * p3[0],
                w[0] * p0[1] + w[1] * p1[1] + w[2] * p2[1] + w[3] * p3[1],
            )
        )
    pen.current, pen.cubic_ctrl, pen.quad_ctrl = p3, p2, None


def _quadratic(pen: _Pen, p1: Point, p2: Point) -> None:
    p0 = pen.current
    n = segment_count(math.dist(p0, p1) + math.dist(p1, p2))
    for i in range(1, n + 1):
        s = i / n
        u = 1.0 - s
        pen.add(
            (
                u * u * p0[0] + 2 * u * s * p1[0] + s * s * p2[0],
                u * u * p0[1] + 2 * u * s * p1[1] + s * s * p2[1],
            )
        )
    pen.current, pen.quad_ctrl, pen.cubic_ctrl = p2, p1, None


def _reflect(current: Point, ctrl: Point | None) -> Point:
    return current if ctrl is None else (2 * current[0] - ctrl[0], 2 * current[1] - ctrl[1])


def _arc_centre(p0: Point, p1: Point, rx: float, ry: float, phi: float, large: bool, sweep: bool):
    """Endpoint to centre parametrisation (SVG 1.1 implementation notes F.6.5/F.6.6)."""
    cos_p, sin_p = math.cos(phi), math.sin(phi)
    dx, dy = (p0[0] - p1[0]) / 2, (p0[1] - p1[1]) / 2
    x1, y1 = cos_p * dx + sin_p * dy, -sin_p * dx + cos_p * dy
    lam = x1**2 / rx**2 + y1**2 / ry**2
    if lam > 1:
        rx, ry = rx * math.sqrt(lam), ry * math.sqrt(lam)
    num = rx**2 * ry**2 - rx**2 * y1**2 - ry**2 * x1**2
    den = rx**2 * y1**2 + ry**2 * x1**2
    coef = (-1 if large == sweep else 1) * math.sqrt(max(0.0, num / den))
    cxp, cyp = coef * rx * y1 / ry, -coef * ry * x1 / rx
    cx = cos_p * cxp - sin_p * cyp + (p0[0] + p1[0]) / 2
    cy = sin_p * cxp + cos_p * cyp + (p0[1] + p1[1]) / 2
    ux, uy = (x1 - cxp) / rx, (y1 - cyp) / ry
    vx, vy = (-x1 - cxp) / rx, (-y1 - cyp) / ry
    theta = math.atan2(uy, ux)
    delta = math.atan2(ux * vy - uy * vx, ux * vx + uy * vy)
    if not sweep and delta > 0:
        delta -= 2 * math.pi
    elif sweep and delta < 0:
        delta += 2 * math.pi
    return (cx, cy), rx, ry, theta, delta


def _arc(pen: _Pen, rx: float, ry: float, rot_deg: float, large: bool, sweep: bool, end: Point) -> None:
    """Flatten an elliptical arc; the segment count comes from the arc length |delta| * max(rx, ry)."""
    start = pen.current
    pen.current, pen.cubic_ctrl, pen.quad_ctrl = end, None, None
    if math.dist(start, end) <= 1e-12:
        return
    rx, ry = abs(rx), abs(ry)
    if rx <= 1e-12 or ry <= 1e-12:
        pen.add(end)
        return
    phi = math.radians(rot_deg % 360.0)
    (cx, cy), rx, ry, theta, delta = _arc_centre(start, end, rx, ry, phi, large, sweep)
    n = segment_count(abs(delta) * max(rx, ry))
    cos_p, sin_p = math.cos(phi), math.sin(phi)
    for i in range(1, n):
        a = theta + delta * i / n
        pen.add(
            (
                cx + cos_p * rx * math.cos(a) - sin_p * ry * math.sin(a),
                cy + sin_p * rx * math.cos(a) + cos_p * ry * math.sin(a),
            )
        )
    pen.add(end)  # exact end point, no floating-point drift


def _do_m(pen: _Pen, t: _Tokens, rel: bool) -> None:
    pen.move(pen.point(t, rel))
    pen.start = pen.current


def _do_l(pen: _Pen, t: _Tokens, rel: bool) -> None:
    pen.move(pen.point(t, rel))


def _do_h(pen: _Pen, t: _Tokens, rel: bool) -> None:
    x = t.number()
    pen.move((pen.current[0] + x if rel else x, pen.current[1]))


def _do_v(pen: _Pen, t: _Tokens, rel: bool) -> None:
    y = t.number()
    pen.move((pen.current[0], pen.current[1] + y if rel else y))


def _do_c(pen: _Pen, t: _Tokens, rel: bool) -> None:
    p1, p2, p3 = pen.point(t, rel), pen.point(t, rel), pen.point(t, rel)
    _cubic(pen, p1, p2, p3)


def _do_s(pen: _Pen, t: _Tokens, rel: bool) -> None:
    p1 = _reflect(pen.current, pen.cubic_ctrl)
    p2, p3 = pen.point(t, rel), pen.point(t, rel)
    _cubic(pen, p1, p2, p3)


def _do_q(pen: _Pen, t: _Tokens, rel: bool) -> None:
    p1, p2 = pen.point(t, rel), pen.point(t, rel)
    _quadratic(pen, p1, p2)


def _do_t(pen: _Pen, t: _Tokens, rel: bool) -> None:
    p1 = _reflect(pen.current, pen.quad_ctrl)
    _quadratic(pen, p1, pen.point(t, rel))


def _do_a(pen: _Pen, t: _Tokens, rel: bool) -> None:
    rx, ry, rot = t.number(), t.number(), t.number()
    large, sweep = t.flag(), t.flag()
    _arc(pen, rx, ry, rot, large, sweep, pen.point(t, rel))


_HANDLERS: dict[str, Callable[[_Pen, _Tokens, bool], None]] = {
    "m": _do_m,
    "l": _do_l,
    "h": _do_h,
    "v": _do_v,
    "c": _do_c,
    "s": _do_s,
    "q": _do_q,
    "t": _do_t,
    "a": _do_a,
}


def parse_path(d: str) -> list[Point]:
    """Flatten path data into a polyline [m]; raises PathDataError on malformed data."""
    tokens = _Tokens(tokenize(d))
    pen = _Pen()
    while tokens.i < len(tokens.tokens):
        cmd = tokens.tokens[tokens.i]
        if cmd not in COMMAND_LETTERS:
            raise PathDataError(f"number {cmd!r} before any command")
        tokens.i += 1
        if cmd in "Zz":
            if pen.start is not None:
                pen.move(pen.start)
            continue
        rel = cmd.islower()
        handler = _HANDLERS[cmd.lower()]
        handler(pen, tokens, rel)
        if cmd in "Mm":  # further pairs after a moveto are implicit linetos
            handler = _do_l
        while tokens.has_number():
            handler(pen, tokens, rel)
    return pen.points
