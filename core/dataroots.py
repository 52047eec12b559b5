"""Named data roots: where a data set such as ``ethucy`` lives on this machine.

Configs and job specs name a data root (``ethucy``), never a folder; this module is the one reading
of the names: ``FORESIGHT_DATA_ROOTS`` (``name=path,name=path``) plus ``ethucy`` from the shared
reference folder (``FORESIGHT_SHARED``, default ``../shared`` next to the project) unless a root is
named so. The service settings (``store.settings``) and the library (replay scenes of a scenario
matrix, read by whoever loads it) both use it.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

from foresight.core.errors import NotFoundError

ROOT_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,63}$")
DEFAULT_SHARED = Path(__file__).resolve().parent.parent.parent / "shared"  #: ../shared next to the project


def parse_data_roots(value: str) -> dict[str, Path]:
    """``"ethucy=/data/ethucy,other=/x"`` -> {name: resolved folder}; ValueError naming a malformed entry."""
    roots: dict[str, Path] = {}
    for entry in (e.strip() for e in value.split(",")):
        if not entry:
            continue
        name, sep, path = (x.strip() for x in entry.partition("="))
        if not sep or not path or not ROOT_NAME.match(name):
            raise ValueError(
                f"data root entry {entry!r}: expected NAME=PATH (NAME: letters, digits, '.', '_', '-')"
            )
        roots[name] = Path(path).expanduser().resolve()
    return roots


def named_data_roots(value: str, shared: Path) -> dict[str, Path]:
    """Data root name -> folder: the parsed ``value``, plus ``ethucy`` from ``shared`` when it exists."""
    roots = parse_data_roots(value)
    ethucy = Path(shared) / "reference" / "ethucy"
    if "ethucy" not in roots and ethucy.is_dir():
        roots["ethucy"] = ethucy.resolve()
    return roots


def pick_root(roots: dict[str, Path], name: str) -> Path:
    """The folder of data root ``name``; NotFoundError naming the known roots."""
    if name not in roots:
        known = ", ".join(sorted(roots)) or "none (set FORESIGHT_DATA_ROOTS)"
        raise NotFoundError(f"unknown data root {name!r}; known: {known}")
    return roots[name]


def data_root(name: str) -> Path:
    """Data root ``name`` from the environment (``FORESIGHT_DATA_ROOTS``, ``FORESIGHT_SHARED``)."""
    shared = Path(os.environ.get("FORESIGHT_SHARED") or DEFAULT_SHARED)
    return pick_root(named_data_roots(os.environ.get("FORESIGHT_DATA_ROOTS", ""), shared), name)
