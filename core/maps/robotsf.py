"""robot_sf's own serialized map format (JSON/YAML with ``x_margin``/``y_margin``), read into a MapDef.

As robot_sf's ``serialize_map``: the map spans ``x_margin`` x ``y_margin`` and every coordinate is
shifted by the margins' minimum; obstacles are vertex lists, zones three corners, routes
``{spawn_id, goal_id, waypoints}``. ``infrastructure_zones`` (stairs, pedestrian-only cuts,
crossing boxes, each with ``allowed_actor_types``) are route-certification input in robot_sf: a
robot route that enters a zone which does not admit robots is refused here, when the map loads.
The simulator does not otherwise enforce such zones (see docs/scenarios.md).
"""

from __future__ import annotations

from typing import Any

from pydantic import ValidationError

from foresight.core.errors import ConfigError
from foresight.core.maps import geometry
from foresight.core.maps.model import MapDef, Route, Zone

KEYS = {
    "x_margin",
    "y_margin",
    "obstacles",
    "robot_spawn_zones",
    "robot_goal_zones",
    "ped_spawn_zones",
    "ped_goal_zones",
    "ped_crowded_zones",
    "robot_routes",
    "ped_routes",
    "infrastructure_zones",
}
ROBOT_ACTORS = {"robot", "amv", "vehicle"}  #: actor names that mean the robot in ``allowed_actor_types``


def is_robotsf_map(doc: Any) -> bool:
    return isinstance(doc, dict) and "x_margin" in doc and "y_margin" in doc


def map_from_robotsf(doc: dict[str, Any], *, source: str, name: str) -> MapDef:
    """A MapDef from a robot_sf serialized map; unknown keys and robot routes through closed zones are errors."""
    unknown = sorted(set(doc) - KEYS)
    if unknown:
        raise ConfigError(
            f"unknown key(s) {unknown} in a robot_sf map; allowed: {sorted(KEYS)}", source=source
        )
    try:
        (x0, x1), (y0, y1) = doc["x_margin"], doc["y_margin"]

        def pt(p: Any) -> tuple[float, float]:
            return (float(p[0]) - x0, float(p[1]) - y0)

        def zones(key: str) -> tuple[Zone, ...]:
            return tuple(Zone(corners=tuple(pt(c) for c in z)) for z in doc.get(key) or [])

        def routes(key: str) -> tuple[Route, ...]:
            return tuple(
                Route(spawn_id=r["spawn_id"], goal_id=r["goal_id"], waypoints=tuple(map(pt, r["waypoints"])))
                for r in doc.get(key) or []
            )

        mapdef = MapDef(
            name=name,
            width=x1 - x0,
            height=y1 - y0,
            source=source,
            obstacles=tuple(tuple(map(pt, o)) for o in doc.get("obstacles") or []),
            robot_spawn_zones=zones("robot_spawn_zones"),
            robot_goal_zones=zones("robot_goal_zones"),
            ped_spawn_zones=zones("ped_spawn_zones"),
            ped_goal_zones=zones("ped_goal_zones"),
            ped_crowded_zones=zones("ped_crowded_zones"),
            robot_routes=routes("robot_routes"),
            ped_routes=routes("ped_routes"),
        )
    except (KeyError, TypeError, ValueError, ValidationError) as err:
        raise ConfigError(f"not a valid robot_sf map: {err}", source=source) from None
    for zone in doc.get("infrastructure_zones") or []:
        allowed = {str(a).lower() for a in zone.get("allowed_actor_types", [])}
        if allowed & ROBOT_ACTORS:
            continue
        ring = [pt(v) for v in zone.get("vertices", [])]
        for k, route in enumerate(mapdef.robot_routes):
            if len(ring) >= 3 and geometry.polyline_enters_interior(route.waypoints, ring):
                raise ConfigError(
                    f"robot route {k} enters infrastructure zone {zone.get('id')!r} ({zone.get('zone_type')}), "
                    f"which admits only {sorted(allowed)}",
                    source=source,
                    item=f"infrastructure_zones.{zone.get('id')}",
                )
    return mapdef
