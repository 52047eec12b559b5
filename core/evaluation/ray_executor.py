"""Episodes as Ray tasks: the data plane of evaluate, diagnose and campaign when their ``executor`` is ``ray``.

The job queue stays the control plane (submission, leases, status, results); here every episode is one Ray
task on whatever nodes the cluster has. Why these choices:

- The run's settings, matrix and checkpoint bytes enter the object store once per run (``ray.put``); each worker
  process builds one EpisodeWorker per run and reuses it, so nothing is sent or rebuilt per episode.
- A task is retried when its node or worker process dies (``MAX_RETRIES``), never because it raised: a planner
  error is already a recorded episode outcome, and anything else is a bug that must fail the job.
- Results are gathered by job index and each index is taken once, so a retried task never yields a duplicate;
  records equal the local executor's (an episode depends only on scenario, seed and resolved planner) except
  ``timing``, which also names the node that ran the episode.
- Cancellation and timeouts are polled every ``POLL_S`` while waiting; leaving the wait cancels (force-kills)
  every task not yet finished.

The cluster is ``FORESIGHT_RAY_ADDRESS`` (e.g. ``ray://head:10001`` or ``head:6379``); without it a local Ray
instance with the stage's worker count is started for the process. Ray itself is an optional extra.
"""

from __future__ import annotations

import os
import tempfile
import threading
import uuid
from collections import OrderedDict
from collections.abc import Callable, Iterator
from dataclasses import replace
from pathlib import Path
from typing import Any

from foresight.core import files

RAY_ADDRESS_ENV = "FORESIGHT_RAY_ADDRESS"
MAX_RETRIES = 3  #: attempts after a lost node or worker process
POLL_S = 0.25  #: [s] how often the driver checks for cancellation while episodes run

_connect_lock = threading.Lock()


def connect(cpus: int) -> str:
    """Join the cluster at ``FORESIGHT_RAY_ADDRESS``, or start a local instance with ``cpus`` CPUs, once per
    process; the address in use."""
    import ray

    with _connect_lock:
        if not ray.is_initialized():
            address = os.environ.get(RAY_ADDRESS_ENV) or None
            quiet = {"include_dashboard": False, "log_to_driver": False, "logging_level": "ERROR"}
            if address:
                ray.init(address=address, **quiet)
            else:
                ray.init(address="local", num_cpus=max(1, cpus), **quiet)  # a new instance, never a running one
        return os.environ.get(RAY_ADDRESS_ENV) or "local"


def cluster_cpus() -> int:
    """CPUs the connected cluster offers (recorded with the run)."""
    import ray

    return int(ray.cluster_resources().get("CPU", 0))


# ------------------------------------------------------------------------------ inside a Ray worker process

_WORKERS: OrderedDict[str, Any] = OrderedDict()  #: run token -> EpisodeWorker (a few runs may interleave)


def _checkpoint_file(sha256: str, blob: bytes) -> str:
    """The checkpoint from the object store as a local file (one per content hash and machine)."""
    path = Path(tempfile.gettempdir()) / "foresight-ray-checkpoints" / f"{sha256}.pt"
    if not path.is_file():
        files.write_bytes(path, blob)
    return str(path)


def _episode(token: str, make_worker: Callable[[], Any], checkpoints: dict[str, bytes], job: Any) -> tuple[int, Any]:
    import ray

    from foresight.core.evaluation.episode import EpisodeRun

    os.environ.setdefault("OMP_NUM_THREADS", "1")  # one torch thread: trajectories independent of the executor
    worker = _WORKERS.get(token)
    if worker is None:
        worker = _WORKERS[token] = make_worker()
        while len(_WORKERS) > 4:
            _WORKERS.popitem(last=False)
    planner = job.planner
    if planner.learned:
        planner = replace(planner, model_path=_checkpoint_file(planner.checkpoint_sha256,
                                                               checkpoints[planner.checkpoint_sha256]))
    index, item = worker.run(replace(job, planner=planner))
    node = ray.get_runtime_context().get_node_id()
    record = item.record if isinstance(item, EpisodeRun) else item
    record = record.model_copy(update={"timing": record.timing.model_copy(update={"node": node})})
    return index, (replace(item, record=record) if isinstance(item, EpisodeRun) else record)


# ------------------------------------------------------------------------------ the driver


def run_on_ray(jobs: list[Any], make_worker: Callable[[], Any], ctx: Any) -> Iterator[tuple[int, Any]]:
    """(index, result) of every job as its task finishes; cancels the unfinished tasks when left early.

    ``make_worker`` (picklable, e.g. a partial of the run's EpisodeWorker with its settings and matrix) builds the
    executor of one worker process; it travels through the object store once.
    """
    import ray

    connect(int(ctx.workers or 1))
    task = ray.remote(num_cpus=1, max_retries=MAX_RETRIES, retry_exceptions=False)(_episode)
    paths = {j.planner.checkpoint_sha256: j.planner.model_path for j in jobs if j.planner.learned}
    checkpoints = {sha: Path(path).read_bytes() for sha, path in paths.items()}  # each file read once per run
    refs = [ray.put(make_worker), ray.put(checkpoints)]
    token = uuid.uuid4().hex
    pending = {task.remote(token, *refs, job): job.index for job in jobs}
    try:
        while pending:
            done, _ = ray.wait(list(pending), num_returns=len(pending), timeout=POLL_S, fetch_local=True)
            for ref in done:
                del pending[ref]
                yield ray.get(ref)
            ctx.check_cancelled()
    finally:
        for ref in pending:
            ray.cancel(ref, force=True)
