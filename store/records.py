"""Result records of finished stage jobs, written in the transaction that marks the job succeeded
(so a job's records exist exactly once, together with its final status). Ids are the job's id.

Each recorder reads the job's result as its stage's result model (validated) and derives the rows from its
fields, so a renamed field is an error here, never a NULL in a row."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from sqlalchemy import Connection, insert, select

from foresight.core.evaluation.campaign_result import CampaignResult
from foresight.core.evaluation.evaluation_result import (
    EvaluationResult,
    evaluation_metrics,
    evaluation_run_config,
)
from foresight.core.evaluation.gates import GateResult as Gate
from foresight.core.reports.pipeline_summary import PipelineResult
from foresight.core.training.collect import CollectResult
from foresight.store.models import (
    Campaign,
    CampaignCell,
    Dataset,
    Evaluation,
    FailureTaxonomy,
    GateResult,
    Model,
)

#: ``record(conn, job, result, job_dir)``: ``job_dir`` is the job's store-relative artifact folder
Recorder = Callable[[Connection, dict[str, Any], dict[str, Any], str], None]


def dataset(conn: Connection, job: dict[str, Any], result: dict[str, Any], job_dir: str) -> None:
    res = CollectResult.model_validate(result)
    conn.execute(
        insert(Dataset.__table__).values(
            id=job["id"],
            job_id=job["id"],
            path=f"{job_dir}/{res.dataset}",
            sha256=res.sha256,
            summary={**res.summary.model_dump(mode="json"), "outcomes": res.outcomes},
            created_at=time.time(),
        )
    )


def evaluation(conn: Connection, job: dict[str, Any], result: dict[str, Any], job_dir: str) -> None:
    res = EvaluationResult.model_validate(result)
    model_id: str | None = res.planner.model_id
    if conn.execute(select(Model.id).where(Model.id == model_id)).first() is None:
        model_id = None  # a model outside the registry (e.g. constant velocity): no foreign key to keep
    conn.execute(
        insert(Evaluation.__table__).values(
            id=job["id"],
            job_id=job["id"],
            model_id=model_id,
            bundle_id=res.bundle,
            config=evaluation_run_config(res).model_dump(mode="json"),
            metrics=evaluation_metrics(res).model_dump(mode="json"),
            per_scenario=[g.model_dump(mode="json") for g in res.aggregates.per_scenario],
            created_at=time.time(),
        )
    )
    rows = [
        {"evaluation_id": job["id"], "category": k, "count": v, "examples": []}
        for k, v in res.taxonomy.items()
    ]
    if rows:
        conn.execute(insert(FailureTaxonomy.__table__), rows)
    _gate(conn, job, None, res.gate)


def campaign(conn: Connection, job: dict[str, Any], result: dict[str, Any], job_dir: str) -> None:
    res = CampaignResult.model_validate(result)
    conn.execute(
        insert(Campaign.__table__).values(
            id=job["id"],
            job_id=job["id"],
            config=res.model_dump(mode="json", include={"matrix", "seed_manifest", "grid", "horizon"}),
            best=res.best.model_dump(mode="json") if res.best else None,
            created_at=time.time(),
        )
    )
    cells = [
        {
            "campaign_id": job["id"],
            "rank": i + 1,
            "params": c.params().model_dump(),
            "metrics": c.metrics().model_dump(mode="json"),
        }
        for i, c in enumerate(res.ranked)
    ]
    if cells:
        conn.execute(insert(CampaignCell.__table__), cells)
    _gate(conn, job, job["id"], res.gate)


def _gate(conn: Connection, job: dict[str, Any], campaign_id: str | None, gate: Gate | None) -> None:
    if gate is None:
        return
    conn.execute(
        insert(GateResult.__table__).values(
            job_id=job["id"],
            campaign_id=campaign_id,
            gate="gate",
            passed=gate.passed,
            details=gate.model_dump(mode="json"),
            created_at=time.time(),
        )
    )


def pipeline_gates(conn: Connection, job: dict[str, Any], result: dict[str, Any], job_dir: str) -> None:
    """The pipeline's gate verdicts as gate-result rows (``pipeline:<gate>``), written with its final status."""
    res = PipelineResult.model_validate(result)
    rows = [
        {
            "job_id": job["id"],
            "campaign_id": None,
            "gate": f"pipeline:{g.name}",
            "passed": g.passed,
            "details": g.model_dump(mode="json"),
            "created_at": time.time(),
        }
        for g in res.summary.gates
        if g.passed is not None
    ]
    if rows:
        conn.execute(insert(GateResult.__table__), rows)


#: job kind -> the recorder of its result rows (kinds without rows are absent; names checked against the kinds)
RECORDERS: dict[str, Recorder] = {
    "collect": dataset,
    "mix": dataset,
    "import_dataset": dataset,
    "evaluate": evaluation,
    "campaign": campaign,
    "pipeline": pipeline_gates,
}
