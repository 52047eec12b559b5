"""Evaluation throughput: the reference classic matrix (23 scenarios x 3 seeds = 69 episodes) at the
scenario horizons, with the predictive planner and 2 worker processes, through ``run_evaluation``.

Target: <= 60 s wall for the 69 episodes (the reference needs 337 s with its predictive planner and
constant-velocity forecasts). Wall time includes starting the worker processes and writing the
artifacts. ``--json`` prints ONE JSON object; the outcome rates are printed too, since a fast but
failing planner is no result. Beside the wall time: the CPU time of this process and its workers (``cpu_s``) and
the load average at the start and the end (``load_1min``): on a machine shared with other work the wall time
alone overstates the cost.

Any other matrix: ``--matrix M`` with its own target (``--target-s``), e.g. a CrowdNav++ suite's 500 episodes in
3 min (``--matrix configs/scenarios/crowdnav/crowdnavpp_rand.yaml --target-s 180``).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from foresight.core.errors import NotFoundError  # noqa: E402
from foresight.core.evaluation.config import EvaluationConfig  # noqa: E402
from foresight.core.evaluation.runner import run_evaluation  # noqa: E402
from foresight.core.runtime.context import StageContext  # noqa: E402

TARGET_S = 60.0


def reference_matrix() -> Path:
    shared = Path(os.environ.get("FORESIGHT_SHARED", REPO.parent / "shared"))
    return shared / "reference" / "robot_sf" / "configs" / "scenarios" / "classic_interactions.yaml"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--matrix", default=str(reference_matrix()))
    ap.add_argument("--planner", default="predictive")
    ap.add_argument("--model", default="cv", help="cv or a checkpoint path (predictive planner)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--scenarios", help="comma-separated scenario names (default: all)")
    ap.add_argument("--seeds-per-scenario", type=int, help="default: the matrix's own seeds (3)")
    ap.add_argument("--max-steps", type=int, help="horizon override (default: the scenario horizons)")
    ap.add_argument("--out", help="work folder (default: a temporary folder)")
    ap.add_argument(
        "--target-s", type=float, default=TARGET_S, help=f"wall-time target [s] (default {TARGET_S:g})"
    )
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)

    matrix = Path(args.matrix).resolve()
    model = args.model if args.planner == "predictive" else None
    checkpoint = Path(args.model).resolve() if model not in (None, "cv") else None

    def resolve_model(ident: str) -> Path:
        if checkpoint is None:
            raise NotFoundError(f"unknown model {ident!r}")
        return checkpoint

    config = EvaluationConfig(
        bundle="local",
        matrix=matrix.name,
        planner={
            "name": args.planner,
            "model": (None if model is None else ("cv" if checkpoint is None else "file:" + checkpoint.name)),
        },
        scenarios=args.scenarios.split(",") if args.scenarios else None,
        seeds_per_scenario=args.seeds_per_scenario,
        max_steps=args.max_steps,
    )
    work = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="foresight-bench-eval-"))
    work.mkdir(parents=True, exist_ok=True)
    ctx = StageContext(
        workdir=work,
        resolve_bundle=lambda _b: matrix.parent,
        resolve_model=resolve_model,
        workers=args.workers,
    )
    load0 = os.getloadavg()[0]
    cpu0 = _cpu_s()
    t0 = time.perf_counter()
    res = run_evaluation(config, ctx)
    wall = time.perf_counter() - t0
    cpu = _cpu_s() - cpu0
    g = res.aggregates.overall
    out = {
        "benchmark": "eval_throughput",
        "matrix": str(matrix),
        "planner": args.planner,
        "model": res.planner.model_id,
        "workers": args.workers,
        "cpu_count": os.cpu_count(),
        "episodes": res.episodes,
        "wall_s": round(wall, 2),
        "episodes_per_s": round(res.episodes / wall, 3),
        "cpu_s": round(cpu, 1),
        "load_1min": [round(load0, 2), round(os.getloadavg()[0], 2)],
        "target_s": args.target_s,
        "within_target": wall <= args.target_s,
        "success_rate": res.success_rate,
        "collision_rate": res.collision_rate,
        "timeout_rate": g.rates["timeout"].rate,
        "plan_ms_mean": g.means["plan_ms_mean"].mean,
        "plan_ms_p95_mean": g.means["plan_ms_p95"].mean,
        "workdir": str(work),
    }
    if args.json:
        print(json.dumps(out, indent=2))
    else:
        for k, v in out.items():
            print(f"{k:>18}: {v}")
    return 0


def _cpu_s() -> float:
    """User + system CPU seconds of this process and its finished children (the worker processes)."""
    own, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


if __name__ == "__main__":
    sys.exit(main())
