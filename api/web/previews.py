"""Scenario matrices of a bundle and cached map previews.

A preview is ``core.render.map_view.render_map`` of a scenario's map, kept under
``<store>/web-cache/maps/<hash of the map>.png``: a changed map gets a new file, an unchanged one is drawn once.
"""

from __future__ import annotations

import hashlib
import os
import threading
from functools import lru_cache
from pathlib import Path

from foresight.core.scenarios.model import ScenarioMatrix

CACHE = "web-cache/maps"
_render_lock = threading.Lock()  #: one drawing at a time: previews are CPU work in the server process


@lru_cache(maxsize=32)
def _load(path: str, mtime_ns: int) -> ScenarioMatrix:
    from foresight.core.scenarios.loader import load_matrix

    return load_matrix(Path(path))


def load_matrix_cached(path: Path) -> ScenarioMatrix:
    """The matrix at ``path``, parsed once per file version."""
    return _load(str(path), path.stat().st_mtime_ns)


def map_key(mapdef) -> str:  # noqa: ANN001 (core.maps.model.MapDef)
    return hashlib.sha256(mapdef.model_dump_json().encode()).hexdigest()[:20]


def preview(store_root: Path, mapdef) -> Path:  # noqa: ANN001
    """The PNG preview of ``mapdef``, drawn on first use."""
    path = store_root / CACHE / f"{map_key(mapdef)}.png"
    if path.is_file():
        return path
    from foresight.core.render.map_view import render_map

    with _render_lock:
        if not path.is_file():
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = path.with_name(f".{path.stem}.{os.getpid()}.{threading.get_ident()}.png")
            try:
                render_map(mapdef, tmp)
                os.replace(tmp, path)
            finally:
                tmp.unlink(missing_ok=True)
    return path
