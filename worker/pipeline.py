"""The ``pipeline`` job kind: the seed runbook as child jobs, run in the pipeline's own worker slot.

Each stage is a real job row (``parent_id`` = the pipeline, idempotency key ``pipeline:<id>:<stage>``) with
its own progress, artifacts and result records (datasets, evaluations, campaigns), exactly as if it had been
submitted alone: the pipeline submits it, then claims that very row itself and runs it through the worker's
own code path (:class:`ChildWorker`, a :class:`~worker.runner.JobWorker` that never polls the queue). So a
single worker with one slot never waits on its own children; when another worker took a child first, the
pipeline waits for it to end. Child leases are renewed by the pipeline's own heartbeat thread.

Resume: a retried (or reclaimed) pipeline finds its children by key: succeeded ones are not run again, a
failed or cancelled one is retried (training and campaigns resume from their checkpoints), a queued one is
claimed. The candidate model is registered in the registry (status ``candidate``) straight after training and
promoted only when the required gates pass; a failing gate is a succeeded pipeline job whose result says
``exit_code: 2`` (the summary report is written either way).
"""

from __future__ import annotations

import contextlib
import threading
import time
from functools import cache
from pathlib import Path
from typing import Any, Literal

from pydantic import create_model

from core.errors import CoreError
from core.pipeline.config import PipelineConfig
from core.stages.context import Cancelled, StageContext

PipelineSpec = create_model("PipelineSpec", __base__=PipelineConfig, kind=(Literal["pipeline"], "pipeline"))  # type: ignore[valid-type]
POLL_S = 1.0  #: [s] how often a pipeline looks at a child another worker is running


@cache
def _engine(database_url: str, busy_timeout_ms: int) -> Any:
    from api.db.session import make_engine

    return make_engine(database_url, busy_timeout_ms=busy_timeout_ms)


def worker_services(ctx: StageContext) -> tuple[Any, Any]:
    """(settings, engine) of the worker running this job: its context's resolver holds both (a pipeline
    needs the job store itself); outside a worker, the environment's settings."""
    from api.registry import Resolver
    from api.settings import Settings

    resolver = getattr(ctx.resolve_bundle, "__self__", None)
    if isinstance(resolver, Resolver):
        return resolver.settings, resolver.sessions.kw["bind"]
    settings = Settings()
    return settings, _engine(settings.resolved_database_url, settings.sqlite_busy_timeout_ms)


def _child_worker_class() -> type:
    from worker.runner import JobWorker

    class ChildWorker(JobWorker):
        """Runs the pipeline's children through the worker's own code path (records, artifacts, retries)."""

        def __init__(self, settings: Any, engine: Any, *, owner: str, workers: int | None,
                     on_progress: Any, parent_cancelled: Any) -> None:
            super().__init__(settings, engine, concurrency=1)
            self.id = owner
            self.workers = workers
            self.on_progress = on_progress
            self.parent_cancelled = parent_cancelled

        def _context(self, held: Any, workdir: Path) -> StageContext:
            ctx = super()._context(held, workdir)
            inner = ctx.progress

            def progress(fraction: float, message: str) -> None:
                inner(fraction, message)
                self.on_progress(fraction, message)

            ctx.progress = progress
            if self.workers:  # the pipeline's own request wins over the worker's FORESIGHT_STAGE_WORKERS
                ctx.workers = self.workers
            return ctx

        def beat(self) -> None:
            """Renew the held child's lease; pass the parent's cancellation or stop on to it."""
            from api.db import queue

            with self._lock:
                held = dict(self._held)
            if not held:
                return
            cancel, lost = queue.heartbeat(self.engine, self.id, list(held), self.settings.lease_s)
            stop = self.parent_cancelled()
            for job_id, h in held.items():
                h.cancel_requested = h.cancel_requested or job_id in cancel or stop == "cancel"
                h.lost = h.lost or job_id in lost
                h.shutdown = h.shutdown or stop == "stop"
                if stop == "cancel":
                    with contextlib.suppress(queue.Conflict):
                        queue.request_cancel(self.engine, job_id)

    return ChildWorker


class ChildJobs:
    """``run_child`` of a pipeline job: stage -> child job row, claimed and run here."""

    def __init__(self, ctx: StageContext, config: PipelineConfig, *, settings: Any = None, engine: Any = None):
        from api.db import queue

        self.ctx = ctx
        self.config = config
        self.parent_id = ctx.workdir.name
        if settings is None or engine is None:
            settings, engine = worker_services(ctx)
        self.settings, self.engine = settings, engine
        try:
            parent = queue.get_job(self.engine, self.parent_id)
        except queue.JobNotFound:
            raise CoreError(f"pipeline job {self.parent_id} is not in {self.settings.resolved_database_url}: the "
                            "worker's FORESIGHT_* settings must be in its environment") from None
        if parent["kind"] != "pipeline":
            raise CoreError(f"job {self.parent_id} is a {parent['kind']} job, not a pipeline")
        self.owner = f"{(parent['lease_owner'] or 'worker')[:50]}/pipeline"
        self.children: dict[str, str] = {}  #: stage -> child job id
        self._progress = lambda fraction, message: None
        self.worker = _child_worker_class()(
            self.settings, self.engine, owner=self.owner, workers=config.workers,
            on_progress=lambda f, m: self._progress(f, m), parent_cancelled=self._parent_stop)
        self._beat_stop = threading.Event()
        self._beat = threading.Thread(target=self._beat_loop, name=f"pipeline-{self.parent_id[:8]}", daemon=True)
        self._beat.start()

    def close(self) -> None:
        self._beat_stop.set()
        self._beat.join(timeout=5.0)

    def _beat_loop(self) -> None:
        import logging

        while not self._beat_stop.wait(self.settings.heartbeat_s):
            try:
                self.worker.beat()
            except Exception:  # noqa: BLE001 - the database is briefly unavailable: try again next beat
                logging.getLogger(__name__).exception("pipeline child heartbeat failed")

    def _parent_stop(self) -> str | None:
        """'cancel' when the pipeline's cancellation was requested, 'stop' when it must stop otherwise
        (worker shutdown, timeout, lost lease: children are released to the queue), else None."""
        from api.db import queue

        if not self.ctx.is_cancelled():
            return None
        try:
            return "cancel" if queue.get_job(self.engine, self.parent_id)["cancel_requested"] else "stop"
        except queue.JobNotFound:
            return "cancel"

    # ---------------------------------------------------------------- run_child
    def __call__(self, stage: str, kind: str, spec: dict[str, Any], progress: Any) -> Any:
        if kind == "register":
            return self._register(spec)
        if kind == "promote":
            return self._promote(spec)
        return self._run_stage(stage, kind, spec, progress)

    def _run_stage(self, stage: str, kind: str, spec: dict[str, Any], progress: Any) -> Any:
        from api.db import queue
        from worker.kinds import KINDS

        if kind not in KINDS:
            raise CoreError(f"stage {stage}: this worker has no {kind!r} job kind")
        body = KINDS[kind].spec.model_validate({**spec, "kind": kind}).model_dump(mode="json")
        try:
            job, created = queue.submit(self.engine, kind=kind, spec=body, parent_id=self.parent_id,
                                        idempotency_key=f"pipeline:{self.parent_id}:{stage}",
                                        max_attempts=self.settings.max_attempts)
        except queue.IdempotencyConflict:
            raise CoreError(f"stage {stage}: its child job was submitted with a different spec") from None
        child_id = job["id"]
        self.children[stage] = child_id
        self._progress = progress
        ran = False
        retried = False
        while True:
            job = queue.get_job(self.engine, child_id)
            status = job["status"]
            if status == queue.SUCCEEDED:
                return self._outcome(stage, kind, job, resumed=not (created or ran or retried))
            if status in (queue.FAILED, queue.CANCELLED):
                if ran or retried or (status == queue.CANCELLED and self.ctx.is_cancelled()):
                    if status == queue.CANCELLED:
                        raise Cancelled(f"stage {stage} ({kind} job {child_id}) was cancelled")
                    raise CoreError(f"{kind} job {child_id} failed: {job.get('error_type')}: {job.get('error_message')}")
                self.ctx.log(f"stage {stage}: retrying its {status} child job {child_id}")
                queue.retry(self.engine, child_id)  # resume from the failed stage
                retried = True
                continue
            if self.ctx.is_cancelled():
                if status == queue.RUNNING and self._parent_stop() == "cancel":
                    with contextlib.suppress(queue.Conflict):  # another worker runs it: ask it to stop
                        queue.request_cancel(self.engine, child_id)
                self.ctx.check_cancelled()
            if status == queue.QUEUED:
                claimed = queue.claim_id(self.engine, child_id, self.owner, self.settings.lease_s)
                if claimed is not None:
                    self.ctx.log(f"stage {stage}: running {kind} job {child_id}")
                    self.worker._run(claimed)
                    ran = True
                    if self.ctx.is_cancelled():
                        raise Cancelled(f"pipeline stopped during stage {stage}")
                continue
            time.sleep(POLL_S)  # running elsewhere: another worker took it first

    def _outcome(self, stage: str, kind: str, job: dict[str, Any], *, resumed: bool) -> Any:
        from api import store
        from core.pipeline.runbook import ChildRun

        # the child's report page was written by the worker code path that ran it (JobWorker._execute)
        folder = store.resolve_under(self.settings.store_root, store.job_dir(self.settings.store_root, job["id"]))
        result = dict(job["result"] or {})
        report = f"/ui/jobs/{job['id']}/files/report.html" if (folder / "report.html").is_file() else None
        wall = job["finished_at"] - job["started_at"] if job.get("finished_at") and job.get("started_at") else None
        return ChildRun(result=result, ident=job["id"], job_id=job["id"], wall_s=wall, resumed=resumed, report=report,
                        artifacts={"job": f"/v1/jobs/{job['id']}"})

    # ---------------------------------------------------------------- registry
    def _register(self, spec: dict[str, Any]) -> Any:
        from sqlalchemy import select

        from api.db.models import Artifact, Model, ModelStatus
        from api.db.session import session_factory
        from core.pipeline.runbook import ChildRun

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
        from api import store

        try:
            from core.predict.nn.checkpoint import read_checkpoint

            return dict(read_checkpoint(store.resolve_under(self.settings.store_root, checkpoint))["timebase"])
        except Exception:  # noqa: BLE001 - provenance only
            return {}

    def _promote(self, spec: dict[str, Any]) -> Any:
        from sqlalchemy import update

        from api.db.models import Model, ModelStatus
        from api.db.session import session_factory
        from core.pipeline.runbook import ChildRun

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
    from core.pipeline.runbook import run_pipeline

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

    from api.db.models import GateResult

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
