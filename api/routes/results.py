"""Results of finished stages: datasets, evaluations (with their taxonomy), campaigns, A/B comparison."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Query
from sqlalchemy import select

from foresight.api.deps import SessionDep, SettingsDep
from foresight.api.errors import responses
from foresight.api.schemas import CampaignPublic, DatasetPublic, EvaluationPublic, Ident
from foresight.store import folders, models, queue
from foresight.store.models import Campaign, CampaignCell, Dataset, Evaluation, FailureTaxonomy, GateResult

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
    from foresight.core.predict.ethucy import FOLDS

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


SUITES = ("global", "hard")


def _operand(session: SessionDep, ident: str) -> tuple[str, dict[str, Any], dict[str, Any]]:
    """(what it is, resolved config, headline summary) of an evaluation id or a campaign cell
    ``CAMPAIGN_ID:RANK[:SUITE]`` (rank 1 = the best cell, suite ``global`` (default) or ``hard``)."""
    row = session.get(Evaluation, ident)
    if row is not None:
        return "evaluation", row.config, (row.metrics or {}).get("overall") or {}
    campaign_id, _, rest = ident.partition(":")
    rank, _, suite = rest.partition(":")
    if not rank.isdigit() or (suite or "global") not in SUITES or session.get(Campaign, campaign_id) is None:
        raise queue.JobNotFound(f"no evaluation {ident!r} and no campaign cell of that name "
                                "(cells are CAMPAIGN_ID:RANK or CAMPAIGN_ID:RANK:hard, rank 1 = best)")
    cell = session.scalars(select(CampaignCell).where(CampaignCell.campaign_id == campaign_id,
                                                      CampaignCell.rank == int(rank))).first()  # fmt: skip
    if cell is None:
        raise queue.JobNotFound(f"campaign {campaign_id!r} has no cell of rank {rank}")
    config = {**session.get(Campaign, campaign_id).config, **cell.params}
    suite = suite or "global"
    summary = (cell.metrics or {}).get(suite)
    if not summary:
        raise queue.JobNotFound(f"campaign {campaign_id!r} cell {rank} has no {suite} suite")
    return f"campaign cell ({suite} suite)", config, summary


def _episodes(session: SessionDep, settings: SettingsDep, ident: str) -> list[Any] | None:
    """An evaluation's episode records (its job's episodes.jsonl), None for campaign cells or when gone."""
    from foresight.core.evaluation.runner import read_records

    row, art = session.get(Evaluation, ident), models.Artifact
    art = None if row is None or row.job_id is None else session.scalars(
        select(art).where(art.job_id == row.job_id, art.name == "episodes.jsonl")).first()
    path = None if art is None else folders.resolve_under(settings.store_root, art.path)
    return read_records(path) if path is not None and path.is_file() else None


@router.get("/compare", responses=responses(404))
def compare_evaluations(session: SessionDep, settings: SettingsDep, a: Annotated[Ident, Query()],
                        b: Annotated[Ident, Query()]) -> dict[str, Any]:
    """Two evaluations or campaign cells (``CAMPAIGN_ID:RANK[:hard]``) side by side: the resolved-config diff
    key by key and the headline metric deltas B - A with 95 % intervals. Two evaluations of the same
    (scenario, seed) episodes are paired (McNemar / Wilcoxon p-values, paired bootstrap intervals); the other
    metrics, and results of other episodes, use MOVER from each side's intervals (``method`` per metric)."""
    from foresight.core.evaluation.delta import deltas, diff_configs, paired_deltas

    (kind_a, config_a, sum_a), (kind_b, config_b, sum_b) = _operand(session, a), _operand(session, b)
    ra, rb = _episodes(session, settings, a), _episodes(session, settings, b)
    paired = paired_deltas(ra, rb) if ra and rb else None
    metrics = {**deltas(sum_a, sum_b), **(paired or {})}
    return {"a": a, "b": b, "sources": {"a": kind_a, "b": kind_b}, "config_diff": diff_configs(config_a, config_b),
            "paired": paired is not None, "metrics": {k: v.model_dump() for k, v in metrics.items()}}
