"""SVG ``transform`` attributes as 2-D affine maps.

The reference (robot_sf) ignores transforms; the SVG importer applies them only on request
(``apply_transforms=True``), to read a map the way its author saw it in the editor.
"""

from __future__ import annotations

import math
import re

Point = tuple[float, float]
#: Affine map (a, b, c, d, e, f): x' = a x + c y + e, y' = b x + d y + f (SVG ``matrix`` order).
Affine = tuple[float, float, float, float, float, float]

IDENTITY: Affine = (1.0, 0.0, 0.0, 1.0, 0.0, 0.0)

_FUNC = re.compile(r"\s*,?\s*([A-Za-z]+)\s*\(([^)]*)\)\s*")
_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
_ARITY = {
    "matrix": (6,),
    "translate": (1, 2),
    "scale": (1, 2),
    "rotate": (1, 3),
    "skewx": (1,),
    "skewy": (1,),
}


class TransformError(ValueError):
    """A ``transform`` attribute that does not follow the SVG grammar."""


def compose(outer: Affine, inner: Affine) -> Affine:
    """The map ``p -> outer(inner(p))`` (a parent's transform is ``outer``)."""
    a1, b1, c1, d1, e1, f1 = outer
    a2, b2, c2, d2, e2, f2 = inner
    return (
        a1 * a2 + c1 * b2,
        b1 * a2 + d1 * b2,
        a1 * c2 + c1 * d2,
        b1 * c2 + d1 * d2,
        a1 * e2 + c1 * f2 + e1,
        b1 * e2 + d1 * f2 + f1,
    )


def apply(m: Affine, p: Point) -> Point:
    """Map one point."""
    a, b, c, d, e, f = m
    x, y = p
    return (a * x + c * y + e, b * x + d * y + f)


def _function(name: str, args: list[float]) -> Affine:
    """The affine map of one transform function (angles in degrees, as in SVG)."""
    if name == "matrix":
        return (args[0], args[1], args[2], args[3], args[4], args[5])
    if name == "translate":
        return (1.0, 0.0, 0.0, 1.0, args[0], args[1] if len(args) > 1 else 0.0)
    if name == "scale":
        sy = args[1] if len(args) > 1 else args[0]
        return (args[0], 0.0, 0.0, sy, 0.0, 0.0)
    if name == "rotate":
        t = math.radians(args[0])
        rot = (math.cos(t), math.sin(t), -math.sin(t), math.cos(t), 0.0, 0.0)
        if len(args) == 3:
            cx, cy = args[1], args[2]
            return compose(compose((1.0, 0.0, 0.0, 1.0, cx, cy), rot), (1.0, 0.0, 0.0, 1.0, -cx, -cy))
        return rot
    if name == "skewx":
        return (1.0, 0.0, math.tan(math.radians(args[0])), 1.0, 0.0, 0.0)
    return (1.0, math.tan(math.radians(args[0])), 0.0, 1.0, 0.0, 0.0)  # skewy


def parse_transform(text: str | None) -> Affine:
    """Parse a transform list such as ``translate(0,-4.3) rotate(30 5 5)``; applied right to left."""
    if text is None or not text.strip():
        return IDENTITY
    result = IDENTITY
    pos = 0
    while pos < len(text):
        m = _FUNC.match(text, pos)
        if m is None:
            if text[pos:].strip(" \t\r\n,"):
                raise TransformError(f"cannot read transform at {text[pos:]!r}")
            break
        name, body = m.group(1).lower(), m.group(2)
        if name not in _ARITY:
            raise TransformError(f"unknown transform function {m.group(1)!r}")
        args = [float(v) for v in _NUMBER.findall(body)]
        leftover = _NUMBER.sub("", body).replace(",", " ").strip()
        if leftover or len(args) not in _ARITY[name]:
            raise TransformError(f"bad arguments to {m.group(1)}({body})")
        result = compose(result, _function(name, args))
        pos = m.end()
    return result
