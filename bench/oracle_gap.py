"""How much better prediction could help: the predictive planner with the future itself as its forecast.

On a matrix where nobody reacts to the robot (default: the reference classic matrix at typical walking speed with
``peds_have_robot_repulsion: false``, 10 seeds per scenario), each episode is run with the oracle forecaster
(``core.predict.oracle``: every pedestrian's recorded future) and with the learned default model and constant
velocity, same planner, same episodes. The oracle's success is what perfect prediction would reach with this planner;
the gap to it is what a better predictor could still win, and the oracle's own failures are the planner's. Episodes
where someone reacts to the robot are run too but flagged (``approximate``: the recording was made around a standing
robot). ``--json`` prints ONE object: per forecaster success / collision / timeout counts and rates (success with its
Wilson 95 % interval), failures per scenario, and paired counts (oracle-only : other-only successes) with McNemar's exact p.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from functools import cache
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from foresight.core.errors import CoreError  # noqa: E402
from foresight.core.evaluation.runner import expand_seeds  # noqa: E402
from foresight.core.evaluation.stats import mcnemar_p, wilson_interval  # noqa: E402
from foresight.core.scenarios.loader import load_matrix  # noqa: E402

SHARED = Path(os.environ.get("FORESIGHT_SHARED", REPO.parent / "shared"))
REF = SHARED / "reference" / "robot_sf" / "configs" / "scenarios" / "classic_interactions.yaml"
BLIND = {"simulation_config": {"ped_speed_tier": "typical", "peds_have_robot_repulsion": False}}
CHECKPOINT = REPO / "model" / "predictor-sim-default.pt"


@cache
def _matrix(path: str, as_is: bool = False):  # noqa: ANN202
    """The matrix with nobody yielding (or unchanged: ``--as-is``), loaded once per worker process."""
    return load_matrix(Path(path), overrides=None if as_is else BLIND)


@cache
def _learned():  # noqa: ANN202
    """The default model, loaded once per worker process."""
    from foresight.core.predict.nn.checkpoint import load_predictor

    return load_predictor(CHECKPOINT)


def _episode(args: tuple[str, str, int, str, int | None, bool]) -> tuple[str, int, str, str]:
    """(scenario, seed, forecaster, outcome) of one episode (runs in a worker process)."""
    matrix_path, name, seed, which, max_steps, as_is = args
    from foresight.core.planners.predictive.planner import PredictivePlanner
    from foresight.core.planners.registry import make_forecaster
    from foresight.core.predict.oracle import OracleForecaster
    from foresight.core.sim.episode import run_episode

    sc = _matrix(matrix_path, as_is).get(name)
    if which == "oracle":
        forecaster = OracleForecaster.for_episode(sc, seed, max_steps)
    else:
        forecaster = make_forecaster("cv" if which == "cv" else _learned())
    res = run_episode(sc, seed, PredictivePlanner(None, forecaster), max_steps=max_steps)
    return name, seed, which, res.outcome


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--matrix", default=str(REF), help="scenario matrix (run with nobody yielding at typical speed)"
    )
    ap.add_argument("--seeds-per-scenario", type=int, default=10)
    ap.add_argument("--scenarios", default=None, help="comma-separated names (default: all)")
    ap.add_argument(
        "--forecasters",
        default="oracle,learned,cv",
        help="of oracle, learned, cv; the first is the reference",
    )
    ap.add_argument("--max-steps", type=int, default=None, help="horizon override for smoke runs")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument(
        "--as-is",
        action="store_true",
        help="run the matrix's own conditions (every chosen scenario must have nobody reacting to the robot, "
        "e.g. the stress suite's *_nr100 and replay_* scenarios)",
    )
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    from foresight.core.sim.feasibility import peds_react

    try:
        matrix = _matrix(args.matrix, args.as_is)
        chosen = (
            [matrix.get(n.strip()) for n in args.scenarios.split(",")]
            if args.scenarios
            else list(matrix.scenarios)
        )
    except CoreError as exc:
        sys.exit(f"oracle_gap: {exc}")
    reacting = [s.name for s in chosen if peds_react(s)]
    if args.as_is and reacting:
        sys.exit(
            f"oracle_gap: --as-is: scenario {reacting[0]!r} has pedestrians who react to the robot (the oracle's "
            "recorded future would not hold); choose scenarios where nobody does"
        )
    which = [w.strip() for w in args.forecasters.split(",")]
    unknown = [w for w in which if w not in ("oracle", "learned", "cv")]
    if unknown:
        sys.exit(f"--forecasters: unknown {unknown[0]!r}, expected oracle, learned or cv")
    jobs = [
        (args.matrix, s.name, int(seed), w, args.max_steps, args.as_is)
        for s in chosen
        for seed in expand_seeds(s.scenario.seeds, args.seeds_per_scenario)
        for w in which
    ]
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        rows = list(pool.map(_episode, jobs, chunksize=1))
    outcome = {(n, s, w): o for n, s, w, o in rows}
    episodes = sorted({(n, s) for n, s, _, _ in rows})
    out: dict = {
        "benchmark": "oracle_gap",
        "matrix": args.matrix,
        "overrides": None if args.as_is else BLIND,
        "episodes": len(episodes),
        "approximate": bool(reacting),
        "wall_s": round(time.perf_counter() - t0, 1),
        "forecasters": {},
        "paired": {},
    }
    for w in which:
        got = Counter(outcome[e + (w,)] for e in episodes)
        fails = Counter(e[0] for e in episodes if outcome[e + (w,)] != "success")
        out["forecasters"][w] = {
            "success": got["success"],
            "success_rate": got["success"] / len(episodes),
            "success_interval": wilson_interval(got["success"], len(episodes)),
            "collisions": got["collision_pedestrian"] + got["collision_static"],
            "timeouts": got["timeout"],
            "failures_per_scenario": dict(sorted(fails.items())),
        }
    ref = which[0]
    won = {w: {e for e in episodes if outcome[e + (w,)] == "success"} for w in which}
    for w in which[1:]:
        a, b = len(won[ref] - won[w]), len(won[w] - won[ref])
        out["paired"][f"{ref}_vs_{w}"] = {f"{ref}_only": a, f"{w}_only": b, "mcnemar_p": mcnemar_p(a, b)}
    if args.json:
        print(json.dumps(out))
        return
    for w, r in out["forecasters"].items():
        print(
            f"{w:>8}: {r['success']}/{len(episodes)} = {r['success_rate']:.3f}, collisions {r['collisions']}, "
            f"timeouts {r['timeouts']}"
        )
    for k, r in out["paired"].items():
        print(f"{k}: {list(r.values())[:2]}, p = {r['mcnemar_p']:.3g}")


if __name__ == "__main__":
    main()
