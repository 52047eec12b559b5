"""The job worker: claims jobs, runs their stage in a slot thread, heartbeats, finishes.

Life cycle (as procrastinate's): register a worker row; N slot threads each loop claim → run → finish;
one heartbeat thread renews the worker row and the leases of held jobs every ``heartbeat_s``, learns
about cancellation requests (so a cancel is noticed within about ``heartbeat_s`` + one stage step),
enforces job timeouts, and reaps jobs whose worker died. Stages run in-process in threads and stop
cooperatively through ``ctx.check_cancelled()``; a stage that needs CPU parallelism uses ``ctx.workers``.

Stopping (SIGTERM): no new claims; running jobs get ``shutdown_grace_s`` to finish, then are asked to stop
and are released to the queue (their attempt is not counted). A second stop request releases at once.
"""

from __future__ import annotations

import contextlib
import functools
import logging
import os
import shutil
import socket
import threading
import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from foresight.core.errors import CoreError
from foresight.core.jobs.budget import check_budget, work_size
from foresight.core.jobs.kinds import KINDS
from foresight.core.runtime.context import Cancelled, ChildProgress, StageContext
from foresight.store import folders, queue, records
from foresight.store.registry import Resolver
from foresight.store.session import Engine
from foresight.store.settings import REPO_ROOT, Settings
from foresight.worker import mlflow_export
from foresight.worker.children import ChildRunner
from foresight.worker.memory import memory_error_text
from foresight.worker.retry import decide_retry

logger = logging.getLogger(__name__)

RECORD_RETRY_S = 5.0  #: [s] longest wait between tries to record a failure on a full disk
PROGRESS_EVERY_S = 0.25  #: [s] at most one progress write per job this often (the last one always lands)


@dataclass
class Held:
    """A job this worker is running, and why it should stop, if it should."""

    job: dict[str, Any]
    deadline: float | None
    timeout_s: float | None = None  #: the job's own limit, else the server's default
    cancel_requested: bool = False
    timed_out: bool = False
    shutdown: bool = False
    lost: bool = False
    last_progress: float = field(default=0.0)
    attempt_dir: Path | None = None  #: the folder this attempt writes into (store.folders.start_attempt)

    def should_stop(self) -> bool:
        if self.deadline is not None and time.time() > self.deadline:
            self.timed_out = True
        return self.cancel_requested or self.timed_out or self.shutdown or self.lost


class JobWorker:
    """Claims and runs jobs in ``concurrency`` slot threads (:meth:`run`).

    A child worker (:meth:`child_worker`, made for a parent job's :class:`~worker.children.ChildRunner`) never
    polls the queue: it runs the children its parent claimed (:meth:`run_job`) under its own lease owner, with
    the parent's worker count, their progress forwarded and the parent's stop passed on by :meth:`beat`.
    """

    def __init__(
        self,
        settings: Settings,
        engine: Engine,
        *,
        concurrency: int = 1,
        kinds: list[str] | None = None,
        worker_id: str | None = None,
        stage_workers: int | None = None,
        on_progress: ChildProgress | None = None,
        parent_stop: Callable[[], str | None] | None = None,
    ):
        self.settings = settings
        self.engine = engine
        self.concurrency = concurrency
        self.kinds = kinds or sorted(KINDS)
        unknown = set(self.kinds) - set(KINDS)
        if unknown:
            raise CoreError(f"unknown job kinds {sorted(unknown)}; known: {sorted(KINDS)}")
        self.id = worker_id or f"{socket.gethostname()}-{os.getpid()}-{uuid.uuid4().hex[:6]}"
        #: processes a stage may use: the parent's own request wins over FORESIGHT_STAGE_WORKERS
        self.stage_workers = stage_workers or settings.stage_workers
        self.on_progress = on_progress
        self.parent_stop = parent_stop
        self.resolver = Resolver(settings, engine)
        #: where finished runs are copied (FORESIGHT_MLFLOW_TRACKING_URI); None: nowhere
        self.mlflow = mlflow_export.settings_target(settings)
        self._held: dict[str, Held] = {}
        self._lock = threading.Lock()
        self._stopping = threading.Event()
        self._beat_stop = threading.Event()
        self._stop_requests = 0
        self.completed = 0  #: jobs this worker ended (any final status)

    # ------------------------------------------------------------------ life cycle
    def run(self) -> None:
        """Run until :meth:`stop`; returns once every slot has ended."""
        queue.register_worker(
            self.engine, self.id, socket.gethostname(), os.getpid(), self.concurrency, self.kinds
        )
        logger.info("worker started", extra={"action": "start_worker", "worker": self.id})
        beat = threading.Thread(target=self._heartbeat_loop, name="heartbeat", daemon=True)
        beat.start()
        slots = [
            threading.Thread(target=self._slot_loop, name=f"slot-{i}", daemon=True)
            for i in range(self.concurrency)
        ]
        for t in slots:
            t.start()
        self._stopping.wait()
        deadline = time.time() + self.settings.shutdown_grace_s
        while any(t.is_alive() for t in slots) and time.time() < deadline and self._stop_requests < 2:
            time.sleep(0.05)
        with self._lock:
            for held in self._held.values():
                held.shutdown = True
        for t in slots:
            t.join(timeout=5.0)
        self._beat_stop.set()
        beat.join(timeout=5.0)
        try:
            queue.stop_worker(self.engine, self.id)
        except Exception:  # noqa: BLE001 - a full disk or a database away: the row goes stale and is pruned
            logger.exception("could not record the worker's stop", extra={"action": "stop_worker_failed"})
        logger.info("worker stopped", extra={"action": "stop_worker", "worker": self.id})

    def stop(self) -> None:
        """Ask the worker to stop (signal-handler safe); a second call releases running jobs at once."""
        self._stop_requests += 1
        self._stopping.set()

    # ------------------------------------------------------------------ loops
    def _slot_loop(self) -> None:
        busy = False
        while not self._stopping.is_set():
            try:
                job = queue.claim(self.engine, self.id, self.kinds, self.settings.lease_s, peek=not busy)
            except Exception:  # the database is briefly unavailable: back off, keep the worker alive
                logger.exception("claim failed", extra={"action": "claim_failed"})
                self._stopping.wait(1.0)
                continue
            busy = job is not None
            if job is None:
                self._stopping.wait(self.settings.poll_s)
                continue
            self.run_job(job)

    def beat(self) -> None:
        """Renew the leases of held jobs; note cancellation requests and lost leases (and, in a child worker,
        pass the parent's cancellation or stop on to its children)."""
        with self._lock:
            held_ids = list(self._held)
        if not held_ids and self.parent_stop is not None:
            return
        cancel, lost = queue.heartbeat(self.engine, self.id, held_ids, self.settings.lease_s)
        stop = self.parent_stop() if self.parent_stop is not None else None
        with self._lock:
            for job_id in held_ids:
                held = self._held.get(job_id)
                if held is None:
                    continue
                held.cancel_requested = held.cancel_requested or job_id in cancel or stop == "cancel"
                held.lost = held.lost or job_id in lost
                held.shutdown = held.shutdown or stop == "stop"
        if stop == "cancel":
            for job_id in held_ids:
                with contextlib.suppress(queue.Conflict):
                    queue.request_cancel(self.engine, job_id)

    def child_worker(
        self,
        owner: str,
        workers: int | None,
        on_progress: ChildProgress,
        parent_stop: Callable[[], str | None],
    ) -> JobWorker:
        """A one-slot worker that runs a parent's children (lease owner ``owner``) through this code path."""
        return JobWorker(
            self.settings,
            self.engine,
            worker_id=owner,
            stage_workers=workers or self.stage_workers,
            on_progress=on_progress,
            parent_stop=parent_stop,
        )

    def _heartbeat_loop(self) -> None:
        reap_every = max(self.settings.heartbeat_s, self.settings.lease_s / 4)
        next_reap = 0.0
        while not self._beat_stop.wait(self.settings.heartbeat_s):
            try:
                self.beat()
                if time.time() >= next_reap:
                    reaped = queue.reap_stale(self.engine)
                    if any(reaped.values()):
                        logger.warning("reaped jobs of dead workers: %s", reaped, extra={"action": "reap"})
                    next_reap = time.time() + reap_every
            except Exception:
                logger.exception("heartbeat failed", extra={"action": "heartbeat_failed"})

    # ------------------------------------------------------------------ one job
    def run_job(self, job: dict[str, Any]) -> None:
        """Run a job this worker claimed, to its end (succeeded, failed, retried, cancelled or released)."""
        timeout = job["timeout_s"] or self.settings.job_timeout_s
        held = Held(job, deadline=time.time() + timeout, timeout_s=timeout)
        with self._lock:
            self._held[job["id"]] = held
        try:
            self._execute(held)
        except queue.LeaseLost as exc:
            logger.warning("%s", exc, extra={"action": "lease_lost", "job": job["id"]})
            if held.attempt_dir is not None:  # another attempt owns the job now: this one's files are garbage
                folders.drop_attempt(held.attempt_dir)
        except (
            Exception
        ) as exc:  # recording the outcome failed (database down): the lease expires, the job is reaped
            logger.exception(
                "could not record the outcome of job %s", job["id"], extra={"action": "record_failed"}
            )
            if folders.is_full_disk(
                exc
            ):  # ... unless the disk is full: the failure is recorded once space returns
                self._fail_when_space_returns(held, exc)
        finally:
            with self._lock:
                self._held.pop(job["id"], None)
            self.completed += 1

    def _fail_when_space_returns(self, held: Held, exc: BaseException) -> None:
        """Free the job's files, then try to record its failure every few seconds until the database can write
        again (the lease is renewed meanwhile whenever a heartbeat gets through), this worker stops, or the lease
        is found lost."""
        job = held.job
        if held.attempt_dir is not None:
            folders.drop_attempt(held.attempt_dir)
        shutil.rmtree(
            folders.resolve_under(
                self.settings.store_root, folders.job_dir(self.settings.store_root, job["id"])
            ),
            ignore_errors=True,
        )
        message = (
            f"the disk of the store or the database was full when the job ended, so its outcome could not be "
            f"recorded ({self.public_text(str(exc)).splitlines()[0][:300]}); retry it once space is freed"
        )
        wait = 0.5
        while not held.lost and not self._stopping.wait(wait):
            try:
                queue.fail_or_retry(
                    self.engine, job["id"], self.id, job["attempts"], "StoreFull", message, retry=False
                )
                logger.warning("recorded the failure of job %s now that space returned", job["id"])
                return
            except queue.LeaseLost:
                return
            except Exception as again:  # noqa: BLE001 - still full, or the database is away: try again
                if not folders.is_full_disk(again):
                    logger.warning("job %s: %r while recording its failure", job["id"], again)
            wait = min(2 * wait, RECORD_RETRY_S)

    def _execute(self, held: Held) -> None:
        job = held.job
        args = (self.engine, job["id"], self.id, job["attempts"])
        kind = KINDS[job["kind"]]
        root = self.settings.store_root
        workdir_rel = folders.job_dir(root, job["id"])
        try:
            spec = kind.spec.model_validate(job["spec"])
            # this attempt's own folder, seeded from the previous attempt's (fencing: store.folders)
            workdir = held.attempt_dir = folders.start_attempt(root, job["id"], create=kind.make_workdir)
            ctx = self.stage_context(held, workdir)
            check_budget(work_size(spec, ctx), self.settings.max_job_steps)  # children never passed the API
            result = kind.execute(spec, ctx)
            if kind.make_workdir:  # the report page is a by-product: written before the scan lists artifacts
                # imported here: matplotlib loads on the first finished stage, not at worker start
                from foresight.core.reports.stage import write_report

                write_report(job["kind"], result, workdir, ctx.log)
                # before the job is finished, so a succeeded job's MLflow run exists; an outage is a log line
                mlflow_export.export_run(
                    self.mlflow,
                    job["kind"],
                    result,
                    workdir,
                    ctx.log,
                    job_id=job["id"],
                    parent_id=job.get("parent_id"),
                )
        except Cancelled:
            if held.lost:
                raise queue.LeaseLost(f"job {job['id']}: lease lost while running") from None
            if held.cancel_requested:
                queue.mark_cancelled(*args)
            elif held.timed_out:
                queue.fail_or_retry(
                    *args, "Timeout", f"the job ran longer than {held.timeout_s:g} s", retry=False
                )
            else:
                queue.release(*args)
            return
        except Exception as exc:
            logger.info("job %s failed: %r", job["id"], exc, extra={"action": "job_failed", "job": job["id"]})
            message, retry = self.public_text(str(exc)), decide_retry(exc)
            if isinstance(
                exc, MemoryError
            ):  # over the worker's limit (worker.memory): the same again fails again
                message, retry = memory_error_text(exc), False
            if folders.is_full_disk(exc):  # the partial files are useless and hold the space others need
                if held.attempt_dir is not None:
                    folders.drop_attempt(held.attempt_dir)
                message, retry = (
                    f"{message} (the store is full; this attempt's partial files were removed)",
                    False,
                )
            queue.fail_or_retry(*args, type(exc).__name__, message, retry=retry)
            return
        artifacts = folders.scan(root, workdir_rel, source=workdir)
        record = None
        if job["kind"] in records.RECORDERS:
            record = functools.partial(
                records.RECORDERS[job["kind"]], job=job, result=result, job_dir=workdir_rel
            )
        publish = functools.partial(folders.publish, root, job["id"], workdir)
        queue.finish(*args, result, artifacts, record, publish)
        folders.drop_attempts(root, job["id"])
        if not artifacts:
            folders.remove_empty(folders.resolve_under(root, workdir_rel))

    def public_text(self, text: str) -> str:
        """``text`` with server paths made relative to the store, the project's configs or the repository
        (job errors are readable without a token)."""
        s = self.settings
        for root in sorted(
            {s.store_root, s.project_configs.resolve(), REPO_ROOT}, key=lambda p: -len(str(p))
        ):
            text = text.replace(f"{root}/", "")
        return text

    def stage_context(self, held: Held, workdir: Path) -> StageContext:
        """The context a held job's stage runs in: its folder, progress, log, cancellation, inputs by id,
        and its child jobs (``ctx.children``)."""
        job = held.job

        def progress(fraction: float, message: str) -> None:
            now = time.time()
            if self.on_progress is not None:
                self.on_progress(job["id"], fraction, message)
            if fraction < 1.0 and now - held.last_progress < PROGRESS_EVERY_S:
                return
            held.last_progress = now
            queue.report_progress(
                self.engine, job["id"], self.id, job["attempts"], float(fraction), message[:2000]
            )

        ctx = StageContext(
            workdir=workdir,
            progress=progress,
            log=lambda message: queue.log(self.engine, job["id"], message[:2000]),
            is_cancelled=held.should_stop,
            resolve_dataset=self.resolver.dataset,
            resolve_model=self.resolver.model,
            resolve_bundle=self.resolver.bundle,
            resolve_data_root=self.settings.data_root,
            resolve_run=self.resolver.run,
            local_files=False,  # a spec names inputs by id only
            workers=self.stage_workers,
            job_id=job["id"],
        )
        ctx.children = functools.partial(ChildRunner, self, ctx)
        return ctx
