"""Child jobs run in their parent's own worker slot: the pipeline's stages and a sharded run's shards.

A parent submits real job rows (``parent_id`` = the parent, an idempotency key it derives from its own id), so
each child has its own progress, artifacts and result records, exactly as if submitted alone. Then it drives
them (:meth:`ChildRunner.run`): a queued child is claimed by id and run right here through the worker's own code
path (:class:`ChildWorker`, a :class:`~worker.runner.JobWorker` that never polls the queue), so a single worker
with one slot never waits on its own children; a child another worker took first is waited for. Child leases are
renewed by the runner's own heartbeat thread.

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
from functools import cache
from pathlib import Path
from typing import Any

from foresight.core.errors import CoreError
from foresight.core.stages.context import Cancelled, StageContext

POLL_S = 1.0  #: [s] how often a parent looks at children other workers are running

#: ``on_progress(child_id, fraction, message)`` of a child running in the parent's slot
ChildProgress = Callable[[str, float, str], None]


@cache
def _engine(database_url: str, busy_timeout_ms: int) -> Any:
    from foresight.store.session import make_engine

    return make_engine(database_url, busy_timeout_ms=busy_timeout_ms)


def worker_services(ctx: StageContext) -> tuple[Any, Any]:
    """(settings, engine) of the worker running this job: its context's resolver holds both (a parent job
    needs the job store itself); outside a worker, the environment's settings."""
    from foresight.store.registry import Resolver
    from foresight.store.settings import Settings

    resolver = getattr(ctx.resolve_bundle, "__self__", None)
    if isinstance(resolver, Resolver):
        return resolver.settings, resolver.sessions.kw["bind"]
    settings = Settings()
    return settings, _engine(settings.resolved_database_url, settings.sqlite_busy_timeout_ms)


@cache
def child_worker_class() -> type:
    from foresight.worker.runner import JobWorker

    class ChildWorker(JobWorker):
        """Runs a parent's children through the worker's own code path (records, artifacts, retries)."""

        def __init__(self, settings: Any, engine: Any, *, owner: str, workers: int | None,
                     on_progress: ChildProgress, parent_cancelled: Callable[[], str | None]) -> None:
            super().__init__(settings, engine, concurrency=1)
            self.id = owner
            self.workers = workers
            self.on_progress = on_progress
            self.parent_cancelled = parent_cancelled

        def _context(self, held: Any, workdir: Path) -> StageContext:
            ctx = super()._context(held, workdir)
            inner = ctx.progress
            job_id = held.job["id"]

            def progress(fraction: float, message: str) -> None:
                inner(fraction, message)
                self.on_progress(job_id, fraction, message)

            ctx.progress = progress
            if self.workers:  # the parent's own request wins over the worker's FORESIGHT_STAGE_WORKERS
                ctx.workers = self.workers
            return ctx

        def beat(self) -> None:
            """Renew the held child's lease; pass the parent's cancellation or stop on to it."""
            from foresight.store import queue

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


class ChildRunner:
    """The children of the job running in ``ctx`` (whose kind is one of ``parent_kinds``): submitted, run in the
    parent's slot or waited for. ``role`` names the parent in messages and in the children's lease owner
    (``<parent's worker>/<role>``). Call :meth:`close` when done (it stops the heartbeat thread)."""

    def __init__(self, ctx: StageContext, *, role: str, parent_kinds: tuple[str, ...], workers: int | None = None,
                 settings: Any = None, engine: Any = None) -> None:
        from foresight.store import queue

        self.ctx = ctx
        self.role = role
        self.parent_id = ctx.workdir.name
        if settings is None or engine is None:
            settings, engine = worker_services(ctx)
        self.settings, self.engine = settings, engine
        try:
            parent = queue.get_job(self.engine, self.parent_id)
        except queue.JobNotFound:
            raise CoreError(f"{role} job {self.parent_id} is not in {self.settings.resolved_database_url}: the "
                            "worker's FORESIGHT_* settings must be in its environment") from None
        if parent["kind"] not in parent_kinds:
            raise CoreError(f"job {self.parent_id} is a {parent['kind']} job, not a {' or '.join(parent_kinds)} job")
        self.owner = f"{(parent['lease_owner'] or 'worker')[:50]}/{role}"
        #: progress of the child running in this slot; replace it to follow children
        self.on_progress: ChildProgress = lambda child_id, fraction, message: None
        self.worker = child_worker_class()(
            self.settings, self.engine, owner=self.owner, workers=workers,
            on_progress=lambda c, f, m: self.on_progress(c, f, m), parent_cancelled=self.parent_stop)
        self._beat_stop = threading.Event()
        self._beat = threading.Thread(target=self._beat_loop, name=f"{role}-{self.parent_id[:8]}", daemon=True)
        self._beat.start()

    def close(self) -> None:
        self._beat_stop.set()
        self._beat.join(timeout=5.0)

    def _beat_loop(self) -> None:
        while not self._beat_stop.wait(self.settings.heartbeat_s):
            try:
                self.worker.beat()
            except Exception:  # noqa: BLE001 - the database is briefly unavailable: try again next beat
                logging.getLogger(__name__).exception("%s child heartbeat failed", self.role)

    def parent_stop(self) -> str | None:
        """'cancel' when the parent's cancellation was requested, 'stop' when it must stop otherwise
        (worker shutdown, timeout, lost lease: children are left to the queue), else None."""
        from foresight.store import queue

        if not self.ctx.is_cancelled():
            return None
        try:
            return "cancel" if queue.get_job(self.engine, self.parent_id)["cancel_requested"] else "stop"
        except queue.JobNotFound:
            return "cancel"

    def submit(self, label: str, kind: str, spec: dict[str, Any], key: str) -> tuple[dict[str, Any], bool]:
        """Queue the child ``kind`` job (its spec validated as the API would) under idempotency ``key``;
        returns ``(job, created)``: a known key returns the child an earlier attempt submitted."""
        from foresight.store import queue
        from foresight.worker.kinds import KINDS

        if kind not in KINDS:
            raise CoreError(f"{label}: this worker has no {kind!r} job kind")
        body = KINDS[kind].spec.model_validate({**spec, "kind": kind}).model_dump(mode="json")
        try:
            return queue.submit(self.engine, kind=kind, spec=body, parent_id=self.parent_id, idempotency_key=key,
                                max_attempts=self.settings.max_attempts)
        except queue.IdempotencyConflict:
            raise CoreError(f"{label}: its child job was submitted with a different spec") from None

    def run(self, label: str, child_ids: list[str],
            on_wait: Callable[[dict[str, dict[str, Any]]], None] | None = None) -> tuple[dict[str, dict[str, Any]], set[str]]:
        """Drive ``child_ids`` until every one succeeded: claim and run queued ones here, wait for the others
        (calling ``on_wait(rows)`` between looks). Returns (final rows by id, ids run or retried by this call).

        Raises :class:`Cancelled` when the parent stops or a child was cancelled with it, :class:`CoreError`
        when a child fails after this call ran or retried it."""
        from foresight.store import queue

        touched: set[str] = set()
        while True:
            rows = {cid: queue.get_job(self.engine, cid) for cid in child_ids}
            if all(r["status"] == queue.SUCCEEDED for r in rows.values()):
                return rows, touched
            if self.ctx.is_cancelled():
                if self.parent_stop() == "cancel":
                    for cid, job in rows.items():
                        if job["status"] in (queue.QUEUED, queue.RUNNING):
                            with contextlib.suppress(queue.Conflict):  # queued: cancelled; running: asked to stop
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
                    raise CoreError(f"{job['kind']} job {cid} failed: {job.get('error_type')}: {job.get('error_message')}")
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
                self.worker._run(claimed)
                touched.add(claimed["id"])
                continue  # a parent cancelled meanwhile cancels the other children at the top of the loop
            if on_wait is not None:
                on_wait(rows)
            time.sleep(POLL_S)  # running elsewhere: other workers took them first
