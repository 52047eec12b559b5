"""Route overrides (robot_sf ``route_overrides_file`` and inline ``route_overrides``) and generated replays.

A route override replaces the map's robot and/or pedestrian routes. A route whose ``spawn_id`` or
``goal_id`` has no zone in the map gets a 0.1 m zone at its first or last waypoint, as robot_sf
does; the robot then starts and ends (almost exactly) at the route's ends.
"""

from __future__ import annotations

from pathlib import Path

from pydantic import ValidationError

from foresight.core.errors import ConfigError
from foresight.core.maps.model import MapDef, Point, Route, SinglePedestrian, Zone
from foresight.core.scenarios.model import GeneratedReplay, RouteOverrides, RouteSpec

_SYNTHETIC_EDGE = 0.1  #: side of the zone made for a route end without one [m] (robot_sf's)


def read_route_overrides(path: Path, *, scenario: str, referenced_from: Path) -> RouteOverrides:
    """A route-override file: ``robot_routes``/``ped_routes`` at the top or under ``route_payload``.

    Other top-level keys of such files (optimizer provenance, diagnostics) describe how the routes
    were found and are not read.
    """
    from foresight.core.scenarios.files import read_yaml, validation_message

    data = read_yaml(path, referenced_from=referenced_from, item=f"{scenario}.route_overrides_file")
    if not isinstance(data, dict):
        raise ConfigError("a route-override file must be a mapping", source=path)
    payload = data.get("route_payload", data)
    if not isinstance(payload, dict) or not {"robot_routes", "ped_routes"} & set(payload):
        raise ConfigError(
            "expected robot_routes and/or ped_routes (at the top or under route_payload)", source=path
        )
    try:
        return RouteOverrides.model_validate(
            {k: payload[k] for k in ("robot_routes", "ped_routes") if k in payload}
        )
    except ValidationError as err:
        raise ConfigError(validation_message(err), source=path, item="route_payload") from err


def _zone_at(point: Point) -> Zone:
    x, y = point
    return Zone(corners=((x, y), (x + _SYNTHETIC_EDGE, y), (x + _SYNTHETIC_EDGE, y + _SYNTHETIC_EDGE)))


def _routes(specs: tuple[RouteSpec, ...], spawns: list[Zone], goals: list[Zone]) -> tuple[Route, ...]:
    """Routes of the specs; ``spawns``/``goals`` (the map's zones) grow by a zone per route end lacking one."""
    out = []
    for spec in specs:
        spawn, goal = spec.spawn_id, spec.goal_id
        if spawn is None or spawn >= len(spawns):
            spawns.append(_zone_at(spec.waypoints[0]))
            spawn = len(spawns) - 1
        if goal is None or goal >= len(goals):
            goals.append(_zone_at(spec.waypoints[-1]))
            goal = len(goals) - 1
        out.append(Route(spawn_id=spawn, goal_id=goal, waypoints=spec.waypoints))
    return tuple(out)


def apply_route_overrides(mapdef: MapDef, overrides: RouteOverrides) -> MapDef:
    """The map with its robot and/or pedestrian routes replaced (a kind without override routes is kept)."""
    fields = {k: getattr(mapdef, k) for k in MapDef.model_fields}
    for who in ("robot", "ped"):
        specs = getattr(overrides, f"{who}_routes")
        if specs:
            spawns, goals = list(fields[f"{who}_spawn_zones"]), list(fields[f"{who}_goal_zones"])
            fields[f"{who}_routes"] = _routes(specs, spawns, goals)
            fields[f"{who}_spawn_zones"], fields[f"{who}_goal_zones"] = tuple(spawns), tuple(goals)
    return MapDef(**fields)


def apply_generated_replay(
    mapdef: MapDef, replay: GeneratedReplay, *, source: str | Path, item: str
) -> tuple[MapDef, RouteOverrides | None]:
    """Replay pedestrians become single pedestrians walking their recorded path; the robot's start and goal a route.

    Returns the map with the pedestrians added and the robot route override (None without a robot).
    """
    have = {p.id for p in mapdef.single_pedestrians}
    clash = sorted(have & {p.id for p in replay.pedestrians})
    if clash:
        raise ConfigError(
            f"generated_replay pedestrian ids {clash} clash with the map's single pedestrians",
            source=source,
            item=item,
        )
    peds = tuple(
        SinglePedestrian(id=p.id, start=p.start, trajectory=p.trajectory) for p in replay.pedestrians
    )
    fields = {k: getattr(mapdef, k) for k in MapDef.model_fields}
    fields["single_pedestrians"] = (*mapdef.single_pedestrians, *peds)
    if replay.robot is None:
        return MapDef(**fields), None
    route = RouteSpec(waypoints=(replay.robot.start, replay.robot.goal))
    return MapDef(**fields), RouteOverrides(robot_routes=(route,))
