"""What the SVG importer found, in the vocabulary of the reference registry's ``parser_metadata``.

The reference map catalogue stores per-map counts (explicit/parsed/synthetic zones, routes,
obstacles, single-pedestrian markers, route-only flags, limitation codes). The importer fills the
same keys, so an imported map can be checked against that catalogue key by key.
"""

from __future__ import annotations

from dataclasses import dataclass, field

ZONE_KINDS = ("robot_spawn_zone", "robot_goal_zone", "ped_spawn_zone", "ped_goal_zone")

PED_ROUTE_ONLY_MODE = "PED_ROUTE_ONLY_MODE"
ROBOT_ROUTE_ONLY_MODE = "ROBOT_ROUTE_ONLY_MODE"
ROUTE_USES_RISKY_PATH_COMMANDS = "ROUTE_USES_RISKY_PATH_COMMANDS"
ROUTE_CROSSES_OBSTACLE_INTERIOR = "ROUTE_CROSSES_OBSTACLE_INTERIOR"
#: Order in which limitation codes are listed (the reference's order where it shows one).
LIMITATION_ORDER = (
    PED_ROUTE_ONLY_MODE,
    ROBOT_ROUTE_ONLY_MODE,
    ROUTE_USES_RISKY_PATH_COMMANDS,
    ROUTE_CROSSES_OBSTACLE_INTERIOR,
)


@dataclass(frozen=True)
class SemanticBoundary:
    """A ``semantic_boundary_<name>__<flags>`` path: metadata only, never geometry for the simulator."""

    name: str
    flags: tuple[str, ...]
    points: tuple[tuple[float, float], ...]


@dataclass
class SvgReport:
    """Counts and findings of one SVG import (keys as in the reference ``parser_metadata``)."""

    explicit_zones: dict[str, int] = field(default_factory=lambda: dict.fromkeys(ZONE_KINDS, 0))
    parsed_zones: dict[str, int] = field(default_factory=lambda: dict.fromkeys(ZONE_KINDS, 0))
    synthetic_zones: dict[str, int] = field(default_factory=lambda: dict.fromkeys(ZONE_KINDS, 0))
    robot_routes: int = 0
    ped_routes: int = 0
    synthetic_robot_routes: int = 0
    obstacle_count: int = 0
    extra_bounds: int = 0  #: ``bound`` rects (the reference appends them to the 4 map bounds)
    ped_crowded_zones: int = 0
    single_ped_start_markers: int = 0
    single_ped_goal_markers: int = 0
    single_pedestrian_definitions: int = 0
    robot_route_only_mode: bool = False
    ped_route_only_mode: bool = False
    limitation_codes: set[str] = field(default_factory=set)
    semantic_boundaries: list[SemanticBoundary] = field(default_factory=list)
    poi_labels: dict[str, str] = field(default_factory=dict)
    ignored: list[str] = field(default_factory=list)  #: elements with labels the importer does not use
    warnings: list[str] = field(default_factory=list)  #: tolerated problems (the reference logs them)

    def parser_metadata(self) -> dict[str, object]:
        """The counts under the reference registry's ``parser_metadata`` key names."""
        out: dict[str, object] = {}
        for prefix, counts in (
            ("explicit", self.explicit_zones),
            ("parsed", self.parsed_zones),
            ("synthetic", self.synthetic_zones),
        ):
            for kind in ZONE_KINDS:
                out[f"{prefix}_{kind}s"] = counts[kind]
        out.update(
            robot_routes=self.robot_routes,
            ped_routes=self.ped_routes,
            obstacle_count=self.obstacle_count,
            bounds_count=4 + self.extra_bounds,
            ped_crowded_zones=self.ped_crowded_zones,
            single_ped_start_markers=self.single_ped_start_markers,
            single_ped_goal_markers=self.single_ped_goal_markers,
            single_pedestrian_definitions=self.single_pedestrian_definitions,
            robot_route_only_mode=self.robot_route_only_mode,
            ped_route_only_mode=self.ped_route_only_mode,
            has_explicit_robot_runtime_zones=self._has_zones("robot"),
            has_explicit_pedestrian_runtime_zones=self._has_zones("ped"),
            has_robot_runtime_routes=self.robot_routes > 0,
            has_pedestrian_runtime_routes=self.ped_routes > 0,
            has_obstacles=self.obstacle_count > 0,
            parser_limitation_codes=[c for c in LIMITATION_ORDER if c in self.limitation_codes],
        )
        return out

    def _has_zones(self, who: str) -> bool:
        return self.parsed_zones[f"{who}_spawn_zone"] > 0 and self.parsed_zones[f"{who}_goal_zone"] > 0
