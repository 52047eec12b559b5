"""Navigation table: success / collision / timeout with 95 % Wilson intervals per family, for every planner.

Suites (``--suites``, default all four; each runs at its scenarios' own seeds and horizons):

- ``stress``: configs/scenarios/stress.yaml (realistic speeds; 30 % and 100 % of the pedestrians ignore the robot;
  replayed ETH/UCY scenes), grouped by condition and family;
- ``reference_defaults``: the reference's classic matrix (shared/reference/robot_sf) as it is;
- ``reference_typical``: the same with ``ped_speed_tier: typical``;
- ``reference_typical_blind``: the same and ``peds_have_robot_repulsion: false`` (nobody yields to the robot);
- or ``--matrix M [--override KEY=VALUE ...]``: any matrix under any conditions, as suite ``custom``.
- ``crowdnav`` (not in the default): the field's benchmarks in configs/scenarios/crowdnav/ (CrowdNav circle and square
  crossing, CrowdNav++ 20 humans "no rand" and "rand"; docs/crowdnav.md), the baselines with the published rows'
  parameters (configs/planners/crowdnav/), the learned model left out unless ``--planners`` names it (its 0.2 s
  forecast grid does not fit 0.25 s steps); cells add mean navigation time and path length of the successes,
  discomfort frequency and intrusion ratio.

``--replication`` runs each suite on new episodes of the same conditions instead (suite ``<name>_replication``): the
stress suite's synthetic scenarios on configs/seeds/stress_replication.yaml (evaluation seed + 10), the reference
matrix on configs/seeds/reference_replication.yaml (each scenario's seeds 11-20): episodes nobody tuned a planner or
trained a model on, to see whether what a suite shows holds on episodes nobody looked at.

Planners (``--planners``, default all): predictive with the default learned model, predictive with constant-velocity
forecasts, ORCA, social force, goal-seeking. Every (suite, planner) is one ``foresight evaluate --local`` run whose work
folder (``--out``/<suite>/<planner>: evaluation.json, episodes.jsonl) is kept; ``--reuse`` takes a finished folder
instead of re-running it, so a long table can be built in parts. ``--seeds-per-scenario N`` (the first N of each
scenario's seeds, extended by the next ones where it has fewer: the stress suite's replays, one seed each, then run
N times, the robot's start and goal moved by centimetres) and ``--scenarios`` make partial runs cheap. Prints ONE
JSON object (``--json``) or a Markdown table, and lists every group where a baseline beats a predictive planner
(higher success, or equal with fewer collisions).
With both predictive columns, each suite also gets the paired comparison of the learned model against constant
velocity on the same episodes (``learned_vs_cv``: failed episodes of each, how many fewer, the discordant successes
learned-only : cv-only and their exact McNemar p, which the navigation targets ask to be below 0.01; no p below
``core.evaluation.stats.MIN_PAIRS`` pairs).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
SHARED = Path(os.environ.get("FORESIGHT_SHARED", REPO.parent / "shared"))
REFERENCE = SHARED / "reference/robot_sf/configs/scenarios/classic_interactions.yaml"
STRESS = REPO / "configs/scenarios/stress.yaml"
SUITES = {  #: name -> (matrix, --override values)
    "stress": (STRESS, []),
    "reference_defaults": (REFERENCE, []),
    "reference_typical": (REFERENCE, ["ped_speed_tier=typical"]),
    "reference_typical_blind": (REFERENCE, ["ped_speed_tier=typical", "peds_have_robot_repulsion=false"]),
}
CROWDNAV = REPO / "configs/scenarios/crowdnav"
CROWDNAV_SUITES = {  #: the field's benchmarks (docs/crowdnav.md); ``--suites crowdnav`` names all four
    "crowdnav_circle": (CROWDNAV / "circle_crossing.yaml", []),
    "crowdnav_square": (CROWDNAV / "square_crossing.yaml", []),
    "crowdnavpp_no_rand": (CROWDNAV / "crowdnavpp_no_rand.yaml", []),
    "crowdnavpp_rand": (CROWDNAV / "crowdnavpp_rand.yaml", []),
}
DEFAULT_SUITES = list(SUITES)
SUITES.update(CROWDNAV_SUITES)
SUITE_GROUPS = {"crowdnav": list(CROWDNAV_SUITES)}
REPLICATION = {
    STRESS: REPO / "configs/seeds/stress_replication.yaml",  #: matrix -> its replication seeds
    REFERENCE: REPO / "configs/seeds/reference_replication.yaml",
}
PLANNERS = {  #: column name -> foresight evaluate arguments
    "predictive (learned)": ["--planner", "predictive"],
    "predictive (cv)": ["--planner", "predictive", "--model", "cv"],
    "orca": ["--planner", "orca"],
    "social_force": ["--planner", "social_force"],
    "goal": ["--planner", "goal"],
}
#: on the CrowdNav suites the baselines run with the parameters of the published rows (configs/planners/crowdnav)
CROWDNAV_PLANNERS = {
    "orca": {"crowdnav": "orca.yaml", "crowdnavpp": "orca_pp.yaml"},
    "social_force": {"crowdnav": "social_force_pp.yaml", "crowdnavpp": "social_force_pp.yaml"},
}
SLUG = {"predictive (learned)": "predictive_learned", "predictive (cv)": "predictive_cv"}


def planner_args(suite: str, planner: str) -> list[str]:
    """``foresight evaluate`` planner arguments of a (suite, planner) cell."""
    family = suite.split("_")[0]
    if suite in CROWDNAV_SUITES and planner in CROWDNAV_PLANNERS:
        return ["--planner", str(REPO / "configs/planners/crowdnav" / CROWDNAV_PLANNERS[planner][family])]
    return PLANNERS[planner]


BASELINES = ("orca", "social_force", "goal")


def run_one(
    suite: str, matrix: Path, overrides: list[str], seeds: Path | None, planner: str, args: argparse.Namespace
) -> Path:
    """The work folder of one (suite, planner) evaluation, run now unless --reuse finds it finished."""
    out = Path(args.out) / suite / SLUG.get(planner, planner)
    if args.reuse and (out / "evaluation.json").is_file():
        return out
    cmd = [
        str(REPO / ".venv/bin/foresight"),
        "evaluate",
        "--matrix",
        str(matrix),
        *planner_args(suite, planner),
        "--local",
        "--json",
        "--workers",
        str(args.workers),
        "--out",
        str(out),
        "--min-success",
        "0",
    ]
    cmd += [x for o in overrides for x in ("--override", o)]
    if seeds is not None:
        cmd += ["--seeds", str(seeds)]
    elif args.seeds_per_scenario:
        cmd += ["--seeds-per-scenario", str(args.seeds_per_scenario)]
    if args.scenarios:
        cmd += ["--scenarios", args.scenarios]
    print(
        f"[{time.strftime('%H:%M:%S')}] {suite} / {planner}: {' '.join(cmd[1:])}", file=sys.stderr, flush=True
    )
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode not in (0, 2):  # 2 = a failing gate or integrity check: still a result
        sys.exit(f"{suite} / {planner}: {done.stderr.strip()}")
    return out


def groups_of(matrix: Path, overrides: list[str]) -> dict[str, str]:
    """Scenario name -> table group: its family, prefixed by its stress condition where it has one."""
    from foresight.core.scenarios.loader import load_matrix
    from foresight.local import overrides as parse_overrides

    out = {}
    for s in load_matrix(matrix, overrides=parse_overrides(overrides)).scenarios:
        condition = s.scenario.metadata.get("condition")
        out[s.name] = (
            f"{condition} / {s.scenario.archetype}"
            if condition and condition != "replay"
            else s.scenario.archetype
        )
    return out


def cell(records: list) -> dict:
    from foresight.core.evaluation.stats import rate

    n = len(records)
    counts = {
        "success": sum(r.success for r in records),
        "collision": sum(r.collision for r in records),
        "timeout": sum(r.outcome == "timeout" for r in records),
    }
    unsolvable = sum(r.taxonomy.reachable is False for r in records)  # no robot could have reached the goal
    out = {
        "episodes": n,
        **{k: rate(c, n).model_dump(exclude={"n"}) for k, c in counts.items()},
        "unsolvable": unsolvable,
    }
    if n and records[0].safety.discomfort_steps is not None:  # CrowdNav's metrics
        wins = [r for r in records if r.success]
        out["time_s"] = round(sum(r.time_to_goal_s for r in wins) / len(wins), 2) if wins else None
        out["path_m"] = round(sum(r.efficiency.path_length for r in wins) / len(wins), 2) if wins else None
        per = [
            (r.safety.discomfort_steps or 0, r.safety.intrusion_steps or 0, max(r.steps, 1)) for r in records
        ]
        out["discomfort"] = round(sum(d / t for d, _, t in per) / n, 4)  #: mean share of steps per episode
        out["intrusion"] = round(sum(i / t for _, i, t in per) / n, 4)
    return out


def records_of(folder: Path) -> list:
    from foresight.core.evaluation.record import EpisodeRecord

    return [
        EpisodeRecord.model_validate_json(line)
        for line in (folder / "episodes.jsonl").read_text().splitlines()
    ]


def learned_vs_cv(learned: list, cv: list) -> dict:
    """The paired comparison on the (scenario, seed) episodes both ran: failures, how many fewer, McNemar."""
    from foresight.core.evaluation.stats import MIN_PAIRS, mcnemar_p

    a = {(r.scenario, r.seed): r.success for r in learned}
    b = {(r.scenario, r.seed): r.success for r in cv}
    pairs = sorted(set(a) & set(b))
    fail_l, fail_c = sum(not a[k] for k in pairs), sum(not b[k] for k in pairs)
    only_l, only_c = sum(a[k] and not b[k] for k in pairs), sum(b[k] and not a[k] for k in pairs)
    return {
        "pairs": len(pairs),
        "failed_learned": fail_l,
        "failed_cv": fail_c,
        "fewer_failures": round(1 - fail_l / fail_c, 3) if fail_c else None,
        "learned_only": only_l,
        "cv_only": only_c,
        "mcnemar_p": mcnemar_p(only_l, only_c) if len(pairs) >= MIN_PAIRS else None,
    }


def suite_table(folders: dict[str, Path], groups: dict[str, str]) -> dict[str, dict[str, dict]]:
    """{group: {planner: cell}} with per-condition and overall rows after the families."""
    table: dict[str, dict[str, dict]] = {}
    for planner, folder in folders.items():
        records = records_of(folder)
        by: dict[str, list] = {}
        for r in records:
            group = groups[r.scenario]
            by.setdefault(group, []).append(r)
            if " / " in group:
                by.setdefault(f"all {group.split(' / ')[0]}", []).append(r)
            elif group.startswith("replay_"):
                by.setdefault("all replay", []).append(r)
        by["all"] = records
        for group in sorted(by, key=lambda g: (g.startswith("all"), g == "all", g)):
            table.setdefault(group, {})[planner] = cell(by[group])
    return table


def baseline_better(suites: dict[str, dict]) -> list[dict]:
    out = []
    for suite, t in suites.items():
        for group, cells in t["groups"].items():
            for p in (p for p in cells if p.startswith("predictive")):
                for b in (x for x in BASELINES if x in cells):
                    s, c = cells[p], cells[b]
                    if (c["success"]["rate"], -c["collision"]["rate"]) > (
                        s["success"]["rate"],
                        -s["collision"]["rate"],
                    ):
                        out.append({"suite": suite, "group": group, "planner": p, "baseline": b})
    return out


def _crowdnav_cell(c: dict) -> str:
    t = "–" if c["time_s"] is None else f"{c['time_s']:.2f} s"
    path = "–" if c["path_m"] is None else f"{c['path_m']:.2f} m"
    return f" · {t}, {path}, discomfort {100 * c['discomfort']:.1f} %, intrusion {100 * c['intrusion']:.1f} %"


def markdown(result: dict) -> str:
    def pct(x: dict, interval: bool) -> str:
        s = f"{100 * x['rate']:.0f}"
        return s + (f" [{100 * x['low']:.0f}–{100 * x['high']:.0f}]" if interval else "")

    lines = ["success [95 % CI] / collision [95 % CI] / timeout, % of episodes", ""]
    for suite, t in result["suites"].items():
        planners = list(next(iter(t["groups"].values())))
        over = ", ".join(t["overrides"]) or "none"
        lines += [
            f"**{suite}** ({Path(t['matrix']).name}, overrides: {over})",
            "",
            "| group | " + " | ".join(planners) + " |",
            "|---" * (len(planners) + 1) + "|",
        ]
        for group, cells in t["groups"].items():
            vals = [
                f"{pct(c['success'], True)} / {pct(c['collision'], True)} / {pct(c['timeout'], False)}"
                for c in (cells[p] for p in planners)
            ]
            if "intrusion" in cells[planners[0]]:  # CrowdNav's columns: time, path, discomfort, intrusion
                vals = [v + _crowdnav_cell(cells[p]) for v, p in zip(vals, planners, strict=True)]
            name = f"**{group}**" if group.startswith("all") else group
            lines.append(f"| {name} (n={cells[planners[0]]['episodes']}) | " + " | ".join(vals) + " |")
        lines.append("")
        if "learned_vs_cv" in t:
            c = t["learned_vs_cv"]
            p = "n/a" if c["mcnemar_p"] is None else f"{c['mcnemar_p']:.3g}"
            lines += [
                f"learned vs cv, {c['pairs']} paired episodes: {c['failed_learned']} vs {c['failed_cv']} failed, "
                f"learned-only : cv-only successes {c['learned_only']} : {c['cv_only']}, McNemar p = {p}",
                "",
            ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    from foresight.core.evaluation.evaluation_result import EvaluationResult

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--suites",
        default=",".join(DEFAULT_SUITES),
        help=f"comma-separated, of {', '.join([*SUITES, *SUITE_GROUPS])} (crowdnav = its four suites)",
    )
    ap.add_argument("--matrix", help="instead of --suites: this matrix, as suite 'custom'")
    ap.add_argument(
        "--override", action="append", default=[], metavar="KEY=VALUE", help="with --matrix (repeatable)"
    )
    ap.add_argument(
        "--planners",
        default=",".join(SLUG.get(p, p) for p in PLANNERS),
        help="comma-separated, of predictive_learned, predictive_cv, orca, social_force, goal",
    )
    ap.add_argument(
        "--seeds-per-scenario",
        type=int,
        help="the first N seeds of each scenario, extended by the next ones where it has fewer "
        "(default: all its own)",
    )
    ap.add_argument("--scenarios", help="comma-separated scenario names (default: all)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", default=str(REPO / "out" / "navigation"), help="work folders of the evaluations")
    ap.add_argument(
        "--reuse", action="store_true", help="take finished work folders under --out instead of re-running"
    )
    ap.add_argument(
        "--replication",
        action="store_true",
        help="run each suite on its replication seeds (new episodes of the same conditions)",
    )
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    explicit_planners = any(a == "--planners" or a.startswith("--planners=") for a in (argv or sys.argv[1:]))
    args.suites = ",".join(x for s in args.suites.split(",") for x in SUITE_GROUPS.get(s, [s]))
    unknown = [s for s in args.suites.split(",") if s and s not in SUITES]
    if unknown and not args.matrix:
        ap.error(f"unknown suite {unknown[0]!r}; expected one of {', '.join(SUITES)}")
    if args.replication and any(s in CROWDNAV_SUITES for s in args.suites.split(",")):
        ap.error(
            "--replication: the CrowdNav suites have no replication seeds (their 500 are the published test cases)"
        )
    if args.replication and args.matrix:
        ap.error(
            "--replication runs the named suites on their replication seeds; it does not apply to --matrix"
        )
    suites = (
        {"custom": (Path(args.matrix), args.override, None)}
        if args.matrix
        else {
            f"{s}_replication" if args.replication else s: (
                *SUITES[s],
                REPLICATION.get(SUITES[s][0]) if args.replication else None,
            )
            for s in args.suites.split(",")
            if s
        }
    )
    by_slug = {SLUG.get(p, p): p for p in PLANNERS}
    planners = [by_slug[p] for p in args.planners.split(",") if p]
    result: dict = {
        "command": ["bench/navigation_table.py", *(argv if argv is not None else sys.argv[1:])],
        "suites": {},
        "runs": {},
    }
    for suite, (matrix, overrides, seeds) in suites.items():
        # the shipped learned model forecasts on 0.2 s, which 0.25 s steps do not divide: not on CrowdNav by default
        mine = [
            p for p in planners if explicit_planners or suite not in CROWDNAV_SUITES or "learned" not in p
        ]
        folders = {p: run_one(suite, matrix, overrides, seeds, p, args) for p in mine}
        summaries = {
            p: EvaluationResult.model_validate_json((f / "evaluation.json").read_text())
            for p, f in folders.items()
        }
        result["suites"][suite] = {
            "matrix": str(matrix),
            "overrides": overrides,
            "seeds": None if seeds is None else str(seeds),
            "groups": suite_table(folders, groups_of(matrix, overrides)),
        }
        if {"predictive (learned)", "predictive (cv)"} <= set(folders):
            result["suites"][suite]["learned_vs_cv"] = learned_vs_cv(
                records_of(folders["predictive (learned)"]), records_of(folders["predictive (cv)"])
            )
        result["runs"][suite] = {
            p: {
                "folder": str(folders[p]),
                "wall_s": round(s.wall_s, 1),
                "code_version": s.code_version,
                "episodes": s.episodes,
            }
            for p, s in summaries.items()
        }
    result["baseline_better"] = baseline_better(result["suites"])
    print(json.dumps(result, indent=2) if args.json else markdown(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
