"""Hand-written SVG documents for importer tests."""

from __future__ import annotations

from pathlib import Path

HEAD = (
    '<svg xmlns="http://www.w3.org/2000/svg" '
    'xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape" {attrs}>'
)


def svg_text(body: str, attrs: str = 'width="20" height="10"') -> str:
    return HEAD.format(attrs=attrs) + body + "</svg>"


def write_svg(tmp_path: Path, body: str, attrs: str = 'width="20" height="10"', name: str = "m.svg") -> Path:
    path = tmp_path / name
    path.write_text(svg_text(body, attrs), encoding="utf-8")
    return path


def rect(label: str, x: float, y: float, w: float = 1, h: float = 1, extra: str = "") -> str:
    return f'<rect inkscape:label="{label}" x="{x}" y="{y}" width="{w}" height="{h}" {extra}/>'


def path(label: str, d: str, extra: str = "") -> str:
    return f'<path inkscape:label="{label}" d="{d}" {extra}/>'


def circle(label: str, cx: float, cy: float, extra: str = "") -> str:
    return f'<circle inkscape:label="{label}" cx="{cx}" cy="{cy}" r="0.3" {extra}/>'


#: Robot spawn and goal zones plus a robot route: the smallest runnable body.
ROBOT = (
    rect("robot_spawn_zone", 1, 1)
    + rect("robot_goal_zone", 17, 8)
    + path("robot_route_0_0", "M 1.5 1.5 L 17.5 8.5")
)
