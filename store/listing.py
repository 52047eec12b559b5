"""Filtered, paginated lists of result records (evaluations, campaigns) with their job's labels: how a researcher
finds a run again by planner, model, matrix, grid, verdict, tag or name.

Filters on what a record ran read its JSON config (``config -> stage -> planner -> name`` ...) through
SQLAlchemy's JSON paths, which compile to ``json_extract`` on SQLite and ``#>>`` on PostgreSQL; tags and names
are the job's (``store.labels``). Pages are newest first with a stable tie-break (id).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from sqlalchemy import Engine, and_, exists, func, select

from foresight.store.models import Campaign, CampaignCell, Evaluation, Job, JobTag


@dataclass
class Labelled:
    """A record with its job's labels (None/empty where the job is gone)."""

    row: Any
    name: str | None = None
    tags: list[str] = field(default_factory=list)


def _label_terms(job_id_col: Any, name: str | None, tags: Sequence[str]) -> list:
    where: list = []
    if name:
        where.append(job_id_col.in_(select(Job.id).where(Job.name == name)))
    for tag in dict.fromkeys(tags):
        where.append(job_id_col.in_(select(JobTag.job_id).where(JobTag.tag == tag)))
    return where


def _page(engine: Engine, table: Any, where: list, limit: int, offset: int) -> tuple[int, list[Labelled]]:
    from foresight.store.session import session_factory

    with session_factory(engine)() as session:
        count = session.scalar(select(func.count()).select_from(table).where(*where)) or 0
        rows = session.execute(
            select(table, Job.name, Job.tags)
            .outerjoin(Job, Job.id == table.job_id)
            .where(*where)
            .order_by(table.created_at.desc(), table.id)
            .limit(limit)
            .offset(offset)
        ).all()
        return count, [Labelled(row, name, list(tags or [])) for row, name, tags in rows]


def evaluations(
    engine: Engine,
    *,
    model_id: str | None = None,
    bundle_id: str | None = None,
    planner: str | None = None,
    matrix: str | None = None,
    verdict: str | None = None,
    name: str | None = None,
    tags: Sequence[str] = (),
    limit: int = 50,
    offset: int = 0,
) -> tuple[int, list[Labelled]]:
    """``(total matching, one page)`` of evaluations, newest first."""
    stage = Evaluation.config["stage"]
    terms = [
        Evaluation.model_id == model_id if model_id else None,
        Evaluation.bundle_id == bundle_id if bundle_id else None,
        stage[("planner", "name")].as_string() == planner if planner else None,
        stage["matrix"].as_string() == matrix if matrix else None,
        Evaluation.metrics["status"].as_string() == verdict if verdict else None,
    ]
    where = [t for t in terms if t is not None] + _label_terms(Evaluation.job_id, name, tags)
    return _page(engine, Evaluation, where, limit, offset)


def campaigns(
    engine: Engine,
    *,
    matrix: str | None = None,
    grid: str | None = None,
    model: str | None = None,
    name: str | None = None,
    tags: Sequence[str] = (),
    limit: int = 50,
    offset: int = 0,
) -> tuple[int, list[Labelled]]:
    """``(total matching, one page)`` of campaigns, newest first; ``model``: a checkpoint one of its cells ran."""
    terms = [
        Campaign.config["matrix"].as_string() == matrix if matrix else None,
        Campaign.config["grid"].as_string() == grid if grid else None,
        exists().where(
            and_(
                CampaignCell.campaign_id == Campaign.id,
                CampaignCell.params["checkpoint"].as_string() == model,
            )
        )
        if model
        else None,
    ]
    where = [t for t in terms if t is not None] + _label_terms(Campaign.job_id, name, tags)
    return _page(engine, Campaign, where, limit, offset)


def campaign_grid_cells(engine: Engine, campaign_id: str) -> list[Any]:
    """A campaign's cells as ``core.reports.grid_plot.GridCell`` (resolved planner config and both suites),
    from its job's result; from the stored cells (no configs: plotted against the variant) when the job is gone.
    ``store.queue.JobNotFound`` for an unknown campaign."""
    from foresight.core.evaluation.aggregate import SuiteSummary
    from foresight.core.evaluation.campaign_result import CampaignResult
    from foresight.core.reports.grid_plot import GridCell
    from foresight.store import job_reads, queue, results

    row, cells, _ = results.campaign(engine, campaign_id)
    job = None
    if row.job_id is not None:
        try:
            job = job_reads.get_job(engine, row.job_id)
        except queue.JobNotFound:
            job = None
    if job is not None and job["result"]:
        result = CampaignResult.model_validate(job["result"])
        return [
            GridCell(c.checkpoint, c.variant, c.planner.config, {"global": c.global_, "hard": c.hard})
            for c in result.ranked
        ]
    return [
        GridCell(
            c["params"]["checkpoint"],
            c["params"]["variant"],
            {},
            {
                s: SuiteSummary.model_validate(m)
                for s, m in (c["metrics"] or {}).items()
                if s in ("global", "hard") and m
            },
        )
        for c in cells
    ]
