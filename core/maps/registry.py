"""Map catalogues: map id -> file, pinned by checksum and gated by capability.

Reads the reference's ``maps/registry.yaml`` (schema ``robot_sf.map_catalog.v2``); our own
catalogues use the same schema. Paths are relative to the registry file. ``resolve`` refuses a
file whose bytes changed since it was catalogued (sha256) or that lacks the required capability.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from foresight.core import files
from foresight.core.errors import ConfigError, NotFoundError
from foresight.core.maps.io import file_sha256, load_map
from foresight.core.maps.model import MapDef
from foresight.core.yamlio import load_yaml

SCHEMA = "robot_sf.map_catalog.v2"
SUPPORTED_VERSIONS = frozenset({2})
DEFAULT_CAPABILITY = "robot_runtime"


@dataclass(frozen=True)
class MapEntry:
    """One catalogue row."""

    map_id: str
    path: Path  #: absolute (resolved against the registry file's folder)
    source_sha256: str | None = None
    role: str | None = None
    profile: str | None = None
    capabilities: dict[str, bool] = field(default_factory=dict)
    parser_metadata: dict[str, Any] = field(default_factory=dict)
    limitations: tuple[str, ...] = ()
    validation: dict[str, Any] = field(default_factory=dict)


class MapRegistry:
    """A map catalogue file; look maps up by id."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        doc = self._read()
        self.version: int = doc["version"]
        self.schema: str = doc["schema"]
        self.parser_version: str | None = doc.get("parser_version")
        self._entries: dict[str, MapEntry] = {}
        rows = doc.get("maps")
        if not isinstance(rows, list):
            raise self._error("expected a list of map rows", "maps")
        for i, row in enumerate(rows):
            entry = self._entry(row, f"maps[{i}]")
            if entry.map_id in self._entries:
                raise self._error(f"duplicate map id {entry.map_id!r}", f"maps[{i}]")
            self._entries[entry.map_id] = entry

    def _error(self, message: str, item: str) -> ConfigError:
        return ConfigError(message, source=self.path, item=item)

    def _read(self) -> dict[str, Any]:
        try:
            doc = load_yaml(self.path.read_text(encoding="utf-8"), source=self.path)
        except FileNotFoundError:
            raise ConfigError("map registry not found", source=self.path, item="path") from None
        except yaml.YAMLError as exc:
            raise self._error(f"malformed YAML: {exc}", "yaml") from exc
        if not isinstance(doc, dict):
            raise self._error("expected a mapping with version, schema and maps", "document")
        if doc.get("version") not in SUPPORTED_VERSIONS:
            raise self._error(
                f"unsupported version {doc.get('version')!r}; supported: {sorted(SUPPORTED_VERSIONS)}",
                "version",
            )
        if doc.get("schema") != SCHEMA:
            raise self._error(f"unsupported schema {doc.get('schema')!r}; expected {SCHEMA}", "schema")
        return doc

    def _entry(self, row: Any, item: str) -> MapEntry:
        if not isinstance(row, dict):
            raise self._error("expected a mapping", item)
        for key in ("map_id", "path"):
            if not isinstance(row.get(key), str) or not row[key]:
                raise self._error(f"missing or empty {key}", item)
        caps = row.get("capabilities") or {}
        if not isinstance(caps, dict) or not all(isinstance(v, bool) for v in caps.values()):
            raise self._error("capabilities must map names to true/false", f"{row['map_id']}.capabilities")
        sha = row.get("source_sha256")
        if sha is not None and (not isinstance(sha, str) or len(sha) != 64):
            raise self._error(f"source_sha256 {sha!r} is not a hex SHA-256", f"{row['map_id']}.source_sha256")
        return MapEntry(
            map_id=row["map_id"],
            path=(self.path.parent / row["path"]).resolve(),
            source_sha256=sha.lower() if sha else None,
            role=row.get("role"),
            profile=row.get("profile"),
            capabilities=dict(caps),
            parser_metadata=dict(row.get("parser_metadata") or {}),
            limitations=tuple(row.get("limitations") or ()),
            validation=dict(row.get("validation") or {}),
        )

    def __contains__(self, map_id: object) -> bool:
        return map_id in self._entries

    def __len__(self) -> int:
        return len(self._entries)

    def ids(self) -> list[str]:
        """Map ids in catalogue order."""
        return list(self._entries)

    def entry(self, map_id: str) -> MapEntry:
        try:
            return self._entries[map_id]
        except KeyError:
            raise NotFoundError(f"{self.path}: unknown map id {map_id!r}") from None

    def resolve(self, map_id: str, required_capability: str | None = DEFAULT_CAPABILITY) -> Path:
        """The map's file after checking existence, checksum and capability (None skips the capability check)."""
        e = self.entry(map_id)
        if not e.path.is_file():
            raise self._error(f"map file {e.path} does not exist", map_id)
        if e.source_sha256 is not None:
            actual = file_sha256(e.path)
            if actual != e.source_sha256:
                raise self._error(
                    f"checksum mismatch for {e.path}: expected sha256 {e.source_sha256}, actual {actual}",
                    map_id,
                )
        if required_capability is not None and e.capabilities.get(required_capability) is not True:
            raise self._error(f"map lacks capability {required_capability!r} (has {e.capabilities})", map_id)
        return e.path

    def load(
        self,
        map_id: str,
        required_capability: str | None = DEFAULT_CAPABILITY,
        *,
        apply_transforms: bool = False,
    ) -> MapDef:
        """Resolve and load a map by id."""
        return load_map(self.resolve(map_id, required_capability), apply_transforms=apply_transforms)


def refresh_checksums(path: str | Path, *, write: bool = True) -> dict[str, tuple[str | None, str]]:
    """Recompute every row's ``source_sha256`` after maps were edited; returns {map_id: (old, new)} for changed rows.

    The file is rewritten textually (old hash -> new hash) so its comments and layout survive.
    """
    registry = MapRegistry(path)
    changed: dict[str, tuple[str | None, str]] = {}
    text = registry.path.read_text(encoding="utf-8")
    for map_id in registry.ids():
        e = registry.entry(map_id)
        if not e.path.is_file():
            raise ConfigError(f"map file {e.path} does not exist", source=registry.path, item=map_id)
        new = file_sha256(e.path)
        if new == e.source_sha256:
            continue
        if e.source_sha256 is None or text.count(e.source_sha256) != 1:
            raise ConfigError(
                "cannot update the checksum in place (missing or repeated hash)", source=path, item=map_id
            )
        text = text.replace(e.source_sha256, new)
        changed[map_id] = (e.source_sha256, new)
    if write and changed:
        files.write_text(registry.path, text)
    return changed
