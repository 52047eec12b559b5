"""Store paths: relative names only, resolved under the root; atomic writes."""

from __future__ import annotations

from pathlib import Path

import pytest

from foresight.store import folders


@pytest.mark.parametrize(
    "name", ["/etc/passwd", "../x", "a/../../b", "a\\..\\b", "C:\\x", "", "\\\\server\\share"]
)
def test_check_relative_refuses_unsafe_names(name: str) -> None:
    with pytest.raises(folders.UnsafePath):
        folders.check_relative(name)


def test_check_relative_normalises() -> None:
    assert folders.check_relative("a//b/./c.txt") == "a/b/c.txt"


def test_resolve_under_refuses_symlink_escape(tmp_path: Path) -> None:
    root = tmp_path / "root"
    root.mkdir()
    (root / "link").symlink_to(tmp_path)
    with pytest.raises(folders.UnsafePath):
        folders.resolve_under(root, "link/secret")


def test_write_atomic_leaves_no_temp_files(tmp_path: Path) -> None:
    target = tmp_path / "d" / "f.bin"
    folders.write_atomic(target, b"abc")
    folders.write_atomic(target, b"xyz")
    assert target.read_bytes() == b"xyz"
    assert [p.name for p in target.parent.iterdir()] == ["f.bin"]


@pytest.mark.parametrize(
    "value,unsafe",
    [
        ("/abs", True),
        ("~/x", True),
        ("a/../b", True),
        ("crossing_low", False),
        ("scenarios/classic.yaml", False),
        ("..", True),
        ("a..b", False),
    ],
)
def test_looks_unsafe(value: str, unsafe: bool) -> None:
    assert folders.looks_unsafe(value) is unsafe
