"""Results of finished stages: datasets, evaluations (with their taxonomy), campaigns, A/B comparison."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Query
from sqlalchemy import select

from api.db import queue
from api.db.models import Campaign, CampaignCell, Dataset, Evaluation, FailureTaxonomy, GateResult
from api.deps import SessionDep, SettingsDep
from api.errors import responses
from api.schemas import CampaignPublic, DatasetPublic, EvaluationPublic, Ident

router = APIRouter(tags=["results"])


def _get(session: SessionDep, model: type, ident: str, what: str) -> Any:
    row = session.get(model, ident)
    if row is None:
        raise queue.JobNotFound(f"no {what} with id {ident!r}")
    return row


@router.get("/datasets")
def read_datasets(session: SessionDep) -> list[DatasetPublic]:
    """Datasets, oldest first."""
    return [DatasetPublic.model_validate(d) for d in session.scalars(select(Dataset).order_by(Dataset.created_at))]


@router.get("/datasets/{dataset_id}", responses=responses(404))
def read_dataset(dataset_id: Ident, session: SessionDep) -> DatasetPublic:
    """A dataset's summary."""
    return DatasetPublic.model_validate(_get(session, Dataset, dataset_id, "dataset"))


@router.get("/data-roots")
def read_data_roots(settings: SettingsDep) -> list[dict[str, Any]]:
    """Named data roots an ``import_dataset`` job may read (``FORESIGHT_DATA_ROOTS``), with the ETH/UCY folds
    found in each; names only, the server's folders stay private."""
    from core.predict.ethucy import FOLDS

    return [{"name": name, "folds": [f for f in FOLDS if (path / f).is_dir()]}
            for name, path in sorted(settings.named_data_roots.items())]


def _evaluation(session: SessionDep, evaluation_id: str) -> EvaluationPublic:
    row = _get(session, Evaluation, evaluation_id, "evaluation")
    taxonomy = session.scalars(select(FailureTaxonomy).where(FailureTaxonomy.evaluation_id == evaluation_id))
    out = EvaluationPublic.model_validate(row)
    out.taxonomy = [{"category": t.category, "count": t.count, "examples": t.examples} for t in taxonomy]
    return out


@router.get("/evaluations/{evaluation_id}", responses=responses(404))
def read_evaluation(evaluation_id: Ident, session: SessionDep) -> EvaluationPublic:
    """Metrics, the per-scenario table and the failure taxonomy of an evaluation."""
    return _evaluation(session, evaluation_id)


@router.get("/campaigns/{campaign_id}", responses=responses(404))
def read_campaign(campaign_id: Ident, session: SessionDep) -> CampaignPublic:
    """A campaign's ranked cells, best cell and gate results."""
    row = _get(session, Campaign, campaign_id, "campaign")
    cells = session.scalars(select(CampaignCell).where(CampaignCell.campaign_id == campaign_id).order_by(CampaignCell.rank))
    gates = session.scalars(select(GateResult).where(GateResult.campaign_id == campaign_id))
    return CampaignPublic(
        id=row.id, job_id=row.job_id, config=row.config, best=row.best,
        cells=[{"rank": c.rank, "params": c.params, "metrics": c.metrics} for c in cells],
        gates=[{"gate": g.gate, "passed": g.passed, "details": g.details} for g in gates],
    )  # fmt: skip


def _flatten(value: Any, prefix: str = "") -> dict[str, Any]:
    if isinstance(value, dict):
        out: dict[str, Any] = {}
        for k, v in value.items():
            out.update(_flatten(v, f"{prefix}.{k}" if prefix else str(k)))
        return out
    return {prefix: value}


def diff_configs(a: dict[str, Any], b: dict[str, Any]) -> dict[str, dict[str, Any]]:
    """Keys whose values differ between two (nested) configs, as dotted keys."""
    fa, fb = _flatten(a), _flatten(b)
    return {k: {"a": fa.get(k), "b": fb.get(k)} for k in sorted(fa.keys() | fb.keys()) if fa.get(k) != fb.get(k)}


def metric_deltas(a: dict[str, Any], b: dict[str, Any]) -> dict[str, dict[str, Any]]:
    """b − a for every numeric metric both have; a metric may be a number or ``{value, ci_low, ci_high}``."""
    out = {}
    for key in sorted(a.keys() & b.keys()):
        va, vb = a[key], b[key]
        na = va.get("value") if isinstance(va, dict) else va
        nb = vb.get("value") if isinstance(vb, dict) else vb
        if isinstance(na, int | float) and isinstance(nb, int | float):
            entry = {"a": va, "b": vb, "delta": nb - na}
            out[key] = entry
    return out


@router.get("/compare", responses=responses(404))
def compare_evaluations(session: SessionDep, a: Annotated[Ident, Query()], b: Annotated[Ident, Query()]) -> dict[str, Any]:
    """Two evaluations side by side: resolved-config diff key by key and metric deltas (b − a)."""
    ea, eb = _evaluation(session, a), _evaluation(session, b)
    return {"a": a, "b": b, "config_diff": diff_configs(ea.config, eb.config), "metrics": metric_deltas(ea.metrics, eb.metrics)}
