"""Child jobs run in their parent's own worker slot: the pipeline's stages.

The worker gives every stage a child-job facility (``ctx.children(role, workers)``, a :class:`ChildRunner`).
A parent submits real job rows (``parent_id`` = the parent, an idempotency key it derives from its own id), so
each child has its own progress, artifacts and result records, exactly as if submitted alone. Then it drives
them (:meth:`ChildRunner.run`): a queued child is claimed by id and run right here through the worker's own code
path (a one-slot child worker that never polls the queue, lease owner ``<parent's worker>/<role>``), so a single
worker with one slot never waits on its own children; a child another worker took first is waited for. Child
leases are renewed by the runner's own heartbeat thread.

Cancelling the parent cancels its children (queued ones at once, running ones are asked to stop); a parent that
stops otherwise (worker shutdown, timeout, lost lease) leaves them to whoever claims them. A retried (or
reclaimed) parent finds its children by key: a succeeded child is not run again, a failed or cancelled one is
retried once (training and campaigns resume from their checkpoints), a queued one is claimed.
"""

from __future__ import annotations

import contextlib
import logging
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol

from foresight.core.errors import CoreError, NotFoundError
from foresight.core.jobs.kinds import KINDS
from foresight.core.runtime.context import Cancelled, ChildProgress, StageContext
from foresight.store import folders, job_reads, queue, registry
from foresight.store.models import ModelStatus
from foresight.store.settings import Settings

POLL_S = 1.0  #: [s] how often a parent looks at children other workers are running


class Worker(Protocol):
    """What a child runner needs of the worker running the parent (``worker.runner.JobWorker``)."""

    id: str
    settings: Settings
    engine: Any

    def child_worker(
        self,
        owner: str,
        workers: int | None,
        on_progress: ChildProgress,
        parent_stop: Callable[[], str | None],
    ) -> Worker: ...

    def run_job(self, job: dict[str, Any]) -> None: ...

    def beat(self) -> None: ...


def _row(m: Any) -> dict[str, Any]:
    return {
        "id": m.id,
        "status": m.status,
        "sha256": m.sha256,
        "lineage": dict(m.lineage or {}),
        "created_at": m.created_at,
    }


class ChildRunner:
    """The children of the job running in ``ctx`` (``ctx.job_id``), run by ``worker``: submitted, run in the
    parent's slot or waited for. ``role`` names the parent in messages and in the children's lease owner
    (``<parent's worker>/<role>``). Call :meth:`close` when done (it stops the heartbeat thread)."""

    def __init__(self, worker: Worker, ctx: StageContext, role: str, workers: int | None = None) -> None:
        if ctx.job_id is None:
            raise CoreError(f"{role}: this context runs no job, so it has no child jobs")
        self.ctx = ctx
        self.role = role
        self.parent_id = ctx.job_id
        self.settings, self.engine = worker.settings, worker.engine
        self.owner = f"{worker.id[:50]}/{role}"
        self._on_progress: ChildProgress | None = None
        self.worker = worker.child_worker(self.owner, workers, self._progress, self.parent_stop)
        self._beat_stop = threading.Event()
        self._beat = threading.Thread(
            target=self._beat_loop, name=f"{role}-{self.parent_id[:8]}", daemon=True
        )
        self._beat.start()

    def close(self) -> None:
        self._beat_stop.set()
        self._beat.join(timeout=5.0)

    def _progress(self, child_id: str, fraction: float, message: str) -> None:
        if self._on_progress is not None:
            self._on_progress(child_id, fraction, message)

    def _beat_loop(self) -> None:
        while not self._beat_stop.wait(self.settings.heartbeat_s):
            try:
                self.worker.beat()
            except Exception:  # noqa: BLE001 - the database is briefly unavailable: try again next beat
                logging.getLogger(__name__).exception("%s child heartbeat failed", self.role)

    def parent_stop(self) -> str | None:
        """'cancel' when the parent's cancellation was requested, 'stop' when it must stop otherwise
        (worker shutdown, timeout, lost lease: children are left to the queue), else None."""
        if not self.ctx.is_cancelled():
            return None
        try:
            return "cancel" if job_reads.get_job(self.engine, self.parent_id)["cancel_requested"] else "stop"
        except queue.JobNotFound:
            return "cancel"

    def folder(self, child_id: str) -> Path:
        return folders.resolve_under(
            self.settings.store_root, folders.job_dir(self.settings.store_root, child_id)
        )

    def register_model(self, model_id: str, train_job: str, spec: dict[str, Any]) -> dict[str, Any]:
        status = (
            spec.get("status") or ModelStatus.candidate.value
        )  # relaxed: a pipeline whose gates are relaxed
        return registry.register_checkpoint(
            self.engine,
            self.settings,
            model_id=model_id,
            job_id=train_job,
            metadata=spec,
            status=status,
            resume=True,
        )

    def promote_model(self, model_id: str, to: str) -> dict[str, Any]:
        return registry.promote(self.engine, model_id, to)

    def model_rows(self) -> list[dict[str, Any]]:
        return [_row(m) for m in registry.models(self.engine)]

    def record_promotion(self, model_id: str, verdict: dict[str, Any]) -> None:
        registry.record_promotion(self.engine, model_id, verdict)

    def model_row(self, ident: str) -> dict[str, Any] | None:
        try:
            return _row(registry.Resolver(self.settings, self.engine).model_row(ident))
        except NotFoundError:
            return None

    def submit(self, label: str, kind: str, spec: dict[str, Any], key: str) -> tuple[dict[str, Any], bool]:
        """Queue the child ``kind`` job (its spec validated as the API would) under idempotency ``key``;
        returns ``(job, created)``: a known key returns the child an earlier attempt submitted."""
        if kind not in KINDS:
            raise CoreError(f"{label}: there is no {kind!r} job kind")
        body = KINDS[kind].spec.model_validate({**spec, "kind": kind}).model_dump(mode="json")
        try:
            return queue.submit(
                self.engine,
                kind=kind,
                spec=body,
                parent_id=self.parent_id,
                idempotency_key=key,
                max_attempts=self.settings.max_attempts,
                labels={"name": label},  # "stage train": the parent's page and `jobs ls` name it by its stage
            )
        except queue.IdempotencyConflict:
            raise CoreError(f"{label}: its child job was submitted with a different spec") from None

    def run(
        self,
        label: str,
        child_ids: list[str],
        on_progress: ChildProgress | None = None,
        on_wait: Callable[[dict[str, dict[str, Any]]], None] | None = None,
    ) -> tuple[dict[str, dict[str, Any]], set[str]]:
        """Drive ``child_ids`` until every one succeeded: claim and run queued ones here (their progress goes to
        ``on_progress``), wait for the others (calling ``on_wait(rows)`` between looks). Returns (final rows by
        id, ids run or retried by this call).

        Raises :class:`Cancelled` when the parent stops or a child was cancelled with it, :class:`CoreError`
        when a child fails after this call ran or retried it."""
        self._on_progress = on_progress
        touched: set[str] = set()
        while True:
            rows = {cid: job_reads.get_job(self.engine, cid) for cid in child_ids}
            if all(r["status"] == queue.SUCCEEDED for r in rows.values()):
                return rows, touched
            if self.ctx.is_cancelled():
                if self.parent_stop() == "cancel":
                    for cid, job in rows.items():
                        if job["status"] in (queue.QUEUED, queue.RUNNING):
                            with contextlib.suppress(
                                queue.Conflict
                            ):  # queued: cancelled; running: asked to stop
                                queue.request_cancel(self.engine, cid)
                raise Cancelled(f"{self.role} stopped during {label}")
            retried = False
            for cid, job in rows.items():
                status = job["status"]
                if status not in (queue.FAILED, queue.CANCELLED):
                    continue
                if cid in touched:
                    if status == queue.CANCELLED:
                        raise Cancelled(f"{label} ({job['kind']} job {cid}) was cancelled")
                    raise CoreError(
                        f"{job['kind']} job {cid} failed: {job.get('error_type')}: {job.get('error_message')}"
                    )
                self.ctx.log(f"{label}: retrying its {status} child job {cid}")
                queue.retry(self.engine, cid)  # resume from where it failed
                touched.add(cid)
                retried = True
            if retried:
                continue
            claimed = None
            for cid, job in rows.items():
                if job["status"] == queue.QUEUED:
                    claimed = queue.claim_id(self.engine, cid, self.owner, self.settings.lease_s)
                    if claimed is not None:
                        break
            if claimed is not None:
                self.ctx.log(f"{label}: running {claimed['kind']} job {claimed['id']}")
                self.worker.run_job(claimed)
                touched.add(claimed["id"])
                continue  # a parent cancelled meanwhile cancels the other children at the top of the loop
            if on_wait is not None:
                on_wait(rows)
            time.sleep(POLL_S)  # running elsewhere: other workers took them first
