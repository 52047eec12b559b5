"""load_map dispatch and caching; file_sha256."""

from __future__ import annotations

import hashlib
import os

import pytest

from foresight.core.errors import ConfigError
from foresight.core.maps import io
from foresight.core.maps.native import dump_map

from .svgdocs import ROBOT, path, write_svg

BODY = ROBOT + '<g transform="translate(0,2)">' + path("ped_route", "M 1 1 L 5 1") + "</g>"


@pytest.fixture(autouse=True)
def _fresh_cache():
    io.clear_cache()
    yield
    io.clear_cache()


def test_dispatch_on_suffix(tmp_path):
    svg = write_svg(tmp_path, BODY)
    m = io.load_map(svg)
    for name in ("m.yaml", "m.YML"):
        (tmp_path / name).write_text(dump_map(m))
        assert io.load_map(tmp_path / name).robot_routes == m.robot_routes


def test_apply_transforms_reaches_the_svg_importer(tmp_path):
    svg = write_svg(tmp_path, BODY)
    assert io.load_map(svg).ped_routes[0].waypoints[0] == (1, 1)
    assert io.load_map(svg, apply_transforms=True).ped_routes[0].waypoints[0] == (1, 3)


def test_cache_returns_same_object_until_the_file_changes(tmp_path):
    svg = write_svg(tmp_path, BODY)
    first = io.load_map(svg)
    assert io.load_map(str(svg)) is first
    assert io.load_map(tmp_path / "." / "m.svg") is first  # same resolved path
    write_svg(tmp_path, BODY.replace("L 5 1", "L 6 1"))
    st = svg.stat()
    os.utime(svg, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))
    second = io.load_map(svg)
    assert second is not first and second.ped_routes[0].waypoints[-1] == (6, 1)


def test_missing_file_and_unknown_suffix(tmp_path):
    with pytest.raises(ConfigError, match="absent.svg.*not found") as info:
        io.load_map(tmp_path / "absent.svg")
    assert info.value.item == "path"
    (tmp_path / "m.json").write_text("{}")
    with pytest.raises(ConfigError, match="unknown map file type '.json'"):
        io.load_map(tmp_path / "m.json")


def test_file_sha256(tmp_path):
    p = tmp_path / "f.bin"
    p.write_bytes(b"foresight" * 10000)
    assert io.file_sha256(p) == hashlib.sha256(b"foresight" * 10000).hexdigest()
    with pytest.raises(ConfigError, match="not found"):
        io.file_sha256(tmp_path / "missing")
