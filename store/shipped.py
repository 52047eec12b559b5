"""The shipped model registry (``model/registry.yaml``) and THE default-model rule, without the database.

The server loads the shipped entries as read-only registry rows (``store.registry``); in-process runs
(``--local``) read them from here; both pick the default model with :func:`default_model`, so a command means
the same model in either mode.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any, TypeVar

from foresight.core.errors import ConfigError, NotFoundError
from foresight.core.runtime.refs import DEFAULT_MODEL, RESERVED_MODEL_IDS
from foresight.core.yamlio import load_yaml
from foresight.store import folders

T = TypeVar("T")


def _field(entry: Any, name: str) -> Any:
    return entry.get(name) if isinstance(entry, dict) else getattr(entry, name)


def check_model_id(model_id: str) -> None:
    """ConfigError (422) for an id that would shadow a rule: ``default`` registered as a model took over every
    run that names no model, and could never be deleted once used; ``cv`` and ``none`` would be unreachable."""
    if model_id.lower() in RESERVED_MODEL_IDS:
        reserved = ", ".join(sorted(RESERVED_MODEL_IDS))
        raise ConfigError(
            f"model id {model_id!r} is reserved (reserved ids: {reserved}); choose another id", item="id"
        )


def default_model(entries: Iterable[T]) -> T | None:
    """The default model among registry entries (rows or their JSON; in registration order): the entry with
    status ``default``, else a shipped (read-only) entry tagged ``default``."""
    entries = list(entries)
    return next((m for m in entries if _field(m, "status") == "default"), None) or next(
        (m for m in entries if _field(m, "read_only") and "default" in (_field(m, "tags") or [])), None
    )


def shipped_status(entry: dict[str, Any]) -> str:
    """A shipped entry's status: as written, else ``default`` when tagged so, else ``promoted``."""
    return str(entry.get("status") or ("default" if "default" in entry.get("tags", []) else "promoted"))


def read_shipped(path: Path) -> list[dict[str, Any]]:
    """The entries of a shipped registry file (none when it is missing), each with ``status`` and
    ``read_only: True``; ConfigError naming the file and the entry when one lacks id, path or sha256."""
    if not path.is_file():
        return []
    data = load_yaml(path.read_text(), source=path) or {}
    entries = data.get("models", []) if isinstance(data, dict) else []
    out = []
    for i, entry in enumerate(entries):
        if not isinstance(entry, dict) or not {"id", "path", "sha256"} <= entry.keys():
            raise ConfigError("each model needs id, path and sha256", source=path, item=str(i))
        out.append(
            {**entry, "status": shipped_status(entry), "read_only": True, "tags": entry.get("tags", [])}
        )
    return out


def shipped_checkpoint(registry_file: Path, relative: str) -> Path:
    """A shipped checkpoint: paths in the registry file are relative to the project (the file's grandparent)."""
    return folders.resolve_under(registry_file.resolve().parent.parent, relative)


def resolve_shipped(registry_file: Path, ident: str) -> Path:
    """The verified checkpoint of shipped model ``ident`` (``default``: the default model)."""
    entries = read_shipped(registry_file)
    entry = next((m for m in entries if m["id"] == ident), None)
    if entry is None and ident == DEFAULT_MODEL:
        entry = default_model(entries)
    if entry is None:
        raise NotFoundError(
            f"unknown model id {ident!r} (not in {registry_file}; or pass a checkpoint path, or a predictor "
            f"plug-in: {_plugin_hint()})"
        )
    path = shipped_checkpoint(registry_file, str(entry["path"]))
    if not path.is_file():
        raise NotFoundError(f"model {ident!r}: checkpoint {entry['path']} is missing")
    if folders.sha256_file(path) != entry["sha256"]:
        raise ConfigError(
            f"checkpoint {entry['path']} does not match its sha256", source=registry_file, item=ident
        )
    return path


def _plugin_hint() -> str:
    """The installed predictor plug-ins, for an unknown model's error (docs/predictor_protocol.md)."""
    from foresight.core.predict import plugins

    return ", ".join(sorted(plugins.installed())) or "none installed"
