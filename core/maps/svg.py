"""Import the reference's labelled Inkscape SVG maps into ``MapDef``.

Follows the reference reading (reference-simulation.md section 5): 1 user unit = 1 m, no y-flip,
viewBox origin shifted to (0, 0), labels from ``inkscape:label`` then ``id``, and SVG ``transform``
attributes ignored, because that is what the reference simulator runs on. ``apply_transforms=True``
instead reads the map as drawn in the editor (see docs/maps.md for the maps where that differs). The document
itself (XML, size, shapes with their transforms) is read by ``core.maps.svgdoc``; this module gives the shapes
their meaning.
"""

from __future__ import annotations

import logging
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

from pydantic import ValidationError

from foresight.core.errors import ConfigError
from foresight.core.maps import geometry, svgpath, svgtransform
from foresight.core.maps.model import MapDef, Point, Route, SinglePedestrian, Zone
from foresight.core.maps.svgdoc import INKSCAPE_LABEL, Element, collect_shapes, document_size, parse_xml
from foresight.core.maps.svgreport import (
    PED_ROUTE_ONLY_MODE,
    ROBOT_ROUTE_ONLY_MODE,
    ROUTE_CROSSES_OBSTACLE_INTERIOR,
    ROUTE_USES_RISKY_PATH_COMMANDS,
    ZONE_KINDS,
    SemanticBoundary,
    SvgReport,
)

log = logging.getLogger(__name__)

ROUTE_ONLY_ZONE_EDGE = 1.0  #: synthetic zone edge when a map has no zones of a kind [m]
INDEX_FALLBACK_ZONE_EDGE = 0.1  #: synthetic zone edge when a route's zone index is out of range [m]

_INDEXED_ZONE = re.compile(r"^(robot_spawn_zone|ped_spawn_zone|robot_goal_zone|ped_goal_zone)_(\d+)$")
_PLAIN_ZONE = re.compile(r"^(robot_spawn_zone|ped_spawn_zone|robot_goal_zone|ped_goal_zone)$")
_SINGLE_PED = re.compile(r"^single_ped_(?P<pid>.+)_(?P<kind>start|goal)$")
_STRICT_ROUTE_LABEL = re.compile(r"^(ped_route|robot_route)(?:_(\d+)_(\d+))?$")
_RISKY_COMMANDS = frozenset("HhVvCcQqSsTtAa")


@dataclass(frozen=True)
class SvgImport:
    """An imported map and the importer's report on it."""

    map: MapDef
    report: SvgReport


@dataclass
class _Zones:
    """Zones of one kind: explicitly indexed ones, unindexed ones in document order, then synthetic."""

    indexed: dict[int, Zone] = field(default_factory=dict)
    unindexed: list[Zone] = field(default_factory=list)
    assembled: list[Zone] = field(default_factory=list)


class _Importer:
    """One import: reads elements, then builds zones, routes, obstacles and markers in the reference order."""

    def __init__(self, root: ET.Element, source: str, apply_transforms: bool):
        self.source = source
        self.apply_transforms = apply_transforms
        self.report = SvgReport()
        self.width, self.height, self.origin = document_size(root, source)
        self.elements = collect_shapes(root, source, apply_transforms)
        self.zones = {k: _Zones() for k in ZONE_KINDS}
        self.obstacles: list[tuple[Point, ...]] = []
        self.crowded: list[Zone] = []
        self.routes: dict[str, list[Route]] = {"robot": [], "ped": []}
        self.pois: dict[str, Point] = {}
        self.poi_labels: dict[str, str] = {}

    def error(self, message: str, item: str | None = None) -> ConfigError:
        return ConfigError(message, source=self.source, item=item)

    def warn(self, message: str) -> None:
        log.warning("%s: %s", self.source, message)
        self.report.warnings.append(message)

    # -- document ------------------------------------------------------------------------------

    def world(self, el: Element, p: Point) -> Point:
        """Element coordinates -> map frame [m]: transform (if applied), then viewBox origin shift."""
        x, y = svgtransform.apply(el.matrix, p)
        return (x - self.origin[0], y - self.origin[1])

    def number(self, el: Element, name: str, default: float | None = None) -> float:
        text = el.attrib.get(name)
        if text is None and default is not None:
            return default
        try:
            return float(text)  # type: ignore[arg-type]
        except (TypeError, ValueError):
            raise self.error(f"attribute {name}={text!r} is not a number", el.describe()) from None

    # -- rects ---------------------------------------------------------------------------------

    def _rect_corners(self, el: Element) -> tuple[Point, Point, Point, Point]:
        x, y = self.number(el, "x", 0.0), self.number(el, "y", 0.0)
        w, h = self.number(el, "width"), self.number(el, "height")
        return tuple(self.world(el, p) for p in ((x, y), (x + w, y), (x + w, y + h), (x, y + h)))  # type: ignore[return-value]

    def read_rects(self) -> None:
        for el in self.elements["rect"]:
            kind, index = self._zone_kind(el)
            label = el.label
            if kind is None and label not in ("obstacle", "ped_crowded_zone", "bound"):
                self.report.ignored.append(el.describe())
                continue
            corners = self._rect_corners(el)
            if kind is not None:
                self._add_zone(kind, index, Zone(corners=corners[:3]), el)
            elif label == "obstacle":
                self.obstacles.append(corners)
            elif label == "ped_crowded_zone":
                self.crowded.append(Zone(corners=corners[:3]))
            else:
                self.report.extra_bounds += 1
                self.warn(f"{el.describe()}: 'bound' rect counted but not used (MapDef has no extra bounds)")
        for kind, zones in self.zones.items():
            zones.assembled = self._assemble(kind, zones)
            self.report.parsed_zones[kind] = len(zones.assembled)

    @staticmethod
    def _zone_kind(el: Element) -> tuple[str | None, int | None]:
        """Zone kind and explicit index: indexed names first (label, then id), then plain names."""
        candidates = [c for c in (el.label, el.elem_id) if c]
        for c in candidates:
            if m := _INDEXED_ZONE.match(c):
                return m.group(1), int(m.group(2))
        for c in candidates:
            if m := _PLAIN_ZONE.match(c):
                return m.group(1), None
        return None, None

    def _add_zone(self, kind: str, index: int | None, zone: Zone, el: Element) -> None:
        self.report.explicit_zones[kind] += 1
        zones = self.zones[kind]
        if index is None:
            zones.unindexed.append(zone)
        elif index in zones.indexed:
            self.warn(f"{el.describe()}: duplicate {kind} index {index}; keeping the first")
        else:
            zones.indexed[index] = zone

    def _assemble(self, kind: str, zones: _Zones) -> list[Zone]:
        """Position k = zone indexed k; gaps filled by unindexed zones in order; leftovers appended."""
        if not zones.indexed:
            return list(zones.unindexed)
        rest = list(zones.unindexed)
        out: list[Zone] = []
        for k in range(max(zones.indexed) + 1):
            if k in zones.indexed:
                out.append(zones.indexed[k])
            elif rest:
                out.append(rest.pop(0))
            else:
                self.warn(f"{kind} index {k} missing and no unindexed zone left to fill it")
        return out + rest

    # -- paths ---------------------------------------------------------------------------------

    def _path_points(self, el: Element) -> list[Point]:
        d = el.attrib.get("d", "")
        try:
            raw = svgpath.parse_path(d)
        except svgpath.PathDataError as exc:
            raise self.error(f"path data: {exc}", el.describe()) from exc
        pts: list[Point] = []
        for p in raw:
            w = self.world(el, p)
            if not pts or abs(w[0] - pts[-1][0]) > 1e-9 or abs(w[1] - pts[-1][1]) > 1e-9:
                pts.append(w)
        return pts

    def read_paths(self) -> None:
        """Obstacles, crowded zones and semantic boundaries; routes need all zones, so they come after."""
        route_paths: list[tuple[str, Element]] = []
        for el in self.elements["path"]:
            label = el.label
            if "ped_route" in label:
                route_paths.append(("ped", el))
            elif "robot_route" in label:
                route_paths.append(("robot", el))
            elif label == "obstacle":
                self._obstacle_path(el)
            elif label == "crowded_zone":
                self._crowded_path(el)
            elif label.startswith("semantic_boundary_"):
                name, _, flags = label[len("semantic_boundary_") :].partition("__")
                self.report.semantic_boundaries.append(
                    SemanticBoundary(
                        name, tuple(f for f in flags.split("__") if f), tuple(self._path_points(el))
                    )
                )
            else:
                log.debug("%s: ignoring path %s", self.source, el.describe())
                self.report.ignored.append(el.describe())
        for who in ("robot", "ped"):
            spawn, goal = self.zones[f"{who}_spawn_zone"], self.zones[f"{who}_goal_zone"]
            route_only = not spawn.assembled and not goal.assembled
            mine = [el for w, el in route_paths if w == who]
            if route_only and mine:
                setattr(self.report, f"{who}_route_only_mode", True)
                self.report.limitation_codes.add(
                    PED_ROUTE_ONLY_MODE if who == "ped" else ROBOT_ROUTE_ONLY_MODE
                )
            for el in mine:
                self.routes[who].append(self._route(who, el, route_only))
                self._check_commands(el)

    def _obstacle_path(self, el: Element) -> None:
        pts = self._path_points(el)
        if len(pts) > 1 and pts[0] == pts[-1]:
            pts.pop()  # stored open: last != first
        if len(pts) < 3:
            raise self.error(
                f"obstacle path has {len(pts)} distinct vertices, expected at least 3", el.describe()
            )
        if geometry.ring_self_intersects(pts):
            self.warn(f"{el.describe()}: obstacle polygon intersects itself; kept as drawn (not repaired)")
        self.obstacles.append(tuple(pts))

    def _crowded_path(self, el: Element) -> None:
        pts = self._path_points(el)
        if len(pts) == 4 and pts[0] == pts[-1]:
            pts.pop()
        if len(pts) != 3:
            self.warn(f"{el.describe()}: crowded_zone path needs exactly 3 points, has {len(pts)}; skipped")
            return
        self.crowded.append(Zone(corners=(pts[0], pts[1], pts[2])))

    def _route_indices(self, el: Element) -> tuple[int, int]:
        """Spawn/goal indices = first two integers in the label; none -> (0, 0); exactly one is an error."""
        numbers = re.findall(r"\d+", el.label)
        if len(numbers) == 1:
            raise self.error(
                f"route label {el.label!r} has one integer; write <kind>_route_<spawn>_<goal> or no index",
                el.describe(),
            )
        return (int(numbers[0]), int(numbers[1])) if numbers else (0, 0)

    def _route(self, who: str, el: Element, route_only: bool) -> Route:
        pts = self._path_points(el)
        if len(pts) < 2:
            raise self.error(f"route has {len(pts)} distinct points, expected at least 2", el.describe())
        spawn_id, goal_id = self._route_indices(el)
        spawn_id = self._zone_for(f"{who}_spawn_zone", spawn_id, pts[0], route_only, el)
        goal_id = self._zone_for(f"{who}_goal_zone", goal_id, pts[-1], route_only, el)
        return Route(spawn_id=spawn_id, goal_id=goal_id, waypoints=tuple(pts))

    def _zone_for(self, kind: str, index: int, anchor: Point, route_only: bool, el: Element) -> int:
        """The zone list index a route uses, appending a synthetic triangle zone at ``anchor`` if needed."""
        zones = self.zones[kind].assembled
        n_explicit = self.report.parsed_zones[kind]
        if 0 <= index < n_explicit:
            return index
        if route_only:
            edge = ROUTE_ONLY_ZONE_EDGE
        else:
            edge = INDEX_FALLBACK_ZONE_EDGE
            self.warn(
                f"{el.describe()}: {kind} index {index} out of range ({n_explicit} zones); synthetic zone used"
            )
        x, y = anchor
        zones.append(Zone(corners=((x, y), (x + edge, y), (x + edge, y + edge))))
        self.report.synthetic_zones[kind] += 1
        return len(zones) - 1

    def _check_commands(self, el: Element) -> None:
        """Flag routes drawn with commands the reference's catalogue calls risky (H/V/curves/arcs)."""
        if not _STRICT_ROUTE_LABEL.match(el.attrib.get(INKSCAPE_LABEL, "")):
            return
        if svgpath.path_commands(el.attrib.get("d", "")) & _RISKY_COMMANDS:
            self.report.limitation_codes.add(ROUTE_USES_RISKY_PATH_COMMANDS)

    # -- circles -------------------------------------------------------------------------------

    def read_circles(self) -> list[SinglePedestrian]:
        markers: dict[str, dict[str, Point]] = {}
        pois: dict[str, Point] = {}
        for el in self.elements["circle"]:
            label = el.label
            centre = None
            if label.startswith("single_ped_"):
                m = _SINGLE_PED.match(label)
                if m is None:
                    self.warn(f"{el.describe()}: expected single_ped_<id>_start or _goal; ignored")
                    continue
                slot = markers.setdefault(m.group("pid"), {})
                if m.group("kind") in slot:
                    self.warn(f"{el.describe()}: duplicate {label}; keeping the first")
                    continue
                centre = self._centre(el)
                slot[m.group("kind")] = centre
            if "poi" in el.attrib.get("class", "").split() or label == "poi":
                key = el.elem_id or label
                pois[key] = centre or self._centre(el)
                self.report.poi_labels[key] = label
                if label not in (key, "poi"):
                    self.poi_labels[key] = label
            elif centre is None:
                self.report.ignored.append(el.describe())
        self.pois = pois
        return self._single_peds(markers)

    def _centre(self, el: Element) -> Point:
        return self.world(el, (self.number(el, "cx", 0.0), self.number(el, "cy", 0.0)))

    def _single_peds(self, markers: dict[str, dict[str, Point]]) -> list[SinglePedestrian]:
        peds = []
        for pid, slot in markers.items():
            self.report.single_ped_start_markers += "start" in slot
            self.report.single_ped_goal_markers += "goal" in slot
            if "start" not in slot:
                self.warn(f"single pedestrian {pid!r} has a goal marker but no start; skipped")
                continue
            peds.append(SinglePedestrian(id=pid, start=slot["start"], goal=slot.get("goal")))
        self.report.single_pedestrian_definitions = len(peds)
        return peds

    # -- assembly ------------------------------------------------------------------------------

    def synthetic_robot_routes(self) -> None:
        """No robot route but spawn and goal zones: straight routes between zone 'centres' for every pair.

        The reference's centre is the mean of the 3 stored corners, (x + 2w/3, y + h/3) for a rect.
        """
        spawns, goals = self.zones["robot_spawn_zone"].assembled, self.zones["robot_goal_zone"].assembled
        if self.routes["robot"] or not spawns or not goals:
            return
        for i, s in enumerate(spawns):
            for j, g in enumerate(goals):
                self.routes["robot"].append(Route(spawn_id=i, goal_id=j, waypoints=(_mean3(s), _mean3(g))))
        self.report.synthetic_robot_routes = len(self.routes["robot"])

    def check_route_obstacles(self) -> None:
        for who, routes in self.routes.items():
            for k, route in enumerate(routes):
                for obstacle in self.obstacles:
                    if geometry.polyline_enters_interior(route.waypoints, obstacle):
                        self.report.limitation_codes.add(ROUTE_CROSSES_OBSTACLE_INTERIOR)
                        self.warn(f"{who} route {k} runs through an obstacle interior")
                        break

    def build(self, name: str) -> MapDef:
        self.read_rects()
        self.read_paths()
        peds = self.read_circles()
        self.synthetic_robot_routes()
        self.check_route_obstacles()
        r = self.report
        r.robot_routes, r.ped_routes = len(self.routes["robot"]), len(self.routes["ped"])
        r.obstacle_count, r.ped_crowded_zones = len(self.obstacles), len(self.crowded)
        z = {k: tuple(v.assembled) for k, v in self.zones.items()}
        try:
            return MapDef(
                name=name,
                width=self.width,
                height=self.height,
                obstacles=tuple(self.obstacles),
                robot_spawn_zones=z["robot_spawn_zone"],
                robot_goal_zones=z["robot_goal_zone"],
                robot_routes=tuple(self.routes["robot"]),
                ped_spawn_zones=z["ped_spawn_zone"],
                ped_goal_zones=z["ped_goal_zone"],
                ped_routes=tuple(self.routes["ped"]),
                ped_crowded_zones=tuple(self.crowded),
                single_pedestrians=tuple(peds),
                pois=self.pois,
                poi_labels=self.poi_labels,
                source=self.source,
            )
        except ValidationError as exc:
            raise self.error(f"map is not valid: {exc.errors()[0]['msg']}", name) from exc


def _mean3(zone: Zone) -> Point:
    (ax, ay), (bx, by), (cx, cy) = zone.corners
    return ((ax + bx + cx) / 3.0, (ay + by + cy) / 3.0)


def parse_svg_text(text: str | bytes, *, name: str, source: str, apply_transforms: bool = False) -> SvgImport:
    """Import SVG text; ``source`` names the file in error messages."""
    importer = _Importer(parse_xml(text, source), source, apply_transforms)
    return SvgImport(importer.build(name), importer.report)


def read_svg(path: str | Path, *, apply_transforms: bool = False) -> SvgImport:
    """Import an SVG map file with the importer's report (parser metadata, warnings)."""
    p = Path(path)
    try:
        data = p.read_bytes()
    except FileNotFoundError:
        raise ConfigError("map file not found", source=p, item="path") from None
    except IsADirectoryError:
        raise ConfigError("map path is a directory, expected an .svg file", source=p, item="path") from None
    return parse_svg_text(data, name=p.stem, source=str(p), apply_transforms=apply_transforms)


def load_svg_map(path: str | Path, *, apply_transforms: bool = False) -> MapDef:
    """Import an SVG map file (reference reading unless ``apply_transforms``)."""
    return read_svg(path, apply_transforms=apply_transforms).map
