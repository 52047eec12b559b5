"""Episodes as Ray tasks: the data plane of evaluate, diagnose, campaign, collect and training's proxy selection
when their ``executor`` is ``ray``.

The job queue stays the control plane (submission, leases, status, results); here every episode is one Ray
task on whatever nodes the cluster has. Why these choices:

- The run's settings, matrix and checkpoint bytes enter the object store once per run (``ray.put``); each worker
  process builds one EpisodeWorker per run and reuses it, so nothing is sent or rebuilt per episode.
- At most ``WINDOW_PER_CPU`` tasks per cluster CPU are in flight (:func:`run_tasks`): a new one is submitted as
  one finishes, and each result is handed on and dropped from the object store when it arrives. So a run of
  10^6 episodes holds a few thousand futures, not 10^6, and the driver's memory does not grow with pending work.
- A task is one episode, or a chunk of up to ``MAX_CHUNK`` once a run has many more episodes than the cluster has
  CPUs (:func:`chunk_size`): Ray's per-task cost in the driver (~2 ms here) would otherwise cap a big cluster of
  short episodes at a few hundred episodes/s.
- A task is retried when its node or worker process dies (``MAX_RETRIES``), never because it raised: a planner
  error is already a recorded episode outcome, and anything else is a bug that must fail the job.
- Results are gathered by job index and each index is taken once, so a retried task never yields a duplicate;
  records equal the local executor's (an episode depends only on scenario, seed and resolved planner) except
  ``timing``, which also names the node that ran the episode.
- Cancellation and timeouts are polled every ``POLL_S`` while waiting; leaving the wait cancels (force-kills)
  every task not yet finished.

The cluster is ``FORESIGHT_RAY_ADDRESS`` (e.g. ``ray://head:10001`` or ``head:6379``); without it a local Ray
instance with the stage's worker count is started for the process (``core.runtime.cluster``). An address
nobody answers at is one ``RayUnreachable`` line naming it. Ray itself is an optional extra.
"""

from __future__ import annotations

import os
import tempfile
import uuid
from collections import OrderedDict
from collections.abc import Callable, Iterable, Iterator
from dataclasses import replace
from pathlib import Path
from typing import Any

from foresight.core import files
from foresight.core.runtime.cluster import cluster_cpus, connect

MAX_RETRIES = 3  #: attempts after a lost node or worker process
POLL_S = 0.25  #: [s] how often the driver checks for cancellation while episodes run
WINDOW_PER_CPU = (
    4  #: tasks in flight per cluster CPU: enough to keep every CPU busy, few enough to stay small
)
CHUNKS_PER_CPU = (
    16  #: a run is cut into chunks of several episodes only when it has more tasks than this per CPU
)
MAX_CHUNK = 16  #: most episodes in one task (bounds the work a lost node's retry repeats)


# ------------------------------------------------------------------------------ inside a Ray worker process

_WORKERS: OrderedDict[str, Any] = OrderedDict()  #: run token -> EpisodeWorker (a few runs may interleave)


def _checkpoint_file(sha256: str, blob: bytes) -> str:
    """The checkpoint from the object store as a local file (one per content hash and machine)."""
    path = Path(tempfile.gettempdir()) / "foresight-ray-checkpoints" / f"{sha256}.pt"
    if not path.is_file():
        files.write_bytes(path, blob)
    return str(path)


def _episodes(
    token: str, make_worker: Callable[[], Any], checkpoints: dict[str, bytes], jobs: list[Any]
) -> list[tuple[int, Any, tuple[str, bytes] | None]]:
    """One task: a chunk of episode jobs, one after another in this worker process."""
    import ray

    from foresight.core.evaluation.episode import EpisodeRun
    from foresight.core.render.episode_trace import write_compact

    os.environ.setdefault(
        "OMP_NUM_THREADS", "1"
    )  # one torch thread: trajectories independent of the executor
    worker = _cached_worker(token, make_worker)
    node = ray.get_runtime_context().get_node_id()
    # a node that sees the job's folder (a shared store, or the driver's own machine) writes its traces itself,
    # in parallel with every other node; elsewhere they travel back and the driver writes them
    root = worker.settings.trace_root
    shared = root is not None and Path(root).is_dir()
    out = []
    for job in jobs:
        planner = job.planner
        if planner.learned:
            planner = replace(
                planner,
                model_path=_checkpoint_file(
                    planner.checkpoint_sha256, checkpoints[planner.checkpoint_sha256]
                ),
            )
        index, item, trace = worker.run_traced(replace(job, planner=planner))
        if shared and trace is not None:
            write_compact(Path(root) / trace[0], trace[1])
            trace = None
        record = item.record if isinstance(item, EpisodeRun) else item
        record = record.model_copy(update={"timing": record.timing.model_copy(update={"node": node})})
        out.append((index, (replace(item, record=record) if isinstance(item, EpisodeRun) else record), trace))
    return out


def chunk_size(episodes: int, cpus: int) -> int:
    """Episodes per task: one while a run is small next to the cluster, more (at most ``MAX_CHUNK``) once there are
    over ``CHUNKS_PER_CPU`` tasks per CPU to go round, so a driver keeps up with many CPUs of short episodes."""
    return max(1, min(MAX_CHUNK, episodes // (CHUNKS_PER_CPU * max(1, cpus))))


def _cached_worker(token: str, make_worker: Callable[..., Any], *args: Any) -> Any:
    """This process's executor of run ``token`` (built on its first task, reused by the run's later ones)."""
    worker = _WORKERS.get(token)
    if worker is None:
        worker = _WORKERS[token] = make_worker(*args)
        while len(_WORKERS) > 4:
            _WORKERS.popitem(last=False)
    return worker


def _worker_task(
    token: str, make_worker: Callable[..., Any], checkpoint: tuple[str, bytes] | None, job: Any
) -> Any:
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    path = None if checkpoint is None else _checkpoint_file(*checkpoint)
    return _cached_worker(token, make_worker, path).run(job)


# ------------------------------------------------------------------------------ the driver


def run_tasks(
    task: Any, shared: tuple[Any, ...], items: Iterable[Any], ctx: Any, window: int | None = None
) -> Iterator[Any]:
    """``task.remote(*shared, item)`` for every item, at most ``window`` (default ``WINDOW_PER_CPU`` x cluster
    CPUs) in flight; each result as its task finishes (any order). Checks ``ctx`` for cancellation every
    ``POLL_S``; leaving early (cancelled, an error, the caller stops) force-cancels the tasks in flight."""
    import ray

    window = max(1, window or WINDOW_PER_CPU * max(1, cluster_cpus()))
    todo = iter(items)
    pending: set[Any] = set()

    def fill() -> None:
        while len(pending) < window:
            item = next(todo, _END)
            if item is _END:
                return
            pending.add(task.remote(*shared, item))

    try:
        fill()
        while pending:
            done, _ = ray.wait(list(pending), num_returns=1, timeout=POLL_S, fetch_local=True)
            if (
                done
            ):  # and every other one finished meanwhile: refill the window without waiting on the slowest
                done, _ = ray.wait(list(pending), num_returns=len(pending), timeout=0, fetch_local=False)
            for ref in done:
                pending.discard(ref)
                yield ray.get(ref)
            fill()
            ctx.check_cancelled()
    finally:
        for ref in pending:
            ray.cancel(ref, force=True)


_END = object()


def run_on_ray(
    jobs: list[Any], make_worker: Callable[[], Any], ctx: Any
) -> Iterator[tuple[int, Any, tuple[str, bytes] | None]]:
    """(index, result, compact trace as (name, bytes) or None) of every episode job as its task finishes; cancels
    the unfinished tasks when left early.

    ``make_worker`` (picklable, e.g. a partial of the run's EpisodeWorker with its settings and matrix) builds the
    executor of one worker process; it travels through the object store once.
    """
    import ray

    connect(int(ctx.workers or 1))
    task = ray.remote(num_cpus=1, max_retries=MAX_RETRIES, retry_exceptions=False)(_episodes)
    paths = {j.planner.checkpoint_sha256: j.planner.model_path for j in jobs if j.planner.learned}
    checkpoints = {sha: Path(path).read_bytes() for sha, path in paths.items()}  # each file read once per run
    shared = (uuid.uuid4().hex, ray.put(make_worker), ray.put(checkpoints))
    size = chunk_size(len(jobs), cluster_cpus())
    for results in run_tasks(task, shared, (jobs[i : i + size] for i in range(0, len(jobs), size)), ctx):
        yield from results


def run_workers_on_ray(
    jobs: list[Any], make_worker: Callable[[str | None], Any], model_path: str | None, ctx: Any
) -> Iterator[Any]:
    """``worker.run(job)`` of every job as its task finishes, ``worker`` = ``make_worker(checkpoint file or
    None)`` built once per Ray worker process and run (e.g. collect's CollectWorker); the checkpoint's bytes travel
    through the object store once per run."""
    import hashlib

    import ray

    connect(int(ctx.workers or 1))
    task = ray.remote(num_cpus=1, max_retries=MAX_RETRIES, retry_exceptions=False)(_worker_task)
    checkpoint = None
    if model_path is not None:
        blob = Path(model_path).read_bytes()
        checkpoint = (hashlib.sha256(blob).hexdigest(), blob)
    shared = (uuid.uuid4().hex, ray.put(make_worker), ray.put(checkpoint))
    yield from run_tasks(task, shared, jobs, ctx)
