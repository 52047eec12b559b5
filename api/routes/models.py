"""The model registry: list, register a job's checkpoint, read, promote, delete."""

from __future__ import annotations

from typing import Annotated

from fastapi import APIRouter, Query, Response, status
from fastapi.responses import PlainTextResponse
from sqlalchemy import select

from foresight.api.deps import EngineDep, SessionDep, SettingsDep, WriteAuth, WriteSessionDep
from foresight.api.errors import AUTH, responses
from foresight.api.schemas import Ident, ModelCreate, ModelPromote, ModelPublic, ModelsPublic
from foresight.store import queue, registry
from foresight.store.models import Model, ModelStatus
from foresight.store.registry import export_models, models_using

router = APIRouter(prefix="/models", tags=["models"])


def _get(session: SessionDep, model_id: str) -> Model:
    row = session.get(Model, model_id)
    if row is None:
        raise queue.JobNotFound(f"no model with id {model_id!r}")
    return row


@router.get("")
def read_models(
    session: SessionDep,
    status_: Annotated[ModelStatus | None, Query(alias="status")] = None,
    tag: Annotated[str | None, Query(max_length=100)] = None,
) -> ModelsPublic:
    """Registry entries (shipped read-only entries included), filtered by status or tag."""
    stmt = select(Model).order_by(Model.created_at, Model.id)
    if status_ is not None:
        stmt = stmt.where(Model.status == status_.value)
    rows = [m for m in session.scalars(stmt) if tag is None or tag in m.tags]
    return ModelsPublic(data=[ModelPublic.model_validate(m) for m in rows], count=len(rows))


class YamlResponse(PlainTextResponse):
    media_type = "application/yaml"


@router.get("/export", response_class=YamlResponse, responses={200: {"content": {"application/yaml": {"schema": {
    "type": "object", "required": ["models"], "properties": {"models": {"type": "array", "items": {"type": "object"}}}}}}}})
def export_registry(session: SessionDep) -> YamlResponse:
    """Models registered at run time, in the schema of ``model/registry.yaml``."""
    rows = list(session.scalars(select(Model).where(Model.read_only.is_(False)).order_by(Model.created_at)))
    return YamlResponse(export_models(rows))


@router.post("", status_code=status.HTTP_201_CREATED, dependencies=[WriteAuth], responses=responses(*AUTH, 404, 409))
def create_model(body: ModelCreate, session: SessionDep, engine: EngineDep, settings: SettingsDep) -> ModelPublic:
    """Register a checkpoint artifact of a succeeded job (409 for a duplicate id)."""
    meta = body.model_dump(include={"time_base", "lineage", "training", "metrics", "tags", "provenance"})
    registry.register_checkpoint(engine, settings, model_id=body.id, job_id=body.job_id, artifact=body.artifact,
                                 metadata=meta, status=body.status)
    return ModelPublic.model_validate(_get(session, body.id))


@router.get("/{model_id}", responses=responses(404))
def read_model(model_id: Ident, session: SessionDep) -> ModelPublic:
    """One registry entry."""
    return ModelPublic.model_validate(_get(session, model_id))


@router.post("/{model_id}/promote", dependencies=[WriteAuth], responses=responses(*AUTH, 404, 409))
def promote_model(model_id: Ident, session: SessionDep, engine: EngineDep, body: ModelPromote | None = None) -> ModelPublic:
    """Promote a model; promoting to ``default`` demotes the previous default to ``promoted``."""
    registry.promote(engine, model_id, (body or ModelPromote()).to)
    return ModelPublic.model_validate(_get(session, model_id))


@router.delete("/{model_id}", status_code=status.HTTP_204_NO_CONTENT, dependencies=[WriteAuth],
                responses=responses(*AUTH, 404, 409))
def delete_model(model_id: Ident, session: WriteSessionDep, engine: EngineDep) -> Response:
    """Delete a registered model (409 for shipped or default models and models that records use)."""
    row = _get(session, model_id)
    if row.read_only:
        raise queue.Conflict(f"model {model_id} is shipped (model/registry.yaml) and read-only")
    if row.status == ModelStatus.default.value:
        raise queue.Conflict(f"model {model_id} is the default; promote another model to default first")
    users = models_using(engine, model_id)
    if users:
        raise queue.Conflict(f"model {model_id} is used by evaluations {users[:10]}")
    session.delete(row)
    session.commit()
    return Response(status_code=status.HTTP_204_NO_CONTENT)

