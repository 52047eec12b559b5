"""Load a map file of any supported kind, once per file version.

Maps are parsed once per episode batch and shared (``MapDef`` is frozen), so results are cached
by (resolved path, modification time, size, options): an edited file is read again.
"""

from __future__ import annotations

import functools
import hashlib
from pathlib import Path

from foresight.core.errors import ConfigError
from foresight.core.maps import native, svg
from foresight.core.maps.model import MapDef

SVG_SUFFIXES = frozenset({".svg"})
YAML_SUFFIXES = frozenset({".yaml", ".yml"})
_CACHE_SIZE = 128  #: distinct (file, version, option) entries kept


def _stat(path: str | Path) -> tuple[Path, int, int]:
    p = Path(path)
    try:
        resolved = p.resolve(strict=True)
        st = resolved.stat()
    except FileNotFoundError:
        raise ConfigError("map file not found", source=p, item="path") from None
    if not resolved.is_file():
        raise ConfigError("map path is not a file", source=p, item="path")
    return resolved, st.st_mtime_ns, st.st_size


@functools.lru_cache(maxsize=_CACHE_SIZE)
def _load_cached(resolved: Path, _mtime_ns: int, _size: int, apply_transforms: bool) -> MapDef:
    suffix = resolved.suffix.lower()
    if suffix in SVG_SUFFIXES:
        return svg.load_svg_map(resolved, apply_transforms=apply_transforms)
    return native.load_native_map(resolved)


def load_map(path: str | Path, *, apply_transforms: bool = False) -> MapDef:
    """Load an ``.svg`` (reference reading unless ``apply_transforms``) or ``.yaml``/``.yml`` map.

    ``apply_transforms`` only concerns SVG files. A missing file or an unknown suffix is a ConfigError.
    """
    suffix = Path(path).suffix.lower()
    if suffix not in SVG_SUFFIXES | YAML_SUFFIXES:
        raise ConfigError(
            f"unknown map file type {suffix!r}; expected .svg, .yaml or .yml", source=path, item="path"
        )
    resolved, mtime_ns, size = _stat(path)
    return _load_cached(resolved, mtime_ns, size, apply_transforms and suffix in SVG_SUFFIXES)


def clear_cache() -> None:
    """Forget every cached map (tests, long-lived workers after bulk edits)."""
    _load_cached.cache_clear()
    _sha256_cached.cache_clear()


@functools.lru_cache(maxsize=_CACHE_SIZE)
def _sha256_cached(resolved: Path, _mtime_ns: int, _size: int) -> str:
    h = hashlib.sha256()
    with resolved.open("rb") as f:
        for block in iter(lambda: f.read(1 << 16), b""):
            h.update(block)
    return h.hexdigest()


def file_sha256(path: str | Path) -> str:
    """Hex SHA-256 of a file's bytes (registry checksums); cached per file version."""
    return _sha256_cached(*_stat(path))
