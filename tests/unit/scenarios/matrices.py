"""Tiny matrices and maps written into a temporary folder for the loader tests."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from foresight.core.maps.io import file_sha256


def write(path: Path, data: Any) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(
        data if isinstance(data, str) else yaml.safe_dump(data, sort_keys=False), encoding="utf-8"
    )
    return path


def tiny_map(
    name: str = "tiny", *, singles: tuple[str, ...] = ("s1",), route_spawn: int = 0
) -> dict[str, Any]:
    """A 20 x 10 m foresight.map/1 document with one obstacle, one route of each kind and single peds."""
    return {
        "format": "foresight.map/1",
        "name": name,
        "width": 20,
        "height": 10,
        "obstacles": [{"rect": [9, 0, 2, 2]}],
        "robot_spawn_zones": [{"rect": [1, 4, 2, 2]}],
        "robot_goal_zones": [{"rect": [17, 4, 2, 2]}],
        "robot_routes": [{"spawn": 0, "goal": 0, "waypoints": [[2, 5], [18, 5]]}],
        "ped_spawn_zones": [{"rect": [9, 8, 2, 1]}],
        "ped_goal_zones": [{"rect": [9, 3, 2, 1]}],
        "ped_routes": [{"spawn": route_spawn, "goal": 0, "waypoints": [[10, 8.5], [10, 3.5]]}],
        "single_pedestrians": [
            {"id": s, "start": [5, 2], "goal": [15, 2], "speed_m_s": 0.5} for s in singles
        ],
    }


def scenario(name: str, **extra: Any) -> dict[str, Any]:
    data: dict[str, Any] = {"name": name, "map_file": "tiny.yaml", "simulation_config": {"ped_density": 0.02}}
    data.update(extra)
    return data


def registry(path: Path, rows: dict[str, Path], *, sha: dict[str, str] | None = None) -> Path:
    """A map registry (reference schema) for ``map_id -> file``, checksums current unless given."""
    maps = []
    for map_id, file in rows.items():
        digest = (sha or {}).get(map_id) or file_sha256(file)
        maps.append(
            {
                "map_id": map_id,
                "path": str(file.relative_to(path.parent)),
                "source_sha256": digest,
                "capabilities": {"robot_runtime": True},
            }
        )
    return write(path, {"version": 2, "schema": "robot_sf.map_catalog.v2", "maps": maps})
