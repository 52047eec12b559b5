"""Navigation table: success (collisions) per family for every planner, from evaluation results.

Either runs the evaluations (``--matrix M --seeds-per-scenario N``: the predictive planner with
constant-velocity forecasts and with the default learned model, ORCA, social force, goal-seeking, each
through ``foresight evaluate``'s engine) or reads ``foresight evaluate --json`` outputs given as
``NAME=FILE`` pairs. Prints ONE JSON object (``--json``) or a Markdown table, and flags every family where
a baseline beats the predictive planner (higher success, or equal success with fewer collisions).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
PLANNERS = {  #: column name -> foresight evaluate arguments
    "predictive (cv)": ["--planner", "predictive", "--model", "cv"],
    "predictive (learned)": ["--planner", "predictive"],
    "orca": ["--planner", "orca"],
    "social_force": ["--planner", "social_force"],
    "goal": ["--planner", "goal"],
}
BASELINES = ("orca", "social_force", "goal")


def run(matrix: str, seeds: int, workers: int) -> dict[str, dict]:
    results = {}
    for name, args in PLANNERS.items():
        cmd = [str(REPO / ".venv/bin/foresight"), "evaluate", "--matrix", matrix, *args, "--local", "--json",
               "--seeds-per-scenario", str(seeds), "--workers", str(workers)]
        out = subprocess.run(cmd, capture_output=True, text=True)
        if out.returncode not in (0, 2):  # 2 = the evaluation gate failed: still a result
            sys.exit(f"{name}: {out.stderr.strip()}")
        results[name] = json.loads(out.stdout)
    return results


def table(results: dict[str, dict]) -> dict:
    families: dict[str, dict[str, dict]] = {}
    for planner, res in results.items():
        rows = [*res["aggregates"]["per_family"], {**res["aggregates"]["overall"], "key": "all"}]
        for row in rows:
            r = row["rates"]
            families.setdefault(row["key"], {})[planner] = {
                "episodes": row["episodes"], "success": r["success"]["rate"], "collision": r["collision"]["rate"]}
    ours = [p for p in results if p.startswith("predictive")]
    beaten = []
    for fam, cells in families.items():
        for p in ours:
            for b in (x for x in BASELINES if x in cells):
                s, c = cells[p], cells[b]
                if c["success"] > s["success"] or (c["success"] == s["success"] and c["collision"] < s["collision"]):
                    beaten.append({"family": fam, "planner": p, "baseline": b})
    return {"families": families, "baseline_better": beaten,
            "wall_s": {p: round(r["wall_s"], 1) for p, r in results.items()}}


def markdown(t: dict) -> str:
    planners = list(next(iter(t["families"].values())))
    lines = ["| family | " + " | ".join(planners) + " |", "|---" * (len(planners) + 1) + "|"]
    for fam, cells in t["families"].items():
        vals = [f"{100 * cells[p]['success']:.1f} % ({100 * cells[p]['collision']:.1f} %)" for p in planners]
        lines.append(f"| {fam} (n={cells[planners[0]]['episodes']}) | " + " | ".join(vals) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--matrix", help="run every planner on this matrix")
    ap.add_argument("--seeds-per-scenario", type=int, default=10)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("results", nargs="*", help="NAME=FILE pairs of `foresight evaluate --json` outputs")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    if args.matrix:
        results = run(args.matrix, args.seeds_per_scenario, args.workers)
    else:
        results = {k: json.loads(Path(v).read_text()) for k, v in (a.split("=", 1) for a in args.results)}
    t = table(results)
    print(json.dumps(t, indent=2) if args.json else markdown(t))
    return 0


if __name__ == "__main__":
    sys.exit(main())
