"""The ``pipeline`` job kind: the seed runbook as child jobs, run in the pipeline's own worker slot.

Each stage is a real job row (``parent_id`` = the pipeline, idempotency key ``pipeline:<id>:<stage>``) with
its own progress, artifacts and result records (datasets, evaluations, campaigns), exactly as if it had been
submitted alone: the pipeline submits it, then runs that very row itself through the worker's own code path, or
waits for the worker that took it first (``ctx.children``, the worker's child-job facility). So a
single worker with one slot never waits on its own children.

Resume: a retried (or reclaimed) pipeline finds its children by key: succeeded ones are not run again, a
failed or cancelled one is retried (training and campaigns resume from their checkpoints), a queued one is
claimed. The candidate model is registered in the registry (status ``candidate``) straight after training and
promoted only when the required gates pass; a failing gate is a succeeded pipeline job whose result says
``exit_code: 2`` (the summary report is written either way).
"""

from __future__ import annotations

from typing import Any

from foresight.core.errors import CoreError
from foresight.core.jobs.pipeline.config import PipelineConfig
from foresight.core.jobs.pipeline.runbook import ChildRun, run_pipeline
from foresight.core.reports.pipeline_summary import PipelineResult
from foresight.core.runtime.context import StageContext


class ChildJobs:
    """``run_child`` of a pipeline job: stage -> child job, run here or waited for (``ctx.children``)."""

    def __init__(self, ctx: StageContext, config: PipelineConfig):
        self.ctx = ctx
        self.config = config
        self.jobs = ctx.children("pipeline", config.workers)
        self.parent_id = self.jobs.parent_id
        self.children: dict[str, str] = {}  #: stage -> child job id

    def close(self) -> None:
        self.jobs.close()

    def __call__(self, stage: str, kind: str, spec: dict[str, Any], progress: Any) -> ChildRun:
        if kind == "register":
            return self._register(spec)
        if kind == "promote":
            row = self.jobs.promote_model(spec["model_id"], spec["to"])
            self.ctx.log(f"promoted {row['model_id']} to {row['status']}")
            return ChildRun(
                result=row, ident=row["model_id"], artifacts={"model": f"/v1/models/{row['model_id']}"}
            )
        job, created = self.jobs.submit(
            f"stage {stage}", kind, spec, key=f"pipeline:{self.parent_id}:{stage}"
        )
        child_id = job["id"]
        self.children[stage] = child_id
        rows, touched = self.jobs.run(
            f"stage {stage}",
            [child_id],
            on_progress=lambda _child, fraction, message: progress(fraction, message),
        )
        return self._outcome(rows[child_id], resumed=not (created or child_id in touched))

    def _outcome(self, job: dict[str, Any], *, resumed: bool) -> ChildRun:
        # the child's report page was written by the worker code path that ran it
        report = (
            f"/ui/jobs/{job['id']}/files/report.html"
            if (self.jobs.folder(job["id"]) / "report.html").is_file()
            else None
        )
        wall = (
            job["finished_at"] - job["started_at"]
            if job.get("finished_at") and job.get("started_at")
            else None
        )
        return ChildRun(
            result=dict(job["result"] or {}),
            ident=job["id"],
            job_id=job["id"],
            wall_s=wall,
            resumed=resumed,
            report=report,
            artifacts={"job": f"/v1/jobs/{job['id']}"},
        )

    def _register(self, spec: dict[str, Any]) -> ChildRun:
        train_job = self.children.get(spec.get("train_stage", "train"))
        if train_job is None:
            raise CoreError("register: the training stage has not run")
        provenance = f"pipeline {self.config.name} (job {self.parent_id}), trained by job {train_job}"
        row = self.jobs.register_model(spec["model_id"], train_job, {**spec, "provenance": provenance})
        if not row["resumed"]:
            self.ctx.log(f"registered {row['model_id']} (candidate) from training job {train_job}")
        return ChildRun(
            result={"model_id": row["model_id"], "status": row["status"], "train_job": train_job},
            ident=row["model_id"],
            resumed=row["resumed"],
            artifacts={"model": f"/v1/models/{row['model_id']}"},
        )


def run_pipeline_job(config: PipelineConfig, ctx: StageContext) -> PipelineResult:
    children = ChildJobs(ctx, config)
    try:
        return run_pipeline(config, ctx, children, run_id=children.parent_id)
    finally:
        children.close()
