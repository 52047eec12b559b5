"""Our human-writable YAML map format ``foresight.map/1`` (see docs/architecture.md and docs/maps.md).

The same fields as ``MapDef`` with two conveniences: a zone may be ``{rect: [x, y, w, h]}`` or
``{corners: [[ax, ay], [bx, by], [cx, cy]]}``, an obstacle ``{rect: [x, y, w, h]}`` or
``{polygon: [[x, y], ...]}``; routes are ``{spawn: i, goal: j, waypoints: [[x, y], ...]}``.
Every problem is a ConfigError naming the file and the item (``obstacles[2]``, ``ped_routes[0].goal``).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import yaml
from pydantic import ValidationError

from foresight.core.errors import ConfigError
from foresight.core.maps import robotsf
from foresight.core.maps.model import MapDef, Point, Route, SinglePedestrian, Zone
from foresight.core.yamlio import load_yaml

FORMAT = "foresight.map/1"
ZONE_FIELDS = (
    "robot_spawn_zones",
    "robot_goal_zones",
    "ped_spawn_zones",
    "ped_goal_zones",
    "ped_crowded_zones",
)
ROUTE_FIELDS = {"robot_routes": "robot", "ped_routes": "ped"}
TOP_KEYS = {
    "format",
    "name",
    "width",
    "height",
    "obstacles",
    "single_pedestrians",
    "pois",
    "poi_labels",
    *ZONE_FIELDS,
    *ROUTE_FIELDS,
}
PED_KEYS = {
    "id",
    "start",
    "goal",
    "trajectory",
    "speed_m_s",
    "wait_at",
    "start_delay_s",
    "note",
    "role",
    "role_target_id",
    "role_offset",
    "hold_until_robot_within_m",
    "hold_ref_point",
    "hold_timeout_s",
    "metadata",
}


class _Reader:
    """Turns the parsed YAML document into model objects, naming the item at fault."""

    def __init__(self, source: str):
        self.source = source

    def fail(self, item: str, message: str) -> ConfigError:
        return ConfigError(message, source=self.source, item=item)

    def number(self, v: Any, item: str) -> float:
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
            raise self.fail(item, f"expected a finite number, got {v!r}")
        return float(v)

    def point(self, v: Any, item: str) -> Point:
        if not isinstance(v, list | tuple) or len(v) != 2:
            raise self.fail(item, f"expected a point [x, y], got {v!r}")
        return (self.number(v[0], item), self.number(v[1], item))

    def points(self, v: Any, item: str, at_least: int) -> tuple[Point, ...]:
        if not isinstance(v, list) or len(v) < at_least:
            raise self.fail(item, f"expected a list of at least {at_least} points [x, y], got {v!r}")
        return tuple(self.point(p, f"{item}[{i}]") for i, p in enumerate(v))

    def mapping(self, v: Any, item: str, allowed: set[str]) -> dict[str, Any]:
        if not isinstance(v, dict):
            raise self.fail(item, f"expected a mapping, got {v!r}")
        unknown = sorted(set(v) - allowed)
        if unknown:
            raise self.fail(item, f"unknown key(s) {unknown}; allowed: {sorted(allowed)}")
        return v

    def one_of(self, v: Any, item: str, keys: tuple[str, str]) -> tuple[str, Any]:
        d = self.mapping(v, item, set(keys))
        if len(d) != 1:
            raise self.fail(item, f"expected exactly one of {list(keys)}, got {sorted(d)}")
        return next(iter(d.items()))

    def rect(self, v: Any, item: str) -> tuple[float, float, float, float]:
        if not isinstance(v, list) or len(v) != 4:
            raise self.fail(item, f"expected rect [x, y, w, h], got {v!r}")
        x, y, w, h = (self.number(c, item) for c in v)
        if w <= 0 or h <= 0:
            raise self.fail(item, f"rect width and height must be positive, got {w} x {h}")
        return x, y, w, h

    def zone(self, v: Any, item: str) -> Zone:
        key, value = self.one_of(v, item, ("rect", "corners"))
        if key == "rect":
            return Zone.from_rect(*self.rect(value, f"{item}.rect"))
        pts = self.points(value, f"{item}.corners", 3)
        if len(pts) != 3:
            raise self.fail(f"{item}.corners", f"expected exactly 3 corners, got {len(pts)}")
        return Zone(corners=(pts[0], pts[1], pts[2]))

    def obstacle(self, v: Any, item: str) -> tuple[Point, ...]:
        key, value = self.one_of(v, item, ("rect", "polygon"))
        if key == "rect":
            x, y, w, h = self.rect(value, f"{item}.rect")
            return ((x, y), (x + w, y), (x + w, y + h), (x, y + h))
        pts = list(self.points(value, f"{item}.polygon", 3))
        if pts[0] == pts[-1]:
            pts.pop()  # a closed ring written with its first vertex repeated
        if len(pts) < 3:
            raise self.fail(f"{item}.polygon", "a polygon needs at least 3 distinct vertices")
        return tuple(pts)

    def route(self, v: Any, item: str, n_spawn: int, n_goal: int) -> Route:
        d = self.mapping(v, item, {"spawn", "goal", "waypoints"})
        ids = {}
        for key, n in (("spawn", n_spawn), ("goal", n_goal)):
            idx = d.get(key, 0)
            if isinstance(idx, bool) or not isinstance(idx, int) or not 0 <= idx < n:
                raise self.fail(f"{item}.{key}", f"zone index {idx!r} out of range: {n} {key} zone(s)")
            ids[key] = idx
        if "waypoints" not in d:
            raise self.fail(item, "missing waypoints")
        wps = self.points(d["waypoints"], f"{item}.waypoints", 2)
        return Route(spawn_id=ids["spawn"], goal_id=ids["goal"], waypoints=wps)

    def single_pedestrian(self, v: Any, item: str) -> SinglePedestrian:
        d = dict(self.mapping(v, item, PED_KEYS))
        for key in ("start", "goal", "role_offset", "hold_ref_point"):
            if d.get(key) is not None:
                d[key] = self.point(d[key], f"{item}.{key}")
        if "trajectory" in d:
            d["trajectory"] = self.points(d["trajectory"], f"{item}.trajectory", 1)
        try:
            return SinglePedestrian(**d)
        except ValidationError as exc:
            err = exc.errors()[0]
            raise self.fail(f"{item}.{'.'.join(map(str, err['loc']))}", err["msg"]) from exc


def _list(r: _Reader, doc: dict[str, Any], key: str) -> list[Any]:
    v = doc.get(key) or []
    if not isinstance(v, list):
        raise r.fail(key, f"expected a list, got {type(v).__name__}")
    return v


def map_from_dict(doc: Any, *, source: str, default_name: str = "map") -> MapDef:
    """Build a MapDef from a parsed ``foresight.map/1`` document."""
    r = _Reader(source)
    doc = r.mapping(doc, "document", TOP_KEYS)
    if doc.get("format") != FORMAT:
        raise r.fail("format", f"expected format: {FORMAT}, got {doc.get('format')!r}")
    fields: dict[str, Any] = {"name": doc.get("name", default_name), "source": source}
    for key in ("width", "height"):
        if key not in doc:
            raise r.fail(key, "missing")
        fields[key] = r.number(doc[key], key)
        if fields[key] <= 0:
            raise r.fail(key, f"must be positive, got {fields[key]}")
    fields["obstacles"] = tuple(
        r.obstacle(o, f"obstacles[{i}]") for i, o in enumerate(_list(r, doc, "obstacles"))
    )
    for key in ZONE_FIELDS:
        fields[key] = tuple(r.zone(z, f"{key}[{i}]") for i, z in enumerate(_list(r, doc, key)))
    for key, who in ROUTE_FIELDS.items():
        n_spawn, n_goal = len(fields[f"{who}_spawn_zones"]), len(fields[f"{who}_goal_zones"])
        fields[key] = tuple(
            r.route(v, f"{key}[{i}]", n_spawn, n_goal) for i, v in enumerate(_list(r, doc, key))
        )
    fields["single_pedestrians"] = tuple(
        r.single_pedestrian(p, f"single_pedestrians[{i}]")
        for i, p in enumerate(_list(r, doc, "single_pedestrians"))
    )
    pois = doc.get("pois") or {}
    if not isinstance(pois, dict):
        raise r.fail("pois", "expected a mapping name -> [x, y]")
    fields["pois"] = {str(k): r.point(v, f"pois.{k}") for k, v in pois.items()}
    labels = doc.get("poi_labels") or {}
    if not isinstance(labels, dict) or not all(str(k) in fields["pois"] for k in labels):
        raise r.fail("poi_labels", "expected a mapping POI id -> label over ids listed in pois")
    fields["poi_labels"] = {str(k): str(v) for k, v in labels.items()}
    try:
        return MapDef(**fields)
    except ValidationError as exc:
        err = exc.errors()[0]
        raise r.fail(".".join(map(str, err["loc"])) or "map", err["msg"]) from exc


def load_native_map(path: str | Path) -> MapDef:
    """Read a ``foresight.map/1`` YAML file (or robot_sf's serialized map format, ``core.maps.robotsf``)."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigError("map file not found", source=p, item="path") from None
    try:
        doc = load_yaml(text, source=p)
    except yaml.YAMLError as exc:
        raise ConfigError(f"malformed YAML: {exc}", source=p, item="yaml") from exc
    if robotsf.is_robotsf_map(doc):
        return robotsf.map_from_robotsf(doc, source=str(p), name=p.stem)
    return map_from_dict(doc, source=str(p), default_name=p.stem)


# -- writing -----------------------------------------------------------------------------------


def _pt(p: Point) -> list[float]:
    return [p[0], p[1]]


def _zone_doc(z: Zone) -> dict[str, Any]:
    """``rect`` when it reads back bit-identical, else ``corners``."""
    (ax, ay), (bx, by), (cx, cy) = z.corners
    w, h = bx - ax, cy - by
    if by == ay and cx == bx and w > 0 and h > 0 and ax + w == bx and ay + h == cy:
        return {"rect": [ax, ay, w, h]}
    return {"corners": [_pt(c) for c in z.corners]}


def _obstacle_doc(poly: tuple[Point, ...]) -> dict[str, Any]:
    if len(poly) == 4:
        (x, y), (bx, _), (_, cy), _ = poly
        w, h = bx - x, cy - y
        if (
            w > 0
            and h > 0
            and x + w == bx
            and y + h == cy
            and poly == ((x, y), (x + w, y), (x + w, y + h), (x, y + h))
        ):
            return {"rect": [x, y, w, h]}
    return {"polygon": [_pt(p) for p in poly]}


def _ped_doc(p: SinglePedestrian) -> dict[str, Any]:
    d = p.model_dump(exclude_defaults=True)
    d["id"], d["start"] = p.id, _pt(p.start)
    if p.goal is not None:
        d["goal"] = _pt(p.goal)
    if p.trajectory:
        d["trajectory"] = [_pt(q) for q in p.trajectory]
    if p.wait_at:
        d["wait_at"] = [w.model_dump(exclude_defaults=True) for w in p.wait_at]
    for key in ("role_offset", "hold_ref_point"):
        if getattr(p, key) is not None:
            d[key] = _pt(getattr(p, key))
    return d


def map_to_dict(m: MapDef) -> dict[str, Any]:
    """The ``foresight.map/1`` document of a map (``source`` is not part of it)."""
    doc: dict[str, Any] = {"format": FORMAT, "name": m.name, "width": m.width, "height": m.height}
    doc["obstacles"] = [_obstacle_doc(o) for o in m.obstacles]
    for key in ZONE_FIELDS[:4]:
        doc[key] = [_zone_doc(z) for z in getattr(m, key)]
    for key in ROUTE_FIELDS:
        doc[key] = [
            {"spawn": r.spawn_id, "goal": r.goal_id, "waypoints": [_pt(p) for p in r.waypoints]}
            for r in getattr(m, key)
        ]
    doc["ped_crowded_zones"] = [_zone_doc(z) for z in m.ped_crowded_zones]
    doc["single_pedestrians"] = [_ped_doc(p) for p in m.single_pedestrians]
    doc["pois"] = {k: _pt(v) for k, v in m.pois.items()}
    if m.poi_labels:
        doc["poi_labels"] = dict(m.poi_labels)
    return doc


def dump_map(m: MapDef) -> str:
    """YAML text that ``load_native_map`` reads back to an equal map (apart from ``source``)."""
    return yaml.safe_dump(map_to_dict(m), sort_keys=False, default_flow_style=None, width=120)
