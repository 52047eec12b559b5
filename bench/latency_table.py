"""Success against command latency: each planner on each suite at every latency, paired with its own latency-0 run.

A command takes effect ``robot_config.command_latency_s`` after it is issued (``core.sim.latency``; the reference
runs with about 1 s of lag). Every (suite, planner, latency) cell is one ``foresight evaluate --local`` run with
``--override robot_config.command_latency_s=L`` (the runner of ``navigation_table.py``; work folders under
``--out``/<suite>@<L>/<planner>, ``--reuse`` takes finished ones). Suites (``--suites``): ``reference`` (the
reference's classic matrix as it is, ``--seeds-per-scenario`` seeds per scenario), ``crowdnavpp_no_rand`` and
``crowdnavpp_rand`` (CrowdNav++'s 20 humans, the first ``--crowdnav-episodes`` test cases; the baselines with the
published rows' parameters). Planners (``--planners``): the predictive planner with constant-velocity forecasts (it
plans from where the commands in flight take the robot) and ORCA (which does not know of the latency), or any of
``navigation_table.py``'s. Each cell: success / collision / timeout with 95 % Wilson intervals; each latency above 0
is paired with the same planner's latency-0 run on the same episodes (successes lost : gained, exact McNemar p, no p
below ``core.evaluation.stats.MIN_PAIRS`` pairs). Prints ONE JSON object (``--json``) or a Markdown table.
"""

from __future__ import annotations

import argparse
import copy
import json
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "bench"))

from navigation_table import PLANNERS, REFERENCE, SLUG, SUITES, cell, records_of, run_one  # noqa: E402

LATENCY_SUITES = {  #: name -> (navigation_table suite whose planner files it takes, matrix, episodes option)
    "reference": ("reference_defaults", REFERENCE, "seeds_per_scenario"),
    "crowdnavpp_no_rand": ("crowdnavpp_no_rand", SUITES["crowdnavpp_no_rand"][0], "crowdnav_episodes"),
    "crowdnavpp_rand": ("crowdnavpp_rand", SUITES["crowdnavpp_rand"][0], "crowdnav_episodes"),
}


def paired(base: list, other: list) -> dict:
    """``other`` against ``base`` on the (scenario, seed) episodes both ran: successes lost and gained, McNemar p."""
    from foresight.core.evaluation.stats import MIN_PAIRS, mcnemar_p

    a = {(r.scenario, r.seed): r.success for r in base}
    b = {(r.scenario, r.seed): r.success for r in other}
    pairs = sorted(set(a) & set(b))
    lost, gained = sum(a[k] and not b[k] for k in pairs), sum(b[k] and not a[k] for k in pairs)
    return {
        "pairs": len(pairs),
        "lost": lost,
        "gained": gained,
        "mcnemar_p": mcnemar_p(lost, gained) if len(pairs) >= MIN_PAIRS else None,
    }


def markdown(result: dict) -> str:
    def pct(x: dict) -> str:
        return f"{100 * x['rate']:.0f} [{100 * x['low']:.0f}–{100 * x['high']:.0f}]"

    lat = result["latencies"]
    lines = [
        "success [95 % CI] / collision, % of episodes; beside latency > 0: successes lost : gained against "
        "latency 0, McNemar p",
        "",
        "| suite | planner | " + " | ".join(f"{x:g} s" for x in lat) + " |",
        "|---|---|" + "---|" * len(lat),
    ]
    for suite, planners in result["table"].items():
        for planner, cells in planners.items():
            vals = []
            for x in lat:
                c = cells[f"{x:g}"]
                v = f"{pct(c['success'])} / {100 * c['collision']['rate']:.0f}"
                if "vs_0" in c:
                    p = c["vs_0"]["mcnemar_p"]
                    v += f" ({c['vs_0']['lost']}:{c['vs_0']['gained']}, p {'n/a' if p is None else f'{p:.2g}'})"
                vals.append(v)
            n = cells[f"{lat[0]:g}"]["episodes"]
            lines.append(f"| {suite} (n={n}) | {planner} | " + " | ".join(vals) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--latencies", default="0,0.1,0.3,1.0", help="comma-separated [s]; the first is the pairing base"
    )
    ap.add_argument(
        "--suites",
        default="reference,crowdnavpp_rand",
        help=f"comma-separated, of {', '.join(LATENCY_SUITES)}",
    )
    ap.add_argument(
        "--planners", default="predictive_cv,orca", help="comma-separated, as navigation_table.py names them"
    )
    ap.add_argument("--seeds-per-scenario", type=int, default=1, help="reference matrix: seeds per scenario")
    ap.add_argument("--crowdnav-episodes", type=int, default=50, help="CrowdNav++: the first N test cases")
    ap.add_argument("--scenarios", help="comma-separated scenario names (default: all)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", default=str(REPO / "out" / "latency"), help="work folders of the evaluations")
    ap.add_argument("--reuse", action="store_true", help="take finished work folders under --out")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    try:
        latencies = [float(x) for x in args.latencies.split(",") if x.strip()]
    except ValueError:
        ap.error(f"--latencies: expected comma-separated seconds, got {args.latencies!r}")
    if not latencies or any(x < 0 for x in latencies):
        ap.error(f"--latencies: expected seconds >= 0, got {args.latencies!r}")
    suites = [s for s in args.suites.split(",") if s]
    for s in suites:
        if s not in LATENCY_SUITES:
            ap.error(f"--suites: unknown suite {s!r}; expected one of {', '.join(LATENCY_SUITES)}")
    by_slug = {SLUG.get(p, p): p for p in PLANNERS}
    for p in args.planners.split(","):
        if p not in by_slug:
            ap.error(f"--planners: unknown planner {p!r}; expected one of {', '.join(by_slug)}")
    planners = [by_slug[p] for p in args.planners.split(",") if p]
    result: dict = {
        "command": ["bench/latency_table.py", *(argv if argv is not None else sys.argv[1:])],
        "latencies": latencies,
        "table": {},
        "runs": {},
    }
    for suite in suites:
        family, matrix, size = LATENCY_SUITES[suite]
        run_args = copy.copy(args)
        run_args.seeds_per_scenario = getattr(args, size)
        for planner in planners:
            cells, base = {}, None
            for lat in latencies:
                out = run_one(
                    family,
                    matrix,
                    [f"robot_config.command_latency_s={lat:g}"],
                    None,
                    planner,
                    _at(run_args, suite, lat),
                )
                records = records_of(out)
                c = cell(records)
                if base is None:
                    base = records
                else:
                    c["vs_0"] = paired(base, records)
                cells[f"{lat:g}"] = c
                summary = json.loads((out / "evaluation.json").read_text())
                result["runs"].setdefault(suite, {}).setdefault(planner, {})[f"{lat:g}"] = {
                    "folder": str(out),
                    "wall_s": round(summary.get("wall_s", 0.0), 1),
                    "code_version": summary.get("code_version"),
                }
            result["table"].setdefault(suite, {})[planner] = cells
    print(json.dumps(result, indent=2) if args.json else markdown(result))
    return 0


def _at(args: argparse.Namespace, suite: str, latency: float) -> argparse.Namespace:
    """Arguments whose ``--out`` names the (suite, latency) cell: run_one adds <family>/<planner>."""
    a = copy.copy(args)
    a.out = str(Path(args.out) / f"{suite}@{latency:g}")
    return a


if __name__ == "__main__":
    sys.exit(main())
