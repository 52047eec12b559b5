"""Stage ``evaluate``: (scenario x seed x planner config) episodes in parallel processes, records, aggregates.

Every episode depends only on (scenario, seed, resolved planner config): each worker builds a fresh
planner per episode and results are put back in job order, so the output is identical whatever the
worker count. Workers are plain ``multiprocessing`` processes (spawn by default: safe with torch).
"""

from __future__ import annotations

import contextlib
import functools
import json
import multiprocessing as mp
import os
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from foresight.core import files
from foresight.core.errors import ConfigError
from foresight.core.evaluation.aggregate import aggregate, summarise
from foresight.core.evaluation.config import EpisodeSelection, EvaluationConfig
from foresight.core.evaluation.episode import EpisodeRun, run_one
from foresight.core.evaluation.evaluation_result import EvaluationResult, planner_provenance
from foresight.core.evaluation.gates import evaluation_gate
from foresight.core.evaluation.integrity import check_integrity
from foresight.core.evaluation.metrics import MetricsConfig
from foresight.core.evaluation.plannerspec import ResolvedPlanner, preflight, resolve_planner
from foresight.core.evaluation.record import EpisodeRecord
from foresight.core.evaluation.taxonomy import TaxonomyConfig
from foresight.core.planners.external import release_planner_processes
from foresight.core.runtime.context import StageContext
from foresight.core.runtime.execution import execution
from foresight.core.runtime.refs import resolve_in_bundle
from foresight.core.scenarios.model import ScenarioMatrix
from foresight.core.version import code_version


@dataclass(frozen=True)
class Job:
    index: int
    scenario: str
    seed: int
    planner: ResolvedPlanner
    trace_dir: str = (
        ""  #: the folder (under ``EpisodeSettings.trace_root``) of its trace: a campaign cell's own
    )


@dataclass(frozen=True)
class EpisodeSettings:
    """Shared by every job of a run (sent once to each worker)."""

    matrix_path: str
    max_steps: int | None
    metrics: MetricsConfig
    taxonomy: TaxonomyConfig
    keep_diagnostics: bool = False  #: return whole EpisodeRuns (trace + per-step planner log), not records
    overrides: dict[str, Any] | None = (
        None  #: the selection's scenario_overrides (applied when a worker loads the matrix)
    )
    trace_root: str | None = (
        None  #: the work directory: each episode's compact trace goes to its ``trace_name``
    )


# ------------------------------------------------------------------------------ episode selection


def expand_seeds(own: tuple[int, ...], n: int | None) -> list[int]:
    """The scenario's own seeds, or the first ``n`` of them extended by max+1, max+2, ... (a superset)."""
    seeds = list(own)
    if n is None:
        return seeds
    nxt = max(seeds, default=-1) + 1
    while len(seeds) < n:
        seeds.append(nxt)
        nxt += 1
    return seeds[:n]


def bundle_file(ctx: StageContext, bundle: str, rel: str) -> Path:
    try:
        return resolve_in_bundle(ctx.resolve_bundle(bundle), rel)
    except ValueError as exc:
        raise ConfigError(str(exc), source=rel) from None


def load_selection(
    sel: EpisodeSelection, ctx: StageContext, load: Callable[..., ScenarioMatrix] | None = None
) -> tuple[Path, ScenarioMatrix, list[tuple[str, int]]]:
    """(matrix path, matrix, [(scenario, seed), ...] in matrix order) of an episode selection; ``load(path,
    overrides=...)`` reads the matrix (default ``load_matrix``; a server may pass a cached one)."""
    from foresight.core.scenarios.loader import load_matrix
    from foresight.core.scenarios.seeds import load_seed_manifest

    path = bundle_file(ctx, sel.bundle, sel.matrix)
    matrix = (load or load_matrix)(path, overrides=sel.scenario_overrides)
    names = matrix.names if sel.scenarios is None else [matrix.get(n).name for n in sel.scenarios]
    if sel.seed_manifest is not None:
        manifest = load_seed_manifest(bundle_file(ctx, sel.bundle, sel.seed_manifest), matrix)
        pairs = [(s, seed) for s, seed in manifest.pairs() if s in names]
    else:
        pairs = [
            (n, seed)
            for n in names
            for seed in expand_seeds(matrix.get(n).scenario.seeds, sel.seeds_per_scenario)
        ]
    if not pairs:
        raise ConfigError("no episodes selected", source=sel.matrix)
    return path, matrix, pairs


# ------------------------------------------------------------------------------ workers


class EpisodeWorker:
    """One run's episode executor: its settings, matrix and (stateful, reused) Simulator.

    Owned by exactly one caller at a time: the in-process path builds one per ``run_jobs`` call (several
    runs may execute at once in one process, e.g. a worker's slot threads), a pool process builds one in
    its initialiser.
    """

    def __init__(
        self,
        settings: EpisodeSettings,
        matrix: ScenarioMatrix | None = None,
        check: Callable[[], None] | None = None,
    ):
        """``check`` (in-process runs only) stops an episode from inside; pool processes are terminated instead."""
        from foresight.core.scenarios.loader import load_matrix
        from foresight.core.sim.simulator import Simulator

        self.settings = settings
        self.matrix = matrix or load_matrix(settings.matrix_path, overrides=settings.overrides)
        self.sim = Simulator()
        self.check = check

    def run(self, job: Job) -> tuple[int, Any]:
        """(index, record or EpisodeRun) of one episode; its compact trace written under ``trace_root``."""
        index, item, trace = self.run_traced(job)
        if trace is not None:
            write_trace(self.settings, trace)
        return index, item

    def run_traced(self, job: Job) -> tuple[int, Any, tuple[str, bytes] | None]:
        """:meth:`run`, with the trace returned as (name, file bytes) rather than written (a Ray node need not
        share the driver's disk: the driver writes it)."""
        s = self.settings
        scenario = self.matrix.get(job.scenario)
        run = run_one(
            scenario,
            job.seed,
            job.planner,
            max_steps=s.max_steps,
            metrics_cfg=s.metrics,
            taxonomy_cfg=s.taxonomy,
            keep_diagnostics=s.keep_diagnostics,
            simulator=self.sim,
            check=self.check,
        )
        trace = None
        if s.trace_root is not None:
            from foresight.core.render.episode_trace import compact_bytes, compact_trace, trace_name

            name = trace_name(job.scenario, job.seed)
            trace = (
                f"{job.trace_dir}/{name}" if job.trace_dir else name,
                compact_bytes(compact_trace(run, scenario.map)),
            )
        return job.index, (run if s.keep_diagnostics else run.record), trace


def write_trace(settings: EpisodeSettings, trace: tuple[str, bytes]) -> None:
    from foresight.core.render.episode_trace import write_compact

    assert settings.trace_root is not None
    write_compact(Path(settings.trace_root) / trace[0], trace[1])


POLL_S = 0.25  #: [s] how often a parent waiting on pool processes checks for cancellation
_POOL_WORKER: EpisodeWorker | None = None  #: a pool process's own executor (each pool process serves one run)


def _init_pool_worker(settings: EpisodeSettings) -> None:
    global _POOL_WORKER
    os.environ.setdefault("OMP_NUM_THREADS", "1")  # one thread per worker process (set before torch loads)
    os.environ.setdefault("MKL_NUM_THREADS", "1")
    _POOL_WORKER = EpisodeWorker(settings)


def _run_pool_job(job: Job) -> tuple[int, Any]:
    assert _POOL_WORKER is not None, "pool process without initialiser"
    return _POOL_WORKER.run(job)


def expected_cost(matrix: ScenarioMatrix, name: str, max_steps: int | None) -> float:
    """Rough episode cost for scheduling: horizon x (1 + crowd density in peds per 100 m^2)."""
    cfg = matrix.get(name).scenario.simulation_config
    return (max_steps or cfg.max_episode_steps) * (1.0 + 100.0 * cfg.ped_density)


def iter_jobs(
    jobs: list[Job],
    settings: EpisodeSettings,
    ctx: StageContext,
    *,
    matrix: ScenarioMatrix | None = None,
    start_method: str = "spawn",
    executor: str = "local",
    longest_first: bool = True,
) -> Iterator[tuple[int, Any]]:
    """(position in ``jobs``, result) of every job as it finishes, in any order (``local``: in-process with one
    worker, else a process pool; ``ray``: one Ray task per episode, core.evaluation.ray_executor). Each result is
    the same for either executor. Close the iterator when leaving early (``contextlib.closing``): that stops the
    pool or cancels the Ray tasks.

    ``longest_first`` (with ``matrix`` and several workers): start the costliest episodes first (less idle tail);
    False keeps the given order. Results are EpisodeRecords, or EpisodeRuns when ``settings.keep_diagnostics``.
    """
    workers = max(1, min(int(ctx.workers or 1), len(jobs)))
    local = [replace(j, index=pos) for pos, j in enumerate(jobs)]
    if longest_first and matrix is not None and workers > 1:
        local.sort(key=lambda j: -expected_cost(matrix, j.scenario, settings.max_steps))
    ctx.check_cancelled()
    if executor == "ray":
        from foresight.core.evaluation.ray_executor import run_on_ray
        from foresight.core.scenarios.loader import load_matrix

        matrix = matrix or load_matrix(settings.matrix_path, overrides=settings.overrides)
        for index, item, trace in run_on_ray(local, functools.partial(EpisodeWorker, settings, matrix), ctx):
            if trace is not None:  # each trace stored here as it arrives
                write_trace(settings, trace)
            yield index, item
        return
    # a learned model runs in worker processes even with one worker: one torch thread each, so the
    # numbers (and hence trajectories) do not depend on the worker count
    if workers == 1 and not any(j.planner.learned for j in jobs):
        worker = EpisodeWorker(settings, matrix, ctx.check_cancelled)
        try:
            for job in local:
                yield worker.run(job)
        finally:
            release_planner_processes()  # this thread's external planner processes (a pool's die with it)
    else:
        pool_ctx = mp.get_context(start_method)
        with pool_ctx.Pool(workers, initializer=_init_pool_worker, initargs=(settings,)) as pool:
            yield from _polled(pool.imap_unordered(_run_pool_job, local, chunksize=1), len(local), ctx)


def run_jobs(
    jobs: list[Job],
    settings: EpisodeSettings,
    ctx: StageContext,
    *,
    matrix: ScenarioMatrix | None = None,
    start_method: str = "spawn",
    on_record: Callable[[int, int, EpisodeRecord], None] | None = None,
    executor: str = "local",
) -> list[Any]:
    """Every job's result (:func:`iter_jobs`) in job order, the same for either executor; ``on_record(done,
    total, record)`` as each arrives."""
    out: list[Any] = [None] * len(jobs)
    with contextlib.closing(
        iter_jobs(jobs, settings, ctx, matrix=matrix, start_method=start_method, executor=executor)
    ) as results:
        for done, (i, item) in enumerate(results, start=1):
            out[i] = item
            if on_record is not None:
                on_record(done, len(jobs), item.record if isinstance(item, EpisodeRun) else item)
            ctx.check_cancelled()
    return [r for r in out if r is not None]


def _polled(results: Any, n: int, ctx: StageContext) -> Iterable[tuple[int, Any]]:
    """The pool's ``n`` results, checking for cancellation every :data:`POLL_S` while an episode runs
    (leaving the pool's ``with`` block on Cancelled terminates its processes mid-episode)."""
    for _ in range(n):
        while True:
            try:
                yield results.next(timeout=POLL_S)
                break
            except mp.TimeoutError:
                ctx.check_cancelled()


# ------------------------------------------------------------------------------ the stage


def seed_source(sel: EpisodeSelection) -> str:
    if sel.seed_manifest:
        return f"manifest {sel.seed_manifest}"
    return f"{sel.seeds_per_scenario} per scenario" if sel.seeds_per_scenario else "matrix"


def write_records(path: Path, records: list[EpisodeRecord]) -> None:
    files.write_text(path, "".join(json.dumps(r.model_dump(mode="json")) + "\n" for r in records))


def read_records(path: Path) -> list[EpisodeRecord]:
    return [
        EpisodeRecord.model_validate_json(line)
        for line in Path(path).read_text().splitlines()
        if line.strip()
    ]


def read_outcomes(path: str | Path) -> dict[tuple[str, int], str]:
    """(scenario, seed) -> outcome of an evaluation's episodes.jsonl, reading only those three keys of each record (so
    records of older or other versions serve too); a bad file is a ConfigError naming it."""
    try:
        lines = Path(path).read_text().splitlines()
        return {(e["scenario"], int(e["seed"])): e["outcome"] for e in map(json.loads, filter(None, lines))}
    except FileNotFoundError:
        raise ConfigError("file does not exist", source=path) from None
    except (json.JSONDecodeError, KeyError, TypeError, ValueError) as exc:
        raise ConfigError(
            f"expected episode records with scenario, seed and outcome: {exc}", source=path
        ) from None


@dataclass(frozen=True)
class PreparedEvaluation:
    """What an evaluation runs: its matrix, the (scenario, seed) episode list in order, the resolved planner."""

    path: Path
    matrix: ScenarioMatrix
    pairs: list[tuple[str, int]]
    planner: ResolvedPlanner
    settings: EpisodeSettings


def prepare_evaluation(config: EvaluationConfig, ctx: StageContext) -> PreparedEvaluation:
    """Select the episodes and resolve the planner (what a run needs before its first episode)."""
    path, matrix, pairs = load_selection(config, ctx)
    rp = resolve_planner(config.planner, ctx)
    preflight(rp, [matrix.get(name) for name in dict.fromkeys(s for s, _ in pairs)])
    settings = EpisodeSettings(
        str(path),
        config.max_steps,
        config.metrics,
        config.taxonomy,
        overrides=config.scenario_overrides,
        trace_root=str(ctx.workdir),
    )
    return PreparedEvaluation(path, matrix, pairs, rp, settings)


def run_evaluation(config: EvaluationConfig, ctx: StageContext) -> EvaluationResult:
    """Evaluate one planner config on a matrix; writes evaluation.json and episodes.jsonl under ctx.workdir.

    Episodes run on ``config.executor`` (a local process pool, or Ray tasks on a cluster), with the same result.
    """
    t0 = time.perf_counter()
    prep = prepare_evaluation(config, ctx)
    jobs = [Job(i, s, seed, prep.planner) for i, (s, seed) in enumerate(prep.pairs)]
    ctx.progress(0.0, f"{len(jobs)} episodes, {prep.planner.label}")

    def progress(done: int, total: int, rec: EpisodeRecord) -> None:
        ctx.progress(done / total, f"{rec.scenario} seed {rec.seed}: {rec.outcome}")

    records = run_jobs(
        jobs,
        prep.settings,
        ctx,
        matrix=prep.matrix,
        start_method=config.start_method,
        executor=config.executor,
        on_record=progress,
    )
    return finish_evaluation(config, records, prep, ctx, t0)


def finish_evaluation(
    config: EvaluationConfig,
    records: list[EpisodeRecord],
    prep: PreparedEvaluation,
    ctx: StageContext,
    t0: float,
) -> EvaluationResult:
    """The result of every episode's records (in episode-list order); writes the evaluation's artifacts."""
    result = evaluation_result(config, records, prep.pairs, prep.planner, ctx, time.perf_counter() - t0)
    write_records(ctx.artifact("episodes.jsonl"), records)
    files.write_text(ctx.artifact("evaluation.json"), json.dumps(result.model_dump(mode="json"), indent=2))
    return result


def evaluation_result(
    config: EvaluationConfig,
    records: list[EpisodeRecord],
    pairs: list[tuple[str, int]],
    rp: ResolvedPlanner,
    ctx: StageContext,
    wall_s: float,
) -> EvaluationResult:
    integrity = check_integrity(records, expected=pairs)
    summary = summarise(records, config.bootstrap)
    gate = evaluation_gate(summary, integrity, config.gate)
    status = "passed" if gate.passed else ("failed_integrity" if not integrity.ok else "failed_gate")
    aggs = aggregate(records, config.bootstrap)
    return EvaluationResult(
        status=status,
        exit_code=gate.exit_code,
        success_rate=summary.success.rate,
        collision_rate=summary.collision.rate,
        episodes=len(records),
        planner=planner_provenance(rp),
        code_version=code_version(),
        bundle=config.bundle,
        matrix=config.matrix,
        seed_source=seed_source(config),
        horizon=str(config.max_steps) if config.max_steps else "scenario",
        workers=int(ctx.workers or 1),
        execution=execution(config.executor, ctx.workers),
        aggregates=aggs,
        taxonomy=aggs.overall.taxonomy,
        taxonomy_config=config.taxonomy,
        metrics_config=config.metrics,
        integrity=integrity,
        gate=gate,
        artifacts={"summary": "evaluation.json", "episodes": "episodes.jsonl"},
        wall_s=wall_s,
        config=config.model_dump(mode="json"),
    )
