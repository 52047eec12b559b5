"""Scripted plans with the robot's own dynamics: one that reaches the goal proves an episode solvable.

``foresight scenarios reachable`` decides reachability for a relaxed robot, a disc that may step sideways at once:
its "unreachable" is a proof, its "reachable" is not (a 2 m robot turning at 1 rad/s may not have that step). This
is the other side. Every plan of a family runs in the simulator itself, with the scenario's robot and the crowd
reacting to it as to any robot; a plan that arrives without contact is a *witness* that the episode can be solved.
No witness among many plans is evidence, not proof, that no robot could.

The family: the goal driven at directly; drives through one point of each ``--via`` grid in turn (the product of
the grids), then to the goal; and for each ``--hold`` point and ``--release`` time, a drive there, a stand until
that time, then on through one point of each ``--after`` grid in turn to the goal. Each plan is driven by the
``scripted`` planner (``core.planners.scripted``). ``foresight scenarios witness`` searches a family built from each
episode's route instead, for any map; this bench keeps hand-drawn grids for questions about one map. ``--json`` prints ONE object: per scenario the seeds with a witness and, per seed,
the number of witnesses and the earliest arrival's plan. ``--episodes`` takes an evaluation's episodes.jsonl and tries
only the episodes it failed: which of a planner's failures could a robot with its limits have solved?
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import os
import sys
import time
from itertools import product
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from navigation_table import REFERENCE  # noqa: E402

Point = tuple[float, float]
Plan = tuple[
    tuple[Point, ...], tuple[Point, float] | None, tuple[Point, ...]
]  #: (vias, (hold, release) or None, afters)
MAX_EPISODES = (
    1_000_000  #: plans x episodes one run may take (grids multiply: a few minutes per 100,000 here)
)
_JOBS: dict = {}  #: what a forked worker reads: the loaded matrix


def axis(part: str) -> list[float]:
    """Values of ``START:STOP:STEP`` (ends included) or of one number."""
    nums = [float(v) for v in part.split(":")]
    if len(nums) == 1:
        return nums
    if len(nums) != 3 or nums[2] <= 0 or nums[1] < nums[0]:
        raise ValueError(f"{part!r}: expected START:STOP:STEP with STEP > 0 and STOP >= START, or one number")
    return [round(float(v), 6) for v in np.arange(nums[0], nums[1] + nums[2] / 2, nums[2])]


def grid(spec: str) -> list[Point]:
    """Points of ``X0:X1:DX,Y0:Y1:DY`` (either axis may be one number)."""
    parts = spec.split(",")
    if len(parts) != 2:
        raise ValueError(f"{spec!r}: expected X,Y with each a number or START:STOP:STEP")
    return [(x, y) for x in axis(parts[0]) for y in axis(parts[1])]


def plans(args: argparse.Namespace) -> list[Plan]:
    """The family: direct, every via combination, every (hold, release, after combination)."""
    vias = [tuple(c) for c in product(*(grid(g) for g in args.via))] if args.via else []
    afters = [tuple(c) for c in product(*(grid(g) for g in args.after))]  # [()] without --after
    holds = [(p, t) for h in args.hold for p in grid(h) for t in axis(args.release)]
    return [((), None, ()), *((v, None, ()) for v in vias), *(((), h, a) for h in holds for a in afters)]


def _episode(job: tuple[str, int, Plan]) -> tuple[str, int, Plan, str, int]:
    from foresight.core.planners.scripted import Scripted, ScriptedConfig
    from foresight.core.sim.episode import run_episode
    from foresight.core.sim.simulator import Simulator

    scenario, seed, plan = job
    sim = _JOBS.get("sim") or _JOBS.setdefault("sim", Simulator())
    vias, hold, afters = plan
    config = ScriptedConfig(
        via=vias, hold=hold[0] if hold else None, release_s=hold[1] if hold else 0.0, after=afters
    )
    res = run_episode(_JOBS["matrix"].get(scenario), seed, Scripted(config), simulator=sim)
    return scenario, seed, plan, res.outcome, res.steps


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "--matrix", default=str(REFERENCE), help="scenario matrix (default: the reference matrix)"
    )
    ap.add_argument("--scenarios", required=True, help="comma-separated scenario names")
    ap.add_argument(
        "--override", action="append", default=[], metavar="KEY=VALUE", help="as foresight evaluate"
    )
    ap.add_argument("--seeds-per-scenario", type=int, default=10)
    ap.add_argument(
        "--via", action="append", default=[], metavar="X0:X1:DX,Y0:Y1:DY", help="a grid of via points"
    )
    ap.add_argument("--hold", action="append", default=[], metavar="X,Y", help="holding points (grids too)")
    ap.add_argument("--release", default="0:40:2", metavar="T0:T1:DT", help="release times of a hold [s]")
    ap.add_argument(
        "--after", action="append", default=[], metavar="X,Y", help="a grid of points after a hold"
    )
    ap.add_argument(
        "--episodes",
        type=Path,
        metavar="FILE",
        help="an evaluation's episodes.jsonl (evaluate --local --out DIR): only its failed episodes",
    )
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    from foresight.core.errors import CoreError
    from foresight.core.evaluation.runner import expand_seeds, read_outcomes
    from foresight.core.scenarios.loader import load_matrix
    from foresight.local import overrides

    try:
        family = plans(args)
        matrix = load_matrix(args.matrix, overrides=overrides(args.override) or None)
        names = args.scenarios.split(",")
        if missing := [n for n in names if n not in matrix.names]:
            raise ValueError(f"no scenario {missing[0]!r} in {args.matrix}")
        if args.episodes:  # the evaluation's failures among the scenarios asked about
            outcomes = {
                k: o for k, o in read_outcomes(args.episodes).items() if k[0] in names and o != "success"
            }
            seeds = {n: sorted(s for (m, s) in outcomes if m == n) for n in names}
        else:
            outcomes, seeds = (
                {},
                {n: expand_seeds(matrix.get(n).scenario.seeds, args.seeds_per_scenario) for n in names},
            )
        if (size := len(family) * sum(map(len, seeds.values()))) > MAX_EPISODES:
            raise ValueError(
                f"{len(family)} plans x {size // len(family)} episodes = {size} runs, over the "
                f"{MAX_EPISODES} one run may take: coarser grids or fewer seeds"
            )
    except (ValueError, CoreError) as exc:
        sys.exit(f"witness_plans: {exc}")
    _JOBS["matrix"] = matrix
    jobs = [(n, s, p) for n in names for s in seeds[n] for p in family]
    started, found = time.time(), {(n, s): [] for n in names for s in seeds[n]}
    with mp.get_context("fork").Pool(max(1, min(args.workers, len(jobs)))) as pool:
        for scenario, seed, plan, outcome, steps in pool.imap_unordered(_episode, jobs, chunksize=8):
            if outcome == "success":
                found[scenario, seed].append((steps, plan))
    result = {
        "benchmark": "witness_plans",
        "matrix": args.matrix,
        "overrides": args.override,
        "plans": len(family),
        "seconds": round(time.time() - started, 1),
        "scenarios": {},
    }
    for n in names:
        per_seed, dt = [], matrix.get(n).scenario.simulation_config.dt
        for s in seeds[n]:
            wins = sorted(found[n, s], key=lambda w: w[0])
            best = (
                None
                if not wins
                else {
                    "arrival_s": round(wins[0][0] * dt, 1),
                    "via": wins[0][1][0],
                    "hold": wins[0][1][1],
                    "after": wins[0][1][2],
                }
            )
            per_seed.append(
                {
                    "seed": s,
                    "witnesses": len(wins),
                    "best": best,
                    **({"planner_outcome": outcomes[n, s]} if outcomes else {}),
                }
            )
        result["scenarios"][n] = {
            "seeds": len(per_seed),
            "witnessed": sum(p["witnesses"] > 0 for p in per_seed),
            "per_seed": per_seed,
        }
    if args.json:
        print(json.dumps(result))
    else:
        for n, r in result["scenarios"].items():
            what = "of its failed episodes" if args.episodes else "seeds"
            print(f"{n}: {r['witnessed']} / {r['seeds']} {what} with a witness among {len(family)} plans")
    return 0


if __name__ == "__main__":
    sys.exit(main())
