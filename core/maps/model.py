"""The map model: static geometry, zones, routes and scripted pedestrians of one scene.

Coordinates are metres in the map frame. Like the reference (robot_sf) maps, the frame has its
origin at the top-left of the picture and y grows downward in an SVG rendering; the simulator does
not care about the handedness. The same model is written by the SVG importer and by our own
human-writable YAML format (``core.maps.native``), so every map is validated in one place.
"""

from __future__ import annotations

import functools
import math
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

Point = tuple[float, float]


class _Frozen(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")


class Zone(_Frozen):
    """A rectangular (parallelogram) zone given by three corners a, b, c; the fourth is a + c - b.

    The reference stores rects as (top-left, top-right, bottom-right) and samples only the triangle
    a-b-c (half the rectangle); ``core.sim`` offers both readings.
    """

    corners: tuple[Point, Point, Point]

    @property
    def area(self) -> float:
        """Full parallelogram area [m^2] (the reference's |ab|*|bc|)."""
        (ax, ay), (bx, by), (cx, cy) = self.corners
        return math.hypot(ax - bx, ay - by) * math.hypot(cx - bx, cy - by)

    @property
    def centre(self) -> Point:
        """Centre of the full parallelogram [m]."""
        (ax, ay), _, (cx, cy) = self.corners
        return ((ax + cx) / 2.0, (ay + cy) / 2.0)

    @classmethod
    def from_rect(cls, x: float, y: float, w: float, h: float) -> Zone:
        return cls(corners=((x, y), (x + w, y), (x + w, y + h)))


class Route(_Frozen):
    """A polyline with the indices of the spawn and goal zones it connects (>= 2 waypoints)."""

    spawn_id: int = Field(ge=0)
    goal_id: int = Field(ge=0)
    waypoints: tuple[Point, ...] = Field(min_length=2)

    @functools.cached_property
    def array(self) -> np.ndarray:
        """Waypoints as an (K, 2) float array [m]."""
        return np.asarray(self.waypoints, dtype=float)

    @property
    def length(self) -> float:
        """Polyline length [m]."""
        return float(np.linalg.norm(np.diff(self.array, axis=0), axis=1).sum())


class WaitRule(_Frozen):
    """Hold a single pedestrian at trajectory waypoint ``waypoint_index`` for ``wait_s`` seconds."""

    waypoint_index: int = Field(ge=0)
    wait_s: float = Field(ge=0)
    note: str | None = None


Role = Literal["wait", "follow", "lead", "accompany", "join", "leave"]


class SinglePedestrian(_Frozen):
    """A scripted pedestrian: start, then a goal or a list of waypoints, with optional waits.

    A ``role`` (reference robot_sf semantics, ``core.sim.behaviours.SingleScripts``): ``wait`` holds
    the start; ``follow``/``lead``/``accompany`` head for a point ``role_offset`` (forward, lateral
    [m], robot frame) from the robot (``role_target_id`` ``robot``/``robot:0``; ``lead`` only while
    the ped has no goal or trajectory); ``join`` walks to another single pedestrian
    (``role_target_id``) and stays with it; ``leave`` leaves its group (single peds walk alone).
    A proximity hold stops the ped at the trajectory waypoint before ``hold_ref_point`` until the
    robot is within ``hold_until_robot_within_m`` of that point or ``hold_timeout_s`` has passed.
    """

    id: str = Field(min_length=1)
    start: Point
    goal: Point | None = None
    trajectory: tuple[Point, ...] = ()
    speed_m_s: float = Field(default=0.5, ge=0)  #: spawn speed [m/s]; desired speed = speed_mult * this
    wait_at: tuple[WaitRule, ...] = ()
    start_delay_s: float = Field(default=0.0, ge=0)
    note: str | None = None
    role: Role | None = None
    role_target_id: str | None = None  #: "robot", "robot:0" or a single pedestrian id
    role_offset: Point | None = None  #: (forward, lateral) [m]; default per role (ROLE_OFFSETS)
    hold_until_robot_within_m: float | None = Field(default=None, gt=0)
    hold_ref_point: Point | None = None
    hold_timeout_s: float | None = Field(default=None, gt=0)  #: None = DEFAULT_HOLD_TIMEOUT_S
    metadata: dict[str, Any] = Field(default_factory=dict)

    @model_validator(mode="after")
    def _hold_needs_a_point(self) -> SinglePedestrian:
        if self.hold_until_robot_within_m is not None and self.hold_ref_point is None:
            raise ValueError(f"single pedestrian {self.id!r}: hold_until_robot_within_m needs hold_ref_point")
        return self


#: Default (forward, lateral) offsets from the robot of the robot-relative roles [m] (robot_sf's).
ROLE_OFFSETS: dict[str, Point] = {"follow": (-1.0, 0.0), "lead": (1.5, 0.0), "accompany": (0.0, 1.0)}
#: Fail-open release of a proximity hold without ``hold_timeout_s`` [s] (robot_sf's default).
DEFAULT_HOLD_TIMEOUT_S = 6.0


class MapDef(_Frozen):
    """One map: bounds [0, width] x [0, height], obstacle polygons, zones, routes, scripted peds."""

    name: str = Field(min_length=1)
    width: float = Field(gt=0)
    height: float = Field(gt=0)
    obstacles: tuple[tuple[Point, ...], ...] = ()  #: closed polygons (last vertex != first), >= 3 vertices
    robot_spawn_zones: tuple[Zone, ...] = ()
    robot_goal_zones: tuple[Zone, ...] = ()
    robot_routes: tuple[Route, ...] = ()
    ped_spawn_zones: tuple[Zone, ...] = ()
    ped_goal_zones: tuple[Zone, ...] = ()
    ped_routes: tuple[Route, ...] = ()
    ped_crowded_zones: tuple[Zone, ...] = ()
    single_pedestrians: tuple[SinglePedestrian, ...] = ()
    pois: dict[str, Point] = Field(default_factory=dict)  #: points of interest by id [m]
    poi_labels: dict[str, str] = Field(default_factory=dict)  #: POI id -> human label (SVG inkscape:label)
    source: str | None = None  #: file it was read from (for error messages and provenance)

    @field_validator("obstacles")
    @classmethod
    def _polygons_have_three_vertices(cls, v: tuple[tuple[Point, ...], ...]) -> tuple[tuple[Point, ...], ...]:
        for i, poly in enumerate(v):
            if len(poly) < 3:
                raise ValueError(f"obstacle {i} has {len(poly)} vertices, expected at least 3")
        return v

    @model_validator(mode="after")
    def _routes_reference_zones(self) -> MapDef:
        for kind, routes, spawns, goals in (
            ("robot", self.robot_routes, self.robot_spawn_zones, self.robot_goal_zones),
            ("ped", self.ped_routes, self.ped_spawn_zones, self.ped_goal_zones),
        ):
            for i, r in enumerate(routes):
                if r.spawn_id >= len(spawns) or r.goal_id >= len(goals):
                    raise ValueError(
                        f"{kind} route {i} references spawn zone {r.spawn_id} / goal zone {r.goal_id}, "
                        f"but the map has {len(spawns)} spawn and {len(goals)} goal zones"
                    )
        ids = [p.id for p in self.single_pedestrians]
        dup = {i for i in ids if ids.count(i) > 1}
        if dup:
            raise ValueError(f"duplicate single pedestrian ids: {sorted(dup)}")
        return self

    @functools.cached_property
    def obstacle_segments(self) -> np.ndarray:
        """Edges of all obstacle polygons as an (S, 4) array of (x1, y1, x2, y2) [m], zero-length edges dropped."""
        segs = []
        for poly in self.obstacles:
            p = np.asarray(poly, dtype=float)
            q = np.roll(p, -1, axis=0)
            segs.append(np.hstack([p, q]))
        if not segs:
            return np.zeros((0, 4))
        s = np.vstack(segs)
        keep = np.hypot(s[:, 2] - s[:, 0], s[:, 3] - s[:, 1]) > 1e-9
        return s[keep]

    @functools.cached_property
    def bound_segments(self) -> np.ndarray:
        """The four map-boundary lines as a (4, 4) array of (x1, y1, x2, y2) [m]."""
        w, h = self.width, self.height
        return np.array([[0, 0, w, 0], [0, h, w, h], [0, 0, 0, h], [w, 0, w, h]], dtype=float)

    @functools.cached_property
    def all_segments(self) -> np.ndarray:
        """Obstacle edges plus map bounds, (S + 4, 4): what pedestrians feel and the robot collides with."""
        return np.vstack([self.obstacle_segments, self.bound_segments])

    def poi(self, name: str) -> Point:
        """A point of interest by label (as robot_sf looks it up) or by id; KeyError names the known ones."""
        for key, label in self.poi_labels.items():
            if label == name:
                return self.pois[key]
        if name in self.pois:
            return self.pois[name]
        known = sorted({*self.pois, *self.poi_labels.values()})
        raise KeyError(f"the map has no point of interest {name!r} (has: {', '.join(known) or 'none'})")

    def single_pedestrian(self, ped_id: str) -> SinglePedestrian:
        for p in self.single_pedestrians:
            if p.id == ped_id:
                return p
        raise KeyError(ped_id)
