"""Config bundles: the project's configs (``builtin``), extra config roots, and uploaded archives."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Query, Request, status

from foresight.api.deps import EngineDep, ResolverDep, SettingsDep, WriteAuth
from foresight.api.errors import AUTH, responses
from foresight.api.schemas import BundlePublic, BundlesPublic, Ident, ScenarioPublic
from foresight.core.errors import ConfigError
from foresight.store import queue, registry
from foresight.store.models import Bundle
from foresight.store.registry import MAX_BUNDLE_BYTES, save_upload

router = APIRouter(prefix="/bundles", tags=["bundles"])


def _get(engine: EngineDep, bundle_id: str) -> Bundle:
    row = registry.bundle(engine, bundle_id)
    if row is None:
        raise queue.JobNotFound(f"no bundle with id {bundle_id!r}")
    return row


@router.get("")
def read_bundles(engine: EngineDep) -> BundlesPublic:
    """Registered config bundles."""
    rows = registry.bundles(engine)
    return BundlesPublic(data=[BundlePublic.model_validate(b) for b in rows], count=len(rows))


@router.post("", status_code=status.HTTP_201_CREATED, dependencies=[WriteAuth], responses=responses(*AUTH, 409),
             openapi_extra={"requestBody": {"required": True, "content": {
                 "application/zip": {"schema": {"type": "string", "format": "binary"}},
                 "application/x-tar": {"schema": {"type": "string", "format": "binary"}},
                 "application/gzip": {"schema": {"type": "string", "format": "binary"}}}}})  # fmt: skip
async def create_bundle(
    request: Request, engine: EngineDep, settings: SettingsDep,
    name: Annotated[Ident, Query(description="bundle id")],
) -> BundlePublic:  # fmt: skip
    """Upload a zip or tar of YAML files and maps (the raw archive is the body); validated before it is stored."""
    if registry.bundle(engine, name) is not None:
        raise queue.Conflict(f"a bundle with id {name!r} already exists")
    declared = int(request.headers.get("content-length") or 0)
    if declared > MAX_BUNDLE_BYTES:
        raise ConfigError(f"archive larger than {MAX_BUNDLE_BYTES} bytes", source="upload")
    data = bytearray()
    async for chunk in request.stream():
        data += chunk
        if len(data) > MAX_BUNDLE_BYTES:
            raise ConfigError(f"archive larger than {MAX_BUNDLE_BYTES} bytes", source="upload")
    from starlette.concurrency import run_in_threadpool

    try:
        row = await run_in_threadpool(save_upload, engine, settings, name, bytes(data))
    except FileExistsError:
        raise queue.Conflict(f"a bundle with id {name!r} already exists") from None
    return BundlePublic.model_validate(row)


@router.get("/{bundle_id}", responses=responses(404))
def read_bundle(bundle_id: Ident, engine: EngineDep) -> BundlePublic:
    """One bundle: its files and scenario matrices."""
    return BundlePublic.model_validate(_get(engine, bundle_id))


@router.get("/{bundle_id}/scenarios", responses=responses(404))
def read_bundle_scenarios(bundle_id: Ident, engine: EngineDep, resolver: ResolverDep) -> list[ScenarioPublic]:
    """The scenarios of every matrix in the bundle."""
    from foresight.core.scenarios.loader import load_matrix

    row = _get(engine, bundle_id)
    root = resolver.bundle_root(row)
    out = []
    for rel in row.scenarios:
        matrix = load_matrix(root / rel)
        for s in matrix.scenarios:
            out.append(ScenarioPublic(matrix=rel, name=s.name, map=s.map.name,
                                      archetype=s.scenario.archetype, seeds=list(s.scenario.seeds)))  # fmt: skip
    return out
