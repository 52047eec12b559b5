"""Load a scenario matrix: expand includes, apply overrides, resolve and load every scenario's map.

A matrix file is YAML: a bare list of scenarios, or a mapping with ``scenarios`` and manifest keys.
Reading it the way the reference (robot_sf) does, but with every key checked:

- ``includes`` (aliases ``include``, ``scenario_files``): files relative to the including file,
  expanded recursively (a cycle is an error naming the cycle); included scenarios come first,
  then the file's own ``scenarios``.
- ``map_search_paths``: folders relative to the file that declares them; they apply to that
  file's scenarios and to everything it includes.
- ``map_file`` is tried relative to the root manifest's folder, then the declaring file's
  folder, then each search path in scope (the root's first), then each folder above the
  declaring file (robot_sf names some maps relative to its repository root).
- ``map_id`` (wins over ``map_file``) is resolved through a map registry, chosen as: the
  ``map_registry`` argument, else the root manifest's ``map_registry:`` key (relative to the
  manifest), else the first ``registry.yaml`` found in the parent folder of a search path or in
  the search path itself, else ``maps/registry.yaml`` in a folder above the declaring file (the
  reference layout: maps in ``maps/svg_maps``, registry in ``maps/registry.yaml``). As in the reference, a map loaded by id is named by its id (so
  ``classic_cross_trap`` stays distinct from ``classic_crossing``, which it is read from).
- Root manifest only: ``select_scenarios`` (ordered, case-insensitive), ``scenario_overrides``
  (deep-merged into every scenario), ``scenario_overrides_by_name``, ``map_registry``,
  ``metadata`` (kept on the matrix) and ``seeds`` (default seed list for scenarios without one).
- ``evaluation``, ``evaluation_reason``, ``evaluation_replacement``, ``description``: notes the
  reference puts on archetype files; kept under the matrix metadata ``file_notes``.
- ``schema_version`` (must name a scenario-matrix schema) and ``defaults`` (a block that only
  holds YAML anchors the scenarios alias; the reference never applies it, nor do we).
- A file that is not a scenario matrix (contract set, perturbation manifest, density-tier index,
  catalog, route payload, map, result index; ``core.scenarios.kinds``) is refused by kind.

- ``replay`` (instead of a map): recorded pedestrians of a data root's scene, and a map built from
  the scene's bounds (``core.scenarios.replay``); the scene is read and checked here.

Scenario keys (single pedestrians, route overrides, generated replays, visibility, compositions) and
every choice made where robot_sf is silent: docs/scenarios.md. Anything else is a
:class:`~core.errors.ConfigError` naming the file, the scenario and the key.
"""

from __future__ import annotations

import copy
import functools
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, ValidationError, model_validator

from foresight.core.dataroots import data_root
from foresight.core.errors import ConfigError, NotFoundError
from foresight.core.maps.io import file_sha256, load_map
from foresight.core.maps.model import MapDef
from foresight.core.maps.registry import MapRegistry
from foresight.core.scenarios.files import read_yaml, validation_message
from foresight.core.scenarios.kinds import MATRIX_SCHEMAS, non_matrix_kind
from foresight.core.scenarios.model import (
    ResolvedScenario,
    Scenario,
    ScenarioMatrix,
)
from foresight.core.scenarios.replay import SceneFiles, replay_scene
from foresight.core.scenarios.routes import (
    apply_generated_replay,
    apply_route_overrides,
    read_route_overrides,
)
from foresight.core.scenarios.singles import apply_single_pedestrians

_INCLUDE_ALIASES = ("includes", "include", "scenario_files")
_ROOT_ONLY = (
    "select_scenarios",
    "scenario_overrides",
    "scenario_overrides_by_name",
    "map_registry",
    "metadata",
    "seeds",
)
_NOTE_KEYS = ("evaluation", "evaluation_reason", "evaluation_replacement", "description")
_REGISTRY_NAME = "registry.yaml"


class _FileSpec(BaseModel):
    """The keys a matrix file may hold; scenarios stay raw until overrides are merged in."""

    model_config = ConfigDict(extra="forbid")

    includes: tuple[str, ...] = ()
    scenarios: tuple[Any, ...] = ()
    map_search_paths: tuple[str, ...] = ()
    select_scenarios: tuple[str, ...] | None = None
    scenario_overrides: dict[str, Any] = {}
    scenario_overrides_by_name: dict[str, dict[str, Any]] = {}
    map_registry: str | None = None
    metadata: dict[str, Any] = {}
    seeds: tuple[int, ...] | None = None
    evaluation: str | None = None
    evaluation_reason: str | None = None
    evaluation_replacement: str | None = None
    description: str | None = None
    schema_version: str | None = None
    defaults: dict[str, Any] = {}  #: a block of YAML anchors for the scenarios to alias; never applied itself

    @model_validator(mode="before")
    @classmethod
    def _include_aliases(cls, data: Any) -> Any:
        if isinstance(data, list):
            return {"scenarios": data}
        if not isinstance(data, dict):
            raise ValueError(f"expected a list of scenarios or a mapping, got {type(data).__name__}")
        used = [k for k in _INCLUDE_ALIASES if k in data]
        if len(used) > 1:
            raise ValueError(f"give includes once, not as {' and '.join(used)}")
        data = dict(data)
        if used:
            data["includes"] = data.pop(used[0])
        if isinstance(data.get("includes"), str):
            data["includes"] = [data["includes"]]
        version = data.get("schema_version")
        if version is not None and version not in MATRIX_SCHEMAS:
            raise ValueError(
                f"schema_version {version!r} is not a scenario matrix schema (expected one of "
                f"{', '.join(MATRIX_SCHEMAS)})"
            )
        return data


@dataclass(frozen=True)
class _Entry:
    """A raw scenario mapping with where it was declared and the map search paths in its scope."""

    data: Mapping[str, Any]
    file: Path
    index: int
    search_paths: tuple[Path, ...]

    @property
    def raw_name(self) -> str:
        name = self.data.get("name", self.data.get("scenario_id"))
        return name if isinstance(name, str) and name else f"scenarios[{self.index}]"


def _parse_spec(data: Any, source: Path, *, is_root: bool) -> _FileSpec:
    if data is None:
        raise ConfigError("the file is empty", source=source)
    kind = non_matrix_kind(data)
    if kind is not None:
        raise ConfigError(f"not a scenario matrix (it is a {kind})", source=source)
    try:
        spec = _FileSpec.model_validate(data)
    except ValidationError as err:
        loc = err.errors()[0]["loc"]
        raise ConfigError(
            validation_message(err), source=source, item=str(loc[0]) if loc else "manifest"
        ) from err
    if not is_root:
        for key in _ROOT_ONLY:
            if key in spec.model_fields_set:
                raise ConfigError("only supported in the root manifest", source=source, item=key)
    return spec


def _expand(
    path: Path, spec: _FileSpec, chain: tuple[Path, ...], search: tuple[Path, ...]
) -> tuple[list[_Entry], dict]:
    """Entries of ``path`` and its includes (includes first), plus the informational notes of each file."""
    search = search + tuple((path.parent / p).resolve() for p in spec.map_search_paths)
    entries: list[_Entry] = []
    notes: dict[str, dict] = {}
    own_notes = {k: getattr(spec, k) for k in _NOTE_KEYS if getattr(spec, k) is not None}
    if own_notes:
        notes[str(path)] = own_notes
    for inc in spec.includes:
        inc_path = (path.parent / inc).resolve()
        if inc_path in chain:
            cycle = " -> ".join(p.name for p in (*chain[chain.index(inc_path) :], inc_path))
            raise ConfigError(f"include cycle: {cycle}", source=path, item=inc)
        inc_spec = _parse_spec(read_yaml(inc_path, referenced_from=path, item=inc), inc_path, is_root=False)
        sub_entries, sub_notes = _expand(inc_path, inc_spec, (*chain, inc_path), search)
        entries += sub_entries
        notes.update(sub_notes)
    for i, raw in enumerate(spec.scenarios):
        if not isinstance(raw, dict):
            raise ConfigError(
                f"a scenario must be a mapping, got {type(raw).__name__}", source=path, item=f"scenarios[{i}]"
            )
        entries.append(_Entry(raw, path, i, search))
    return entries, notes


def _deep_merge(base: Mapping[str, Any], over: Mapping[str, Any]) -> dict[str, Any]:
    """``over`` merged into a copy of ``base``: nested mappings merge, anything else replaces."""
    out = dict(base)
    for key, value in over.items():
        if isinstance(value, Mapping) and isinstance(out.get(key), Mapping):
            out[key] = _deep_merge(out[key], value)
        else:
            out[key] = copy.deepcopy(value)
    return out


def _check_names(entries: list[_Entry]) -> dict[str, _Entry]:
    """Entries by case-folded name; a repeated name (ignoring case) is an error."""
    by_name: dict[str, _Entry] = {}
    for e in entries:
        key = e.raw_name.casefold()
        if key in by_name:
            first = by_name[key]
            raise ConfigError(
                f"duplicate scenario name (first declared in {first.file})", source=e.file, item=e.raw_name
            )
        by_name[key] = e
    return by_name


def _select(entries: list[_Entry], spec: _FileSpec, source: Path) -> list[_Entry]:
    """Apply ``select_scenarios`` (ordered, case-insensitive) after checking every named scenario exists."""
    by_name = _check_names(entries)
    for name in spec.scenario_overrides_by_name:
        if name.casefold() not in by_name:
            raise ConfigError(
                "scenario_overrides_by_name names an unknown scenario", source=source, item=name
            )
    for key in ("name", "scenario_id"):
        if key in spec.scenario_overrides or any(key in o for o in spec.scenario_overrides_by_name.values()):
            raise ConfigError("overrides may not rename scenarios", source=source, item=key)
    if spec.select_scenarios is None:
        return entries
    chosen: list[_Entry] = []
    for name in spec.select_scenarios:
        entry = by_name.get(name.casefold())
        if entry is None:
            raise ConfigError("select_scenarios names an unknown scenario", source=source, item=name)
        if entry in chosen:
            raise ConfigError("select_scenarios names a scenario twice", source=source, item=name)
        chosen.append(entry)
    return chosen


def _validate_scenario(entry: _Entry, spec: _FileSpec, overrides: Mapping[str, Any]) -> Scenario:
    data: dict[str, Any] = {"seeds": list(spec.seeds)} if spec.seeds is not None else {}
    data = _deep_merge(data, entry.data)
    data = _deep_merge(data, spec.scenario_overrides)
    for name, over in spec.scenario_overrides_by_name.items():
        if name.casefold() == entry.raw_name.casefold():
            data = _deep_merge(data, over)
    data = _deep_merge(data, overrides)
    try:
        return Scenario.model_validate(data)
    except ValidationError as err:
        raise ConfigError(validation_message(err), source=entry.file, item=entry.raw_name) from err


class _MapResolver:
    """Finds, loads (once per file) and checksums the maps of one matrix."""

    def __init__(self, root: Path, registry: str | Path | MapRegistry | None, apply_transforms: bool):
        self.root = root
        self.registry_arg = registry
        self.apply_transforms = apply_transforms
        self._registry: MapRegistry | None = registry if isinstance(registry, MapRegistry) else None
        self._cache: dict[Path, tuple[MapDef, str]] = {}

    def load(self, scenario: Scenario, entry: _Entry) -> tuple[MapDef, str]:
        path = self._map_path(scenario, entry)
        if path not in self._cache:
            self._cache[path] = (load_map(path, apply_transforms=self.apply_transforms), file_sha256(path))
        mapdef, sha = self._cache[path]
        if scenario.map_id and mapdef.name != scenario.map_id:
            mapdef = _replace(mapdef, name=scenario.map_id)  # the reference names a map by its id
        return mapdef, sha

    def _map_path(self, scenario: Scenario, entry: _Entry) -> Path:
        if scenario.map_id:
            registry = self._find_registry(entry, scenario)
            try:
                return Path(registry.resolve(scenario.map_id, scenario.required_map_profile)).resolve()
            except NotFoundError as err:
                raise ConfigError(
                    f"map_id {scenario.map_id!r}: {err}", source=entry.file, item=scenario.name
                ) from err
        assert scenario.map_file is not None  # Scenario guarantees map_file or map_id
        rel = Path(scenario.map_file)
        tried = [rel] if rel.is_absolute() else [self.root / rel, entry.file.parent / rel]
        tried += [] if rel.is_absolute() else [sp / rel for sp in entry.search_paths]
        # last resort: a path relative to a folder above the file (robot_sf scripts run from its repository root)
        tried += [] if rel.is_absolute() else [d / rel for d in entry.file.parents[1:]]
        tried = list(dict.fromkeys(tried))
        for candidate in tried:
            if candidate.is_file():
                return candidate.resolve()
        raise ConfigError(
            f"map_file {scenario.map_file!r} not found (tried: {', '.join(str(t) for t in tried)})",
            source=entry.file,
            item=scenario.name,
        )

    def _find_registry(self, entry: _Entry, scenario: Scenario) -> MapRegistry:
        if self._registry is not None:
            return self._registry
        path: Path | None = Path(self.registry_arg) if self.registry_arg is not None else None
        if path is None:
            candidates = [
                c for sp in entry.search_paths for c in (sp.parent / _REGISTRY_NAME, sp / _REGISTRY_NAME)
            ]
            # the reference's repository layout: maps/registry.yaml at the root above configs/scenarios/
            candidates += [d / "maps" / _REGISTRY_NAME for d in entry.file.parents]
            path = next((c for c in candidates if c.is_file()), None)
        if path is None:
            raise ConfigError(
                f"map_id {scenario.map_id!r} needs a map registry: pass map_registry, set map_registry: in the "
                f"manifest, or keep {_REGISTRY_NAME} next to a map search path or in a maps/ folder above the file",
                source=entry.file,
                item=scenario.name,
            )
        self._registry = _registry(*_file_version(path))
        return self._registry


def _file_version(path: Path) -> tuple[Path, int, int]:
    st = path.stat()
    return path.resolve(), st.st_mtime_ns, st.st_size


@functools.lru_cache(maxsize=8)
def _registry(path: Path, _mtime_ns: int, _size: int) -> MapRegistry:
    """A map registry, parsed once per file version (robot_sf's catalog is large and matrices share it)."""
    return MapRegistry(path)


def _replace(mapdef: MapDef, **changes: Any) -> MapDef:
    """A validated copy of ``mapdef`` with some fields changed."""
    fields = {k: getattr(mapdef, k) for k in MapDef.model_fields}
    return MapDef(**{**fields, **changes})


def _apply_routes(mapdef: MapDef, scenario: Scenario, entry: _Entry, root: Path) -> MapDef:
    """A scenario's generated replay, then its route-override file, then its inline route overrides."""
    overrides = []
    if scenario.generated_replay is not None:
        mapdef, robot_route = apply_generated_replay(
            mapdef, scenario.generated_replay, source=entry.file, item=f"{scenario.name}.generated_replay"
        )
        overrides.append(robot_route)
    if scenario.route_overrides_file is not None:
        rel = Path(scenario.route_overrides_file)
        tried = [rel] if rel.is_absolute() else [entry.file.parent / rel, root.parent / rel]
        path = next((t for t in tried if t.is_file()), tried[0])
        overrides.append(
            read_route_overrides(path.resolve(), scenario=scenario.name, referenced_from=entry.file)
        )
    overrides.append(scenario.route_overrides)
    for over in filter(None, overrides):
        try:
            mapdef = apply_route_overrides(mapdef, over)
        except ValidationError as err:
            raise ConfigError(
                validation_message(err), source=entry.file, item=f"{scenario.name}.routes"
            ) from err
    return mapdef


def matrix_from_data(
    data: Any,
    *,
    source: str | Path,
    apply_transforms: bool = False,
    map_registry: str | Path | MapRegistry | None = None,
    data_roots: Callable[[str], Path] | None = None,
    overrides: Mapping[str, Any] | None = None,
) -> ScenarioMatrix:
    """Build a matrix from already-parsed manifest data; relative paths resolve against ``source``'s folder.

    ``source`` need not exist as a file (an inline manifest posted to the API names a notional path).
    ``data_roots`` maps a replay scene's data root name to its folder (default: ``core.dataroots.data_root``).
    ``overrides`` are deep-merged into every scenario last, after the matrix's own overrides (a caller's
    conditions, e.g. ``{"simulation_config": {"ped_speed_tier": "typical"}}``); they may not rename scenarios.
    """
    root = Path(source).resolve()
    spec = _parse_spec(data, root, is_root=True)
    overrides = dict(overrides or {})
    for key in ("name", "scenario_id"):
        if key in overrides:
            raise ConfigError("overrides may not rename scenarios", source="overrides", item=key)
    entries, notes = _expand(root, spec, (root,), ())
    chosen = {id(e) for e in _select(entries, spec, root)}
    scenarios = [
        (e, _validate_scenario(e, spec, overrides)) for e in entries
    ]  # validate all, resolve the chosen
    if spec.select_scenarios is not None:
        order = {n.casefold(): i for i, n in enumerate(spec.select_scenarios)}
        scenarios = sorted(
            (p for p in scenarios if id(p[0]) in chosen), key=lambda p: order[p[0].raw_name.casefold()]
        )
    registry = map_registry
    if registry is None and spec.map_registry is not None:
        registry = root.parent / spec.map_registry
    resolver = _MapResolver(root.parent, registry, apply_transforms)
    scenes = SceneFiles(data_roots or data_root)
    resolved = []
    for entry, scenario in scenarios:
        if scenario.replay is not None:
            mapdef, tracks, sha = replay_scene(scenario, entry.file, scenes)
            resolved.append(ResolvedScenario(scenario=scenario, map=mapdef, map_sha256=sha, replay=tracks))
            continue
        mapdef, sha = resolver.load(scenario, entry)
        mapdef = _apply_routes(mapdef, scenario, entry, root)
        mapdef = apply_single_pedestrians(
            mapdef,
            scenario.single_pedestrians,
            source=entry.file,
            scenario=scenario.name,
            default_hold_ref_point=scenario.conflict_point,
        )
        resolved.append(ResolvedScenario(scenario=scenario, map=mapdef, map_sha256=sha))
    metadata = dict(spec.metadata)
    if notes:
        metadata["file_notes"] = notes
    return ScenarioMatrix(source=str(root), scenarios=tuple(resolved), metadata=metadata)


def load_matrix(
    path: str | Path,
    *,
    apply_transforms: bool = False,
    map_registry: str | Path | MapRegistry | None = None,
    data_roots: Callable[[str], Path] | None = None,
    overrides: Mapping[str, Any] | None = None,
) -> ScenarioMatrix:
    """Load a scenario matrix file with its includes and maps (see the module docstring for the rules).

    ``apply_transforms`` is passed to the SVG importer (the reference ignores SVG transforms).
    ``map_registry`` (a registry file or a loaded :class:`MapRegistry`) overrides the manifest's.
    ``data_roots`` and ``overrides``: see :func:`matrix_from_data`.
    """
    p = Path(path).resolve()
    return matrix_from_data(
        read_yaml(p),
        source=p,
        apply_transforms=apply_transforms,
        map_registry=map_registry,
        data_roots=data_roots,
        overrides=overrides,
    )
