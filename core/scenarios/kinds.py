"""What a YAML/JSON file under a scenario folder is, when it is not a scenario matrix.

The reference keeps contracts, perturbation and pilot manifests, density-tier indexes, catalogs,
route-override payloads, map definitions and result indexes next to its matrices. The loader
refuses those by kind in one line instead of listing their keys as unknown scenario keys.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

#: ``schema_version`` headers of scenario matrices (robot_sf writes the first one).
MATRIX_SCHEMAS = ("robot_sf.scenario_matrix.v1",)

_SCHEMA_KINDS = (  # prefix of a schema/schema_version value -> kind
    ("regulation-record", "regulation record"),
    ("generated-scenario-catalog", "generated-scenario catalog"),
    ("generated-scenario-review-manifest", "generated-scenario review manifest"),
    ("scenario_perturbation_manifest", "perturbation manifest"),
    ("scenario_validation_waivers", "validation waiver list"),
    ("robot_sf.classic_archetype_density_index", "density-tier index"),
    ("scenario_contract", "scenario contract set"),
)
_MAP_KEYS = {"obstacles", "robot_spawn_zones", "robot_goal_zones", "ped_spawn_zones", "x_margin", "y_margin"}
_GENERATOR_KEYS = {"preset", "density", "flow", "obstacle", "goal_topology", "robot_context", "speed_var"}
_MATRIX_KEYS = {"scenarios", "includes", "include", "scenario_files"}


def _schema_kind(value: Any) -> str | None:
    if not isinstance(value, str):
        return None
    for prefix, kind in _SCHEMA_KINDS:
        if value.startswith(prefix):
            return kind
    return None


def _is_generator_spec(entry: Any) -> bool:
    """A parametric scenario-generator entry: an ``id`` plus generator knobs, no map."""
    return (
        isinstance(entry, Mapping)
        and "id" in entry
        and len(_GENERATOR_KEYS & set(entry)) >= 3
        and not {"map_file", "map_id"} & set(entry)
    )


def non_matrix_kind(data: Any) -> str | None:
    """The kind of a parsed file that is not a scenario matrix, or None for a (possible) matrix."""
    if isinstance(data, list):
        return "parametric scenario-generator spec" if data and all(map(_is_generator_spec, data)) else None
    if not isinstance(data, Mapping):
        return None
    for key in ("schema_version", "schema"):
        if key in data and data[key] not in MATRIX_SCHEMAS:
            kind = _schema_kind(data[key])
            if kind is not None:
                return kind
    if _MATRIX_KEYS & set(data):
        return None
    if "contracts" in data:
        return "scenario contract set"
    if "density_tiers" in data:
        return "density-tier index"
    if "variants" in data and "scenario_config" in data:
        return "perturbation manifest"
    if "entries" in data:
        return "generated-scenario catalog"
    if "run" in data and "extractors" in data:
        return "training run config"
    if "route_payload" in data or ({"robot_routes", "ped_routes"} & set(data) and not _MAP_KEYS & set(data)):
        return "route-override payload"
    if _MAP_KEYS & set(data):
        return "map definition"
    if _is_generator_spec(data):
        return "parametric scenario-generator spec"
    if "thresholds" in data or "timestamp" in data:
        return "result index"
    return None
