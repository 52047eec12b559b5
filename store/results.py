"""Reads of the result rows finished jobs wrote (``store.records``): datasets, evaluations with their failure
taxonomy, campaigns with their ranked cells and gates, and the operands of a comparison.

Rows come back detached (their columns loaded), for response models to validate from attributes.
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from sqlalchemy import Engine, func, select

from foresight.core.evaluation.aggregate import GroupStats, SuiteSummary
from foresight.core.evaluation.evaluation_result import EvaluationMetrics
from foresight.store import folders, job_reads, queue
from foresight.store.models import (
    Campaign,
    CampaignCell,
    Dataset,
    Evaluation,
    FailureTaxonomy,
    GateResult,
)
from foresight.store.session import session_factory

SUITES = ("global", "hard")  #: a campaign cell's suites


def _get(session: Any, model: type, ident: str, what: str) -> Any:
    row = session.get(model, ident)
    if row is None:
        raise queue.JobNotFound(f"no {what} with id {ident!r}")
    return row


def datasets(engine: Engine) -> list[Dataset]:
    """Datasets, oldest first."""
    with session_factory(engine)() as session:
        return list(session.scalars(select(Dataset).order_by(Dataset.created_at)))


def dataset(engine: Engine, ident: str) -> Dataset:
    with session_factory(engine)() as session:
        return _get(session, Dataset, ident, "dataset")


def evaluations(
    engine: Engine,
    *,
    model_id: str | None = None,
    bundle_id: str | None = None,
    limit: int = 50,
    offset: int = 0,
) -> tuple[int, list[Evaluation]]:
    """``(total matching, one page of evaluations)``, newest first, filtered by model and bundle."""
    where = [
        c
        for c in (
            Evaluation.model_id == model_id if model_id else None,
            Evaluation.bundle_id == bundle_id if bundle_id else None,
        )
        if c is not None
    ]
    with session_factory(engine)() as session:
        count = session.scalar(select(func.count()).select_from(Evaluation).where(*where)) or 0
        rows = session.scalars(
            select(Evaluation)
            .where(*where)
            .order_by(Evaluation.created_at.desc(), Evaluation.id)
            .limit(limit)
            .offset(offset)
        )
        return count, list(rows)


def evaluation(engine: Engine, ident: str) -> tuple[Evaluation, list[dict[str, Any]]]:
    """An evaluation row and its failure taxonomy (category, count, examples)."""
    with session_factory(engine)() as session:
        row = _get(session, Evaluation, ident, "evaluation")
        taxonomy = session.scalars(select(FailureTaxonomy).where(FailureTaxonomy.evaluation_id == ident))
        return row, [{"category": t.category, "count": t.count, "examples": t.examples} for t in taxonomy]


def campaign(engine: Engine, ident: str) -> tuple[Campaign, list[dict[str, Any]], list[dict[str, Any]]]:
    """A campaign row, its cells by rank (rank, params, metrics) and its gate results (gate, passed, details)."""
    with session_factory(engine)() as session:
        row = _get(session, Campaign, ident, "campaign")
        cells = session.scalars(
            select(CampaignCell).where(CampaignCell.campaign_id == ident).order_by(CampaignCell.rank)
        )
        gates = session.scalars(select(GateResult).where(GateResult.campaign_id == ident))
        return (
            row,
            [{"rank": c.rank, "params": c.params, "metrics": c.metrics} for c in cells],
            [{"gate": g.gate, "passed": g.passed, "details": g.details} for g in gates],
        )


def _rank(text: str) -> int | None:
    """A cell rank written in an id (ASCII digits, at most 9 of them: 2**64 reached an integer column), else None."""
    return int(text) if text.isascii() and text.isdigit() and len(text) <= 9 else None


def comparison_operand(engine: Engine, ident: str) -> tuple[str, dict[str, Any], GroupStats | SuiteSummary]:
    """(what it is, resolved config, headline summary) of an evaluation id or a campaign cell
    ``CAMPAIGN_ID:RANK[:SUITE]`` (rank 1 = the best cell, suite ``global`` (default) or ``hard``)."""
    with session_factory(engine)() as session:
        row = session.get(Evaluation, ident)
        if row is not None:
            return "evaluation", row.config, EvaluationMetrics.model_validate(row.metrics).overall
        campaign_id, _, rest = ident.partition(":")
        rank, _, suite = rest.partition(":")
        found = session.get(Campaign, campaign_id)
        if _rank(rank) is None or (suite or "global") not in SUITES or found is None:
            raise queue.JobNotFound(
                f"no evaluation {ident!r} and no campaign cell of that name "
                "(cells are CAMPAIGN_ID:RANK or CAMPAIGN_ID:RANK:hard, rank 1 = best)"
            )
        cell = session.scalars(
            select(CampaignCell).where(
                CampaignCell.campaign_id == campaign_id, CampaignCell.rank == int(rank)
            )
        ).first()
        if cell is None:
            raise queue.JobNotFound(f"campaign {campaign_id!r} has no cell of rank {rank}")
        config = {**found.config, **cell.params}
        suite = suite or "global"
        summary = (cell.metrics or {}).get(suite)
        if not summary:
            raise queue.JobNotFound(f"campaign {campaign_id!r} cell {rank} has no {suite} suite")
        return f"campaign cell ({suite} suite)", config, SuiteSummary.model_validate(summary)


def records_by_job(engine: Engine) -> dict[str, list[tuple[str, str]]]:
    """Job id -> its evaluation and campaign records as (id, API path)."""
    out: dict[str, list[tuple[str, str]]] = defaultdict(list)
    with session_factory(engine)() as session:
        for table, route in ((Evaluation, "evaluations"), (Campaign, "campaigns")):
            for ident, job_id in session.execute(select(table.id, table.job_id)):
                out[job_id].append((ident, f"/v1/{route}/{ident}"))
    return out


@dataclass(frozen=True)
class RunFolder:
    """Where a result's episodes are: an evaluation's job folder or a campaign cell's ``cells/<key>/`` in its job's
    folder, each with ``episodes.jsonl`` and the episodes' compact traces (``traces/``)."""

    path: Path
    #: a cell's suite: its (scenario, seed) episodes in order (the folder holds both suites'); None: every record
    episodes: list[tuple[str, int]] | None = None

    def records(self) -> list[Any] | None:
        """The episode records (of the suite, for a cell), None when the file is gone."""
        from foresight.core.evaluation.runner import read_records

        path = self.path / "episodes.jsonl"
        if not path.is_file():
            return None
        records = read_records(path)
        if self.episodes is None:
            return records
        by_pair = {(r.scenario, r.seed): r for r in records}
        return [by_pair[p] for p in self.episodes if p in by_pair]

    def trace(self, name: str) -> Path | None:
        """The file ``name`` (a trace name, ``core.render.episode_trace.trace_name``) in the folder, if there."""
        path = self.path / name
        return path if path.is_file() and path.resolve().is_relative_to(self.path.resolve()) else None


def run_folder(engine: Engine, store_root: Path, ident: str) -> RunFolder | None:
    """The run folder of an evaluation id or a campaign cell ``CAMPAIGN_ID:RANK[:SUITE]``; None where the record keeps
    none (a row without its job, a cell written before cells kept their folders). JobNotFound for an unknown id."""
    if ":" not in ident:
        with session_factory(engine)() as session:
            row = _get(session, Evaluation, ident, "evaluation")
        return (
            None
            if row.job_id is None
            else RunFolder(folders.resolve_under(store_root, folders.job_dir(store_root, row.job_id)))
        )
    cell = campaign_cell(engine, ident)
    if cell is None or cell.job_id is None or cell.cell.run_dir is None or cell.suites is None:
        return None
    path = folders.resolve_under(
        store_root, f"{folders.job_dir(store_root, cell.job_id)}/{cell.cell.run_dir}"
    )
    return RunFolder(path, [tuple(p) for p in cell.suites[cell.suite]])


@dataclass(frozen=True)
class CellRun:
    """A campaign cell as its campaign job's result holds it."""

    job_id: str | None
    config: dict[str, Any]  #: the campaign row's config
    cell: Any  #: core.evaluation.campaign_result.CellResult
    suite: str  #: global or hard
    suites: (
        dict[str, list[tuple[str, int]]] | None
    )  #: the campaign's suites (None: a result from before they were kept)


def campaign_cell(engine: Engine, ident: str) -> CellRun | None:
    """The cell ``CAMPAIGN_ID:RANK[:SUITE]`` (rank 1 = best) from its job's result; None when the job keeps no result.
    JobNotFound for an unknown campaign, rank or suite."""
    from foresight.core.evaluation.campaign_result import CampaignCells

    campaign_id, _, rest = ident.partition(":")
    rank, _, suite = rest.partition(":")
    with session_factory(engine)() as session:
        found = _get(session, Campaign, campaign_id, "campaign")
        job = None if found.job_id is None else job_reads.get_job(engine, found.job_id)
    if (suite or "global") not in SUITES:
        raise queue.JobNotFound(f"a campaign cell's suite is global or hard, not {suite!r}")
    if job is None or job["result"] is None:
        return None
    result = CampaignCells.model_validate(job["result"])
    if _rank(rank) is None or not 1 <= int(rank) <= len(result.ranked):
        raise queue.JobNotFound(f"campaign {campaign_id!r} has no cell of rank {rank}")
    return CellRun(found.job_id, found.config, result.cell(int(rank)), suite or "global", result.suites)


def comparison_setup(engine: Engine, ident: str) -> dict[str, Any] | None:
    """What an evaluation or campaign cell (``CAMPAIGN_ID:RANK[:SUITE]``) ran, in the one canonical shape of
    ``core.evaluation.delta.run_setup`` (the planner and model of a cell come from its campaign job's result);
    None for a record without its run config or job result (rows written before they were kept)."""
    from pydantic import ValidationError

    from foresight.core.evaluation.config import EvaluationConfig
    from foresight.core.evaluation.delta import run_setup
    from foresight.core.evaluation.runner import seed_source

    with session_factory(engine)() as session:
        row = session.get(Evaluation, ident)
        if row is not None:
            try:
                stage = EvaluationConfig.model_validate(row.config["stage"])
            except (KeyError, ValidationError):  # a row without its stage config, or another version's
                return None
            return run_setup(
                stage.planner.name,
                row.model_id or stage.planner.model,
                stage.bundle,
                stage.matrix,
                seed_source(stage),
                stage.max_steps,
            )
    found = campaign_cell(engine, ident)
    if found is None:
        return None
    cell, config = found.cell, found.config
    episodes = (
        f"hard suite, manifest {config.get('seed_manifest')}" if found.suite == "hard" else "global suite"
    )
    return run_setup(
        f"{cell.planner.name} ({cell.variant})",
        cell.planner.model_id,
        None,
        config.get("matrix"),
        episodes,
        config.get("horizon"),
    )
