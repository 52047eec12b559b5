"""The ``pipeline`` job kind: the seed runbook as child jobs, run in the pipeline's own worker slot.

Each stage is a real job row (``parent_id`` = the pipeline, idempotency key ``pipeline:<id>:<stage>``) with
its own progress, artifacts and result records (datasets, evaluations, campaigns), exactly as if it had been
submitted alone: the pipeline submits it, then claims that very row itself and runs it through the worker's
own code path, or waits for the worker that took it first (the child machinery is shared with sharded runs:
:mod:`worker.children`). So a single worker with one slot never waits on its own children.

Resume: a retried (or reclaimed) pipeline finds its children by key: succeeded ones are not run again, a
failed or cancelled one is retried (training and campaigns resume from their checkpoints), a queued one is
claimed. The candidate model is registered in the registry (status ``candidate``) straight after training and
promoted only when the required gates pass; a failing gate is a succeeded pipeline job whose result says
``exit_code: 2`` (the summary report is written either way).
"""

from __future__ import annotations

import time
from typing import Any, Literal

from pydantic import create_model

from foresight.core.errors import CoreError
from foresight.core.pipeline.config import PipelineConfig
from foresight.core.stages.context import StageContext
from foresight.worker.children import ChildRunner, worker_services

PipelineSpec = create_model("PipelineSpec", __base__=PipelineConfig, kind=(Literal["pipeline"], "pipeline"))  # type: ignore[valid-type]

__all__ = ["ChildJobs", "PipelineSpec", "worker_services"]


class ChildJobs:
    """``run_child`` of a pipeline job: stage -> child job row, claimed and run here (worker.children)."""

    def __init__(self, ctx: StageContext, config: PipelineConfig, *, settings: Any = None, engine: Any = None):
        self.ctx = ctx
        self.config = config
        self.runner = ChildRunner(ctx, role="pipeline", parent_kinds=("pipeline",), workers=config.workers,
                                  settings=settings, engine=engine)
        self.parent_id, self.settings, self.engine = self.runner.parent_id, self.runner.settings, self.runner.engine
        self.owner = self.runner.owner
        self.children: dict[str, str] = {}  #: stage -> child job id

    def close(self) -> None:
        self.runner.close()

    # ---------------------------------------------------------------- run_child
    def __call__(self, stage: str, kind: str, spec: dict[str, Any], progress: Any) -> Any:
        if kind == "register":
            return self._register(spec)
        if kind == "promote":
            return self._promote(spec)
        return self._run_stage(stage, kind, spec, progress)

    def _run_stage(self, stage: str, kind: str, spec: dict[str, Any], progress: Any) -> Any:
        job, created = self.runner.submit(f"stage {stage}", kind, spec, key=f"pipeline:{self.parent_id}:{stage}")
        child_id = job["id"]
        self.children[stage] = child_id
        self.runner.on_progress = lambda _child, fraction, message: progress(fraction, message)
        rows, touched = self.runner.run(f"stage {stage}", [child_id])
        return self._outcome(stage, kind, rows[child_id], resumed=not (created or child_id in touched))

    def _outcome(self, stage: str, kind: str, job: dict[str, Any], *, resumed: bool) -> Any:
        from foresight.core.pipeline.runbook import ChildRun
        from foresight.store import folders

        # the child's report page was written by the worker code path that ran it (JobWorker._execute)
        folder = folders.resolve_under(self.settings.store_root, folders.job_dir(self.settings.store_root, job["id"]))
        result = dict(job["result"] or {})
        report = f"/ui/jobs/{job['id']}/files/report.html" if (folder / "report.html").is_file() else None
        wall = job["finished_at"] - job["started_at"] if job.get("finished_at") and job.get("started_at") else None
        return ChildRun(result=result, ident=job["id"], job_id=job["id"], wall_s=wall, resumed=resumed, report=report,
                        artifacts={"job": f"/v1/jobs/{job['id']}"})

    # ---------------------------------------------------------------- registry
    def _register(self, spec: dict[str, Any]) -> Any:
        from sqlalchemy import select

        from foresight.core.pipeline.runbook import ChildRun
        from foresight.store.models import Artifact, Model, ModelStatus
        from foresight.store.session import session_factory

        train_job = self.children.get(spec.get("train_stage", "train"))
        if train_job is None:
            raise CoreError("register: the training stage has not run")
        model_id = spec["model_id"]
        with session_factory(self.engine, write=True).begin() as session:
            existing = session.get(Model, model_id)
            if existing is not None:
                if existing.job_id != train_job:
                    raise CoreError(f"register: model id {model_id!r} already names another model (job {existing.job_id})")
                return ChildRun(result={"model_id": model_id, "status": existing.status, "train_job": train_job},
                                ident=model_id, resumed=True, artifacts={"model": f"/v1/models/{model_id}"})
            art = session.scalars(select(Artifact).where(Artifact.job_id == train_job, Artifact.name == "model.pt")).first()
            if art is None:
                raise CoreError(f"register: training job {train_job} has no model.pt artifact")
            session.add(Model(
                id=model_id, status=ModelStatus.candidate.value, checkpoint=art.path, sha256=art.sha256,
                time_base=self._time_base(art.path), lineage=spec.get("lineage", {}), training=spec.get("training", {}),
                metrics=spec.get("metrics", {}), tags=spec.get("tags", []),
                provenance=f"pipeline {self.config.name} (job {self.parent_id}), trained by job {train_job}",
                read_only=False, job_id=train_job, created_at=time.time(),
            ))  # fmt: skip
        self.ctx.log(f"registered {model_id} (candidate) from training job {train_job}")
        return ChildRun(result={"model_id": model_id, "status": "candidate", "train_job": train_job}, ident=model_id,
                        artifacts={"model": f"/v1/models/{model_id}"})

    def _time_base(self, checkpoint: str) -> dict[str, Any]:
        from foresight.store import folders

        try:
            from foresight.core.predict.nn.checkpoint import read_checkpoint

            return dict(read_checkpoint(folders.resolve_under(self.settings.store_root, checkpoint))["timebase"])
        except Exception:  # noqa: BLE001 - provenance only
            return {}

    def _promote(self, spec: dict[str, Any]) -> Any:
        from sqlalchemy import update

        from foresight.core.pipeline.runbook import ChildRun
        from foresight.store.models import Model, ModelStatus
        from foresight.store.session import session_factory

        model_id, target = spec["model_id"], spec["to"]
        with session_factory(self.engine, write=True).begin() as session:
            row = session.get(Model, model_id)
            if row is None:
                raise CoreError(f"promote: no model {model_id!r}")
            if target == ModelStatus.default.value:
                session.execute(update(Model).where(Model.status == ModelStatus.default.value, Model.id != model_id)
                                .values(status=ModelStatus.promoted.value))
            row.status = target
        self.ctx.log(f"promoted {model_id} to {target}")
        return ChildRun(result={"model_id": model_id, "status": target}, ident=model_id,
                        artifacts={"model": f"/v1/models/{model_id}"})


def run_pipeline_job(spec: Any, ctx: StageContext) -> dict[str, Any]:
    from foresight.core.pipeline.runbook import run_pipeline

    config = PipelineConfig.model_validate(spec.model_dump(exclude={"kind"}))
    children = ChildJobs(ctx, config)
    try:
        result = run_pipeline(config, ctx, children, run_id=children.parent_id)
    finally:
        children.close()
    return result.model_dump(mode="json")


def record_gates(conn: Any, job: dict[str, Any], result: dict[str, Any], job_dir: str) -> None:
    """The pipeline's gate verdicts as gate-result rows (``pipeline:<gate>``), written with its final status."""
    from sqlalchemy import insert

    from foresight.store.models import GateResult

    rows = [{"job_id": job["id"], "campaign_id": None, "gate": f"pipeline:{g['name']}", "passed": bool(g["passed"]),
             "details": g, "created_at": time.time()}
            for g in (result.get("summary") or {}).get("gates") or [] if g.get("passed") is not None]
    if rows:
        conn.execute(insert(GateResult.__table__), rows)


#: the ``pipeline`` JobKind's fields (worker/kinds.py registers it; no import of worker.kinds here: no cycle)
KIND_FIELDS = {
    "spec": PipelineSpec,
    "run": run_pipeline_job,
    "record": record_gates,
    "description": "the runbook as child jobs: collect, hard-case collect, mix, train (proxy), register, evaluate, "
    "diagnose, campaign, gates, promote",
}
