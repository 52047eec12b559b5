"""The model registry: list, register a job's checkpoint, read, promote, delete (rules: ``store.registry``)."""

from __future__ import annotations

from typing import Annotated, Literal

from fastapi import APIRouter, Query, Request, Response, status
from fastapi.responses import PlainTextResponse

from foresight.api.bodies import SmallJsonRoute
from foresight.api.deps import EngineDep, SettingsDep, WriteAuth
from foresight.api.errors import AUTH, responses
from foresight.api.routes.bundles import ARCHIVE_BODY
from foresight.api.schemas import Ident, ModelCreate, ModelPromote
from foresight.core.errors import ConfigError
from foresight.schemas import ModelPublic, ModelsPublic
from foresight.store import job_reads, registry
from foresight.store.models import ModelStatus

router = APIRouter(prefix="/models", tags=["models"], route_class=SmallJsonRoute)


@router.get("")
def read_models(
    engine: EngineDep,
    status_: Annotated[ModelStatus | None, Query(alias="status")] = None,
    tag: Annotated[str | None, Query(max_length=100)] = None,
    limit: Annotated[int | None, Query(ge=1, le=500, description="page size (default: every entry)")] = None,
    offset: Annotated[int, Query(ge=0, le=10_000_000)] = 0,
) -> ModelsPublic:
    """Registry entries, oldest first (shipped read-only entries included), filtered by status or tag; ``count``
    is the number matching, ``limit``/``offset`` select a page."""
    rows = registry.models(engine, status=status_.value if status_ is not None else None, tag=tag)
    page = rows[offset : offset + limit if limit is not None else None]
    return ModelsPublic(
        data=[ModelPublic.model_validate(m) for m in page], count=len(rows), limit=limit, offset=offset
    )


class YamlResponse(PlainTextResponse):
    media_type = "application/yaml"


@router.get(
    "/export",
    response_class=YamlResponse,
    responses={
        200: {
            "content": {
                "application/yaml": {
                    "schema": {
                        "type": "object",
                        "required": ["models"],
                        "properties": {"models": {"type": "array", "items": {"type": "object"}}},
                    }
                }
            }
        }
    },
)
def export_registry(engine: EngineDep) -> YamlResponse:
    """Models registered at run time, in the schema of ``model/registry.yaml``."""
    return YamlResponse(registry.export_models(registry.models(engine, run_time_only=True)))


@router.post(
    "",
    status_code=status.HTTP_201_CREATED,
    dependencies=[WriteAuth],
    responses=responses(*AUTH, 404, 409, 413),
)
def create_model(body: ModelCreate, engine: EngineDep, settings: SettingsDep) -> ModelPublic:
    """Register a checkpoint artifact of a succeeded job as a candidate (409 for a duplicate id; 422 for a reserved
    id, when the artifact is not a checkpoint of a known format or no longer has its recorded sha256, or a
    ``time_base`` other than the checkpoint's; 413 for a body over 64 KiB). The time base is the checkpoint's."""
    meta = body.model_dump(include={"lineage", "training", "metrics", "tags", "provenance"})
    if body.time_base:
        meta["time_base"] = body.time_base
    registry.register_checkpoint(
        engine,
        settings,
        model_id=body.id,
        job_id=job_reads.resolve_id(engine, body.job_id),
        artifact=body.artifact,
        metadata=meta,
        status=body.status,
    )
    return ModelPublic.model_validate(registry.model(engine, body.id))


@router.post(
    "/predictors",
    status_code=status.HTTP_201_CREATED,
    dependencies=[WriteAuth],
    responses=responses(*AUTH, 404, 409),
    openapi_extra=ARCHIVE_BODY,
)
async def create_predictor_model(
    request: Request,
    engine: EngineDep,
    settings: SettingsDep,
    id: Annotated[Ident, Query(description="model id")],  # noqa: A002
    kind: Annotated[Literal["plugin", "external"], Query()],
    predictor: Annotated[str, Query(min_length=1, max_length=200, description="plug-in or external:<name>")],
    tag: Annotated[list[Annotated[str, Query(max_length=100)]], Query(max_length=50)] = [],  # noqa: B006
) -> ModelPublic:
    """Register an installed predictor plug-in or an operator-configured external predictor as a candidate model,
    with its files: the body (optional) is a zip or tar of its artifact folder. Its declaration (time base, frame,
    modes) and a sha256 of every file are recorded; 422 for a predictor that is not of that kind or does not load,
    409 for a taken id."""
    from starlette.concurrency import run_in_threadpool

    from foresight.store import model_kinds

    data = bytearray()
    async for chunk in request.stream():
        data += chunk
        if len(data) > model_kinds.MAX_MODEL_BYTES:
            raise ConfigError(f"archive larger than {model_kinds.MAX_MODEL_BYTES} bytes", source="upload")
    await run_in_threadpool(
        lambda: model_kinds.register_predictor(
            engine,
            settings,
            model_id=id,
            kind=kind,
            predictor=predictor,
            archive=bytes(data) or None,
            metadata={"tags": tag},
        )
    )
    return ModelPublic.model_validate(registry.model(engine, id))


@router.get("/{model_id}", responses=responses(404))
def read_model(model_id: Ident, engine: EngineDep) -> ModelPublic:
    """One registry entry."""
    return ModelPublic.model_validate(registry.model(engine, model_id))


@router.post("/{model_id}/promote", dependencies=[WriteAuth], responses=responses(*AUTH, 404, 409))
def promote_model(model_id: Ident, engine: EngineDep, body: ModelPromote | None = None) -> ModelPublic:
    """Promote a model; promoting to ``default`` demotes the previous default to ``promoted``."""
    registry.promote(engine, model_id, (body or ModelPromote()).to)
    return ModelPublic.model_validate(registry.model(engine, model_id))


@router.delete(
    "/{model_id}",
    status_code=status.HTTP_204_NO_CONTENT,
    dependencies=[WriteAuth],
    responses=responses(*AUTH, 404, 409),
)
def delete_model(model_id: Ident, engine: EngineDep) -> Response:
    """Delete a registered model (409 for shipped or default models and models that records use)."""
    registry.delete_model(engine, model_id)
    return Response(status_code=status.HTTP_204_NO_CONTENT)
