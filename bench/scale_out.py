"""Scale-out: episodes/s of the same evaluation with the local process pool and with Ray at 1 and 2 CPUs.

The same (scenario, seed) episodes each time (the reference classic matrix at short horizons by default, the
predictive planner with constant velocity), through ``run_evaluation``; Ray runs on a local instance started for
each setting (its start-up is reported apart and not counted). Ray's per-episode overhead is
(Ray wall - pool wall) / episodes at one CPU, where both run the episodes one after another.
``--json`` prints ONE JSON object.
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
from foresight.core.stages.context import StageContext  # noqa: E402


def timed(config: EvaluationConfig, root: Path, workers: int) -> tuple[float, int]:
    ctx = StageContext(workdir=Path(tempfile.mkdtemp(prefix="foresight-bench-scale-")), resolve_bundle=lambda _: root,
                       workers=workers)
    t0 = time.perf_counter()
    result = run_evaluation(config, ctx)
    return time.perf_counter() - t0, result.episodes


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--matrix", default=str(reference_matrix()))
    ap.add_argument("--max-steps", type=int, default=150, help="horizon cap (short episodes stress the overhead)")
    ap.add_argument("--cpus", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)

    import ray

    matrix = Path(args.matrix).resolve()
    out: dict = {"matrix": str(matrix), "max_steps": args.max_steps, "local": {}, "ray": {}}
    for executor in ("local", "ray"):
        for cpus in args.cpus:
            config = EvaluationConfig(bundle="local", matrix=matrix.name, planner={"name": "predictive", "model": "cv"},
                                      max_steps=args.max_steps, executor=executor, start_method="fork")
            start = 0.0
            if executor == "ray":
                t0 = time.perf_counter()
                ray.init(address="local", num_cpus=cpus, include_dashboard=False, log_to_driver=False,
                         logging_level="ERROR")
                start = time.perf_counter() - t0
            wall, n = timed(config, matrix.parent, cpus)
            if executor == "ray":
                ray.shutdown()
            out[executor][str(cpus)] = {"episodes": n, "wall_s": round(wall, 2), "episodes_per_s": round(n / wall, 2),
                                        **({"ray_start_s": round(start, 2)} if executor == "ray" else {})}
    one = str(args.cpus[0])
    out["ray_overhead_ms_per_episode"] = round(
        1000 * (out["ray"][one]["wall_s"] - out["local"][one]["wall_s"]) / out["ray"][one]["episodes"], 1)
    print(json.dumps(out) if args.json else json.dumps(out, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
