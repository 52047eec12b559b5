"""A scenario's single pedestrians: overrides of the map's markers, points of interest, role targets.

Everything a single pedestrian names (a point of interest, a role target, a hold reference point)
is resolved and checked here, when the matrix loads, so a wrong name is one error naming the file,
the scenario and the item before any episode runs.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pydantic import ValidationError

from foresight.core.errors import ConfigError
from foresight.core.maps.model import MapDef, SinglePedestrian
from foresight.core.scenarios.model import SinglePedestrianOverride

_NULLABLE = {
    "goal": None,
    "trajectory": (),
    "wait_at": (),
    "note": None,
    "role": None,
    "role_target_id": None,
    "role_offset": None,
    "hold_until_robot_within_m": None,
    "hold_ref_point": None,
    "hold_timeout_s": None,
    "metadata": {},
}
_ROBOT_ROLES = ("follow", "lead", "accompany")


def _poi(mapdef: MapDef, name: str, field: str, source: str | Path, item: str) -> tuple[float, float]:
    try:
        return mapdef.poi(name)
    except KeyError as err:
        raise ConfigError(f"{field}: {err.args[0]}", source=source, item=item) from None


def _changes(ov: SinglePedestrianOverride, mapdef: MapDef, source: str | Path, item: str) -> dict[str, Any]:
    """The fields an override sets, with POI names resolved to points."""
    changes: dict[str, Any] = {}
    for field in ov.model_fields_set - {"id"}:
        value = getattr(ov, field)
        if field == "goal_poi":
            field, value = "goal", None if value is None else _poi(mapdef, value, "goal_poi", source, item)
        elif field == "trajectory_poi":
            field, value = (
                "trajectory",
                None
                if value is None
                else tuple(_poi(mapdef, v, "trajectory_poi", source, item) for v in value),
            )
        if value is None and field not in _NULLABLE:
            raise ConfigError(f"{field} may not be null", source=source, item=item)
        changes[field] = _NULLABLE[field] if value is None else value
    return changes


def apply_single_pedestrians(
    mapdef: MapDef,
    overrides: tuple[SinglePedestrianOverride, ...],
    *,
    source: str | Path,
    scenario: str,
    default_hold_ref_point: tuple[float, float] | None = None,
) -> MapDef:
    """The map with the scenario's single-pedestrian overrides applied by id, every name resolved and checked.

    An id the map lacks is a new pedestrian when the entry gives ``start``; metadata merges into the
    marker's. ``default_hold_ref_point`` (the scenario's event-contract conflict point) stands in for
    a missing ``hold_ref_point``, as in robot_sf.
    """
    peds = {p.id: p for p in mapdef.single_pedestrians}
    for ov in overrides:
        item = f"{scenario}.single_pedestrians[{ov.id}]"
        if ov.id not in peds and ov.start is None:
            have = ", ".join(peds) or "none"
            raise ConfigError(
                f"the map has no single pedestrian {ov.id!r} (has: {have}); a new one needs a start",
                source=source,
                item=item,
            )
        changes = _changes(ov, mapdef, source, item)
        base = peds[ov.id].model_dump() if ov.id in peds else {"id": ov.id}
        if changes.get("metadata"):
            changes["metadata"] = {**base.get("metadata", {}), **changes["metadata"]}
        merged = {**base, **changes}
        if merged.get("hold_until_robot_within_m") is not None and merged.get("hold_ref_point") is None:
            merged["hold_ref_point"] = default_hold_ref_point
        try:
            peds[ov.id] = SinglePedestrian.model_validate(merged)
        except ValidationError as err:
            from foresight.core.scenarios.files import validation_message

            raise ConfigError(validation_message(err), source=source, item=item) from err
    for ped in peds.values():
        check_single_pedestrian(ped, peds, source=source, item=f"{scenario}.single_pedestrians[{ped.id}]")
    if not overrides:
        return mapdef
    fields = {k: getattr(mapdef, k) for k in MapDef.model_fields}
    return MapDef(**{**fields, "single_pedestrians": tuple(peds.values())})


def check_single_pedestrian(
    ped: SinglePedestrian, peds: dict[str, SinglePedestrian], *, source: str | Path, item: str
) -> None:
    """A role target that exists and fits the role; a hold reference point on the trajectory."""
    target = ped.role_target_id
    if target is not None:
        if ped.role in _ROBOT_ROLES:
            if target not in ("robot", "robot:0"):
                raise ConfigError(
                    f"role_target_id {target!r}: the only robot is 'robot' (or 'robot:0')",
                    source=source,
                    item=item,
                )
        elif ped.role == "join":
            if target not in peds or target == ped.id:
                others = ", ".join(p for p in peds if p != ped.id) or "none"
                raise ConfigError(
                    f"role_target_id {target!r}: no other single pedestrian has that id (have: {others})",
                    source=source,
                    item=item,
                )
        else:
            raise ConfigError(
                f"role_target_id {target!r} is not used by role {ped.role!r}", source=source, item=item
            )
    if ped.role_offset is not None and ped.role not in _ROBOT_ROLES:
        raise ConfigError(f"role_offset is not used by role {ped.role!r}", source=source, item=item)
    if ped.hold_until_robot_within_m is not None:
        ref = ped.hold_ref_point
        if not any(abs(q[0] - ref[0]) <= 1e-6 and abs(q[1] - ref[1]) <= 1e-6 for q in ped.trajectory):
            raise ConfigError(
                f"hold_ref_point {list(ref)} is not a waypoint of the trajectory (the hold engages "
                "at the waypoint before it)",
                source=source,
                item=item,
            )
