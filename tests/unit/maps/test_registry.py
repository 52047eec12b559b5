"""MapRegistry: the reference catalogue, checksum and capability checks, our own catalogues."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
import yaml

from foresight.core.errors import ConfigError, NotFoundError
from foresight.core.maps import io
from foresight.core.maps.registry import MapRegistry

from .svgdocs import ROBOT, write_svg


@pytest.fixture(scope="module")
def reference_registry(reference_dir: Path) -> MapRegistry:
    return MapRegistry(reference_dir / "maps" / "registry.yaml")


def own_registry(tmp_path: Path, rows: list[dict], **header) -> Path:
    doc = {"version": 2, "schema": "robot_sf.map_catalog.v2", **header, "maps": rows}
    p = tmp_path / "registry.yaml"
    p.write_text(yaml.safe_dump(doc, sort_keys=False))
    return p


def row(map_id: str, path: str, sha: str | None, **caps: bool) -> dict:
    return {
        "map_id": map_id,
        "path": path,
        "source_sha256": sha,
        "capabilities": {"robot_runtime": True, **caps},
    }


def test_reference_registry_header_and_rows(reference_registry: MapRegistry):
    assert (reference_registry.version, reference_registry.schema) == (2, "robot_sf.map_catalog.v2")
    assert reference_registry.parser_version == "parser-capability-metadata.v1"
    assert len(reference_registry) == 79 and "classic_doorway" in reference_registry
    e = reference_registry.entry("classic_doorway")
    assert e.parser_metadata["obstacle_count"] == 6 and e.capabilities["pedestrian_runtime"] is True


def test_cross_trap_resolves_to_classic_crossing(reference_registry: MapRegistry, reference_dir: Path):
    path = reference_registry.resolve("classic_cross_trap")
    assert path == (reference_dir / "maps" / "svg_maps" / "classic_crossing.svg").resolve()
    assert reference_registry.load("classic_cross_trap").name == "classic_crossing"


def test_unknown_id_is_not_found(reference_registry: MapRegistry):
    with pytest.raises(NotFoundError, match=r"registry\.yaml.*'no_such_map'"):
        reference_registry.resolve("no_such_map")


def test_row_whose_file_was_not_copied(reference_registry: MapRegistry):
    with pytest.raises(ConfigError, match="does not exist") as info:
        reference_registry.resolve("MIT_corridor")
    assert info.value.item == "MIT_corridor"


def test_checksum_mismatch_on_a_modified_copy(reference_dir: Path, tmp_path: Path):
    src = reference_dir / "maps"
    (tmp_path / "svg_maps").mkdir()
    shutil.copy(src / "registry.yaml", tmp_path / "registry.yaml")
    target = tmp_path / "svg_maps" / "classic_crossing.svg"
    shutil.copy(src / "svg_maps" / "classic_crossing.svg", target)
    reg = MapRegistry(tmp_path / "registry.yaml")
    assert reg.resolve("classic_cross_trap") == target.resolve()  # untouched copy passes
    expected = reg.entry("classic_cross_trap").source_sha256
    target.write_bytes(target.read_bytes() + b"\n<!-- edited -->\n")
    io.clear_cache()
    with pytest.raises(ConfigError) as info:
        reg.resolve("classic_cross_trap")
    msg = str(info.value)
    assert str(tmp_path / "registry.yaml") in msg and info.value.item == "classic_cross_trap"
    assert f"expected sha256 {expected}" in msg and f"actual {io.file_sha256(target)}" in msg


def test_own_registry_capability_and_relative_paths(tmp_path: Path):
    (tmp_path / "maps").mkdir()
    svg = write_svg(tmp_path / "maps", ROBOT, name="yard.svg")
    sha = io.file_sha256(svg)
    reg = MapRegistry(
        own_registry(
            tmp_path,
            [
                row("yard", "maps/yard.svg", sha, pedestrian_runtime=False),
                row("yard_unpinned", "maps/yard.svg", None),
            ],
        )
    )
    assert reg.ids() == ["yard", "yard_unpinned"]
    assert reg.resolve("yard") == svg.resolve()
    assert reg.resolve("yard_unpinned") == svg.resolve()
    assert reg.resolve("yard", required_capability=None) == svg.resolve()
    with pytest.raises(ConfigError, match="lacks capability 'pedestrian_runtime'"):
        reg.resolve("yard", required_capability="pedestrian_runtime")
    with pytest.raises(ConfigError, match="lacks capability 'benchmark_candidate'"):
        reg.resolve("yard", required_capability="benchmark_candidate")


@pytest.mark.parametrize(
    ("header", "rows", "item", "pattern"),
    [
        ({"version": 1}, [], "version", "unsupported version"),
        ({"schema": "other"}, [], "schema", "unsupported schema"),
        ({}, [{"path": "a.svg"}], "maps[0]", "missing or empty map_id"),
        ({}, [row("a", "a.svg", None), row("a", "b.svg", None)], "maps[1]", "duplicate map id 'a'"),
        ({}, [row("a", "a.svg", "abc")], "a.source_sha256", "not a hex SHA-256"),
        (
            {},
            [{"map_id": "a", "path": "a.svg", "capabilities": {"robot_runtime": "yes"}}],
            "a.capabilities",
            "true/false",
        ),
    ],
)
def test_bad_registry_names_file_and_item(tmp_path: Path, header, rows, item, pattern):
    p = own_registry(tmp_path, rows, **header)
    with pytest.raises(ConfigError, match=pattern) as info:
        MapRegistry(p)
    assert info.value.source == str(p) and info.value.item == item


def test_missing_registry_file(tmp_path: Path):
    with pytest.raises(ConfigError, match="registry not found"):
        MapRegistry(tmp_path / "none.yaml")
