"""Config bundles: the project's configs (``builtin``), extra config roots, and uploaded archives."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Query, Request, Response, status

from foresight.api.deps import EngineDep, ResolverDep, SettingsDep, WriteAuth
from foresight.api.errors import AUTH, responses
from foresight.api.schemas import Ident
from foresight.core.errors import ConfigError
from foresight.schemas import BundlePublic, BundlesPublic, ScenarioPublic
from foresight.store import bundles, queue, registry
from foresight.store.models import Bundle
from foresight.store.registry import MAX_BUNDLE_BYTES
from foresight.store.uploads import save_upload

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


ARCHIVE_BODY = {
    "requestBody": {
        "required": True,
        "content": {
            "application/zip": {"schema": {"type": "string", "format": "binary"}},
            "application/x-tar": {"schema": {"type": "string", "format": "binary"}},
            "application/gzip": {"schema": {"type": "string", "format": "binary"}},
        },
    }
}


async def _archive(request: Request) -> bytes:
    """The raw archive body, refused past MAX_BUNDLE_BYTES before it is all read."""
    declared = int(request.headers.get("content-length") or 0)
    if declared > MAX_BUNDLE_BYTES:
        raise ConfigError(f"archive larger than {MAX_BUNDLE_BYTES} bytes", source="upload")
    data = bytearray()
    async for chunk in request.stream():
        data += chunk
        if len(data) > MAX_BUNDLE_BYTES:
            raise ConfigError(f"archive larger than {MAX_BUNDLE_BYTES} bytes", source="upload")
    return bytes(data)


@router.post(
    "",
    status_code=status.HTTP_201_CREATED,
    dependencies=[WriteAuth],
    responses={
        200: {"model": BundlePublic, "description": "replaced (replace=true)"},
        **responses(*AUTH, 409),
    },
    openapi_extra=ARCHIVE_BODY,
)
async def create_bundle(
    request: Request,
    response: Response,
    engine: EngineDep,
    settings: SettingsDep,
    name: Annotated[Ident, Query(description="bundle id")],
    replace: Annotated[bool, Query(description="replace an uploaded bundle of that id (as PUT)")] = False,
) -> BundlePublic:
    """Upload a zip or tar of YAML files and maps (the raw archive is the body); validated before it is stored.
    An existing id is a 409 unless ``replace=true`` (then 200, as PUT)."""
    from starlette.concurrency import run_in_threadpool

    if replace and registry.bundle(engine, name) is not None:
        data = await _archive(request)
        row = await run_in_threadpool(bundles.replace_upload, engine, settings, name, data)
        response.status_code = status.HTTP_200_OK
        return BundlePublic.model_validate(row)
    if registry.bundle(engine, name) is not None:
        raise queue.Conflict(
            f"a bundle with id {name!r} already exists (replace it: PUT /v1/bundles/{name}, "
            "or `foresight bundles upload --replace`)"
        )
    data = await _archive(request)
    try:
        row = await run_in_threadpool(save_upload, engine, settings, name, data)
    except FileExistsError:
        raise queue.Conflict(f"a bundle with id {name!r} already exists") from None
    return BundlePublic.model_validate(row)


@router.put(
    "/{bundle_id}", dependencies=[WriteAuth], responses=responses(*AUTH, 404, 409), openapi_extra=ARCHIVE_BODY
)
async def replace_bundle(
    bundle_id: Ident, request: Request, engine: EngineDep, settings: SettingsDep
) -> BundlePublic:
    """Replace an uploaded bundle's files with a new archive (validated as an upload). 409 for project and
    config-folder bundles and while queued or running jobs use it (naming them)."""
    from starlette.concurrency import run_in_threadpool

    await run_in_threadpool(bundles.check_replaceable, engine, bundle_id)  # before reading a large body
    data = await _archive(request)
    return BundlePublic.model_validate(
        await run_in_threadpool(bundles.replace_upload, engine, settings, bundle_id, data)
    )


@router.delete(
    "/{bundle_id}",
    status_code=status.HTTP_204_NO_CONTENT,
    dependencies=[WriteAuth],
    responses=responses(*AUTH, 404, 409),
)
def delete_bundle(bundle_id: Ident, engine: EngineDep, settings: SettingsDep) -> Response:
    """Delete an uploaded bundle and its files (records that ran on it keep its name). 409 for project and
    config-folder bundles and while queued or running jobs use it (naming them)."""
    bundles.delete_upload(engine, settings, bundle_id)
    return Response(status_code=status.HTTP_204_NO_CONTENT)


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
            out.append(
                ScenarioPublic(
                    matrix=rel,
                    name=s.name,
                    map=s.map.name,
                    archetype=s.scenario.archetype,
                    seeds=list(s.scenario.seeds),
                )
            )
    return out
