"""A registered predictor's folder (``models/<id>/`` in the store): what runs it, and its files.

``predictor.json`` names the kind (plugin | external) and the predictor; ``files/`` holds its artifacts. The store
hashes every file against the registration before it hands the folder over (``store.model_kinds``), so a run
that gets a folder gets the files that were registered.
"""

from __future__ import annotations

import json
from pathlib import Path

from foresight.core.errors import ConfigError

DESCRIPTOR = "predictor.json"
FILES = "files"
PREDICTOR_KINDS = ("plugin", "external")


def is_registered(path: str | Path | None) -> bool:
    """Whether a resolved model path is a registered predictor's folder (not a checkpoint file)."""
    return path is not None and (Path(path) / DESCRIPTOR).is_file()


def files_dir(path: str | Path) -> str:
    """The folder of a registered predictor's files, handed to it (``artifacts``)."""
    return str(Path(path) / FILES)


def predictor_name(path: str | Path) -> str:
    """The predictor plug-in name a registered folder runs; ConfigError naming the file when it is unreadable."""
    source = Path(path) / DESCRIPTOR
    try:
        data = json.loads(source.read_text())
        kind, name = data["kind"], data["predictor"]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ConfigError(f"not a registered predictor descriptor ({exc})", source=source) from None
    if kind not in PREDICTOR_KINDS or not isinstance(name, str):
        raise ConfigError(f"kind {kind!r}, expected one of {', '.join(PREDICTOR_KINDS)}", source=source)
    return name
