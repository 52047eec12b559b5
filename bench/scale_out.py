"""Scale-out: episodes/s of the same evaluation with the local process pool and with Ray at 1 and 2 CPUs.

The same (scenario, seed) episodes each time (the reference classic matrix at short horizons by default, the
predictive planner with constant velocity), through ``run_evaluation``; Ray runs on a local instance started for
each setting (its start-up is reported apart and not counted). Ray's per-episode overhead is
(Ray wall - pool wall) / episodes at one CPU, where both run the episodes one after another.

The parts of a 10^6-episode plan, each measured here (``components``): Ray's scheduling cost per task (``--tasks``
no-op tasks through the executor's windowed submission: tasks/s the driver sustains), the bytes each episode's
result carries back (its record and its compact trace) and the bytes a run ships once (settings + matrix), and the
driver's cost to store one episode (its trace file, its line of episodes.jsonl). ``--json`` prints ONE JSON
object.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from bench.eval_throughput import reference_matrix  # noqa: E402
from foresight.core.evaluation.config import EvaluationConfig  # noqa: E402
from foresight.core.evaluation.runner import run_evaluation  # noqa: E402
from foresight.core.runtime.context import StageContext  # noqa: E402


def timed(config: EvaluationConfig, root: Path, workers: int) -> tuple[float, int]:
    ctx = StageContext(
        workdir=Path(tempfile.mkdtemp(prefix="foresight-bench-scale-")),
        resolve_bundle=lambda _: root,
        workers=workers,
    )
    t0 = time.perf_counter()
    result = run_evaluation(config, ctx)
    return time.perf_counter() - t0, result.episodes


def components(config: EvaluationConfig, root: Path, tasks: int) -> dict:
    """Per-task scheduling, per-episode bytes and per-episode store cost (see the module docstring)."""
    import functools
    import pickle

    import ray

    from foresight.core.evaluation import ray_executor
    from foresight.core.evaluation.runner import (
        EpisodeWorker,
        Job,
        prepare_evaluation,
        write_records,
        write_trace,
    )

    ctx = StageContext(
        workdir=Path(tempfile.mkdtemp(prefix="foresight-bench-parts-")), resolve_bundle=lambda _: root
    )
    prep = prepare_evaluation(config, ctx)
    worker = EpisodeWorker(prep.settings, prep.matrix)
    runs = [worker.run_traced(Job(i, s, seed, prep.planner)) for i, (s, seed) in enumerate(prep.pairs[:12])]
    record_b = [len(pickle.dumps(item)) for _, item, _ in runs]
    trace_b = [len(trace[1]) for _, _, trace in runs if trace is not None]
    shared_b = len(pickle.dumps(functools.partial(EpisodeWorker, prep.settings, prep.matrix)))
    t0 = time.perf_counter()
    for _ in range(20):
        for _, _, trace in runs:
            assert trace is not None
            write_trace(prep.settings, trace)
    trace_ms = 1000 * (time.perf_counter() - t0) / (20 * len(runs))
    t0 = time.perf_counter()
    for _ in range(20):
        write_records(ctx.workdir / "episodes.jsonl", [item for _, item, _ in runs])
    records_ms = 1000 * (time.perf_counter() - t0) / (20 * len(runs))

    # the driver keeps every record until the run's aggregates are computed: memory and aggregation per record
    import tracemalloc

    from foresight.core.evaluation.aggregate import aggregate
    from foresight.core.evaluation.record import EpisodeRecord

    records = [item for _, item, _ in runs]
    tracemalloc.start()
    before = tracemalloc.get_traced_memory()[0]
    copies = [EpisodeRecord.model_validate_json(r.model_dump_json()) for r in records * 50]
    held_b = (tracemalloc.get_traced_memory()[0] - before) / len(copies)
    tracemalloc.stop()
    t0 = time.perf_counter()
    aggregate(copies)
    aggregate_ms = 1000 * (time.perf_counter() - t0) / len(copies)

    ray.init(address="local", num_cpus=2, include_dashboard=False, log_to_driver=False, logging_level="ERROR")
    try:
        task = ray.remote(num_cpus=1)(_noop)
        list(ray_executor.run_tasks(task, (), range(100), ctx))  # warm the worker processes
        t0 = time.perf_counter()
        n = sum(1 for _ in ray_executor.run_tasks(task, (), range(tasks), ctx))
        wall = time.perf_counter() - t0
    finally:
        ray.shutdown()
    return {
        "noop_tasks": n,
        "noop_tasks_per_s": round(n / wall, 1),
        "scheduling_ms_per_task": round(1000 * wall / n, 2),
        "window": ray_executor.WINDOW_PER_CPU * 2,
        "record_bytes_mean": round(sum(record_b) / len(record_b)),
        "trace_bytes_mean": round(sum(trace_b) / max(1, len(trace_b))),
        "run_shared_bytes": shared_b,
        "store_ms_per_episode": round(trace_ms + records_ms, 3),
        "trace_store_ms": round(trace_ms, 3),
        "records_store_ms": round(records_ms, 3),
        "driver_bytes_per_record": round(held_b),
        "aggregate_ms_per_record": round(aggregate_ms, 3),
        "aggregated_records": len(copies),
    }


def _noop(x: int) -> int:
    return x


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--matrix", default=str(reference_matrix()))
    ap.add_argument(
        "--max-steps", type=int, default=150, help="horizon cap (short episodes stress the overhead)"
    )
    ap.add_argument("--scenarios", help="comma-separated scenario names (default: all)")
    ap.add_argument("--cpus", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--tasks", type=int, default=2000, help="no-op tasks timed for Ray's scheduling cost")
    ap.add_argument("--parts-only", action="store_true", help="only the components (no episodes/s runs)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)

    import ray

    matrix = Path(args.matrix).resolve()
    scenarios = args.scenarios.split(",") if args.scenarios else None
    out: dict = {"matrix": str(matrix), "max_steps": args.max_steps, "local": {}, "ray": {}}
    base = EvaluationConfig(
        bundle="local",
        matrix=matrix.name,
        planner={"name": "predictive", "model": "cv"},
        max_steps=args.max_steps,
        scenarios=scenarios,
    )
    out["components"] = components(base, matrix.parent, args.tasks)
    for executor in ("local", "ray") if not args.parts_only else ():
        for cpus in args.cpus:
            config = EvaluationConfig(
                bundle="local",
                matrix=matrix.name,
                planner={"name": "predictive", "model": "cv"},
                max_steps=args.max_steps,
                scenarios=scenarios,
                executor=executor,
                start_method="fork",
            )
            start = 0.0
            if executor == "ray":
                t0 = time.perf_counter()
                ray.init(
                    address="local",
                    num_cpus=cpus,
                    include_dashboard=False,
                    log_to_driver=False,
                    logging_level="ERROR",
                )
                start = time.perf_counter() - t0
            wall, n = timed(config, matrix.parent, cpus)
            if executor == "ray":
                ray.shutdown()
            out[executor][str(cpus)] = {
                "episodes": n,
                "wall_s": round(wall, 2),
                "episodes_per_s": round(n / wall, 2),
                **({"ray_start_s": round(start, 2)} if executor == "ray" else {}),
            }
    one = str(args.cpus[0])
    if not args.parts_only:
        out["ray_overhead_ms_per_episode"] = round(
            1000 * (out["ray"][one]["wall_s"] - out["local"][one]["wall_s"]) / out["ray"][one]["episodes"], 1
        )
    print(json.dumps(out) if args.json else json.dumps(out, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
