"""Result records of finished stage jobs, written in the transaction that marks the job succeeded
(so a job's records exist exactly once, together with its final status). Ids are the job's id."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from sqlalchemy import Connection, insert, select

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
    conn.execute(insert(Dataset.__table__).values(
        id=job["id"], job_id=job["id"], path=f"{job_dir}/{result['dataset']}", sha256=result.get("sha256"),
        summary={**result.get("summary", {}), "outcomes": result.get("outcomes", {})}, created_at=time.time(),
    ))  # fmt: skip


def evaluation(conn: Connection, job: dict[str, Any], result: dict[str, Any], job_dir: str) -> None:
    aggregates = result.get("aggregates", {})
    model_id = (result.get("planner") or {}).get("model_id")
    if model_id and conn.execute(select(Model.id).where(Model.id == model_id)).first() is None:
        model_id = None  # a model outside the registry (e.g. constant velocity): no foreign key to keep
    metrics = {
        "success_rate": result.get("success_rate"), "collision_rate": result.get("collision_rate"),
        "episodes": result.get("episodes"), "status": result.get("status"), "overall": aggregates.get("overall"),
    }  # fmt: skip
    conn.execute(insert(Evaluation.__table__).values(
        id=job["id"], job_id=job["id"], model_id=model_id, bundle_id=result.get("bundle"),
        config={"stage": result.get("config", {}), "planner": (result.get("planner") or {}).get("config", {})},
        metrics=metrics, per_scenario=aggregates.get("per_scenario", []), created_at=time.time(),
    ))  # fmt: skip
    rows = [{"evaluation_id": job["id"], "category": k, "count": int(v), "examples": []}
            for k, v in (result.get("taxonomy") or {}).items()]  # fmt: skip
    if rows:
        conn.execute(insert(FailureTaxonomy.__table__), rows)
    _gate(conn, job, None, result.get("gate"))


def campaign(conn: Connection, job: dict[str, Any], result: dict[str, Any], job_dir: str) -> None:
    conn.execute(insert(Campaign.__table__).values(
        id=job["id"], job_id=job["id"], config={k: result.get(k) for k in ("matrix", "seed_manifest", "grid", "horizon")},
        best=result.get("best"), created_at=time.time(),
    ))  # fmt: skip
    cells = [{"campaign_id": job["id"], "rank": i + 1, "params": {"checkpoint": c.get("checkpoint"), "variant": c.get("variant")},
              "metrics": {"hard": c.get("hard"), "global": c.get("global"), "vs_baseline": c.get("vs_baseline")}} for i, c in enumerate(result.get("ranked", []))]  # fmt: skip
    if cells:
        conn.execute(insert(CampaignCell.__table__), cells)
    _gate(conn, job, job["id"], result.get("gate"))


def _gate(conn: Connection, job: dict[str, Any], campaign_id: str | None, gate: Any) -> None:
    if not isinstance(gate, dict):
        return
    passed = bool(gate.get("passed", gate.get("status") == "passed"))
    conn.execute(insert(GateResult.__table__).values(
        job_id=job["id"], campaign_id=campaign_id, gate=str(gate.get("name", "gate")), passed=passed, details=gate,
        created_at=time.time(),
    ))  # fmt: skip


def pipeline_gates(conn: Connection, job: dict[str, Any], result: dict[str, Any], job_dir: str) -> None:
    """The pipeline's gate verdicts as gate-result rows (``pipeline:<gate>``), written with its final status."""
    rows = [{"job_id": job["id"], "campaign_id": None, "gate": f"pipeline:{g['name']}", "passed": bool(g["passed"]),
             "details": g, "created_at": time.time()}
            for g in (result.get("summary") or {}).get("gates") or [] if g.get("passed") is not None]
    if rows:
        conn.execute(insert(GateResult.__table__), rows)


#: job kind -> the recorder of its result rows (kinds without rows are absent; names checked against the kinds)
RECORDERS: dict[str, Recorder] = {
    "collect": dataset, "mix": dataset, "import_dataset": dataset, "evaluate": evaluation, "campaign": campaign,
    "pipeline": pipeline_gates,
}  # fmt: skip
