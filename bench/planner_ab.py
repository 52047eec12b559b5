"""Paired A/B of predictive-planner variants on whole suites at once: every (variant, suite, scenario, seed) is one
episode of one process pool, and each variant is compared with the first on the same episodes.

Why one pool: a planner change is judged on every condition the navigation targets name (realistic speed, nobody yields, the
stress suite, the reference defaults), paired, and one pool keeps every core busy across suites and variants (on a
lent GPU machine's 16 cores its prototype ran 936 episodes per variant, four suites of 220-256 episodes, in about 75 s
per variant; ``foresight evaluate`` per suite and variant starts and fills a pool each time).

Suites as in ``bench/navigation_table.py`` (stress, reference_defaults, reference_typical, reference_typical_blind;
``--replication`` for their new seeds); ``--seeds-per-scenario 10`` gives the reference matrix of 230 episodes the targets are measured on.
``--override KEY=VALUE`` applies to every suite (``robot_config.allow_backwards=true``: a robot that may back off).
A variant is ``NAME=JSON``, the predictive planner's config (``{}``: its defaults), with an optional ``"model"`` key of
its own (``cv``, a checkpoint) instead of ``--model`` (default: the shipped learned model): ``--variant learned='{}'
--variant cv='{"model": "cv"}'`` is the targets' learned-vs-constant-velocity comparison on every suite at once.
Episodes are deterministic, so the pairs are exact: the same variant twice reads 0 : 0. Prints ONE JSON object with
``--json``: per suite and variant the outcome counts with Wilson intervals, and per suite each later variant against
the first: successes first-only : variant-only, exact McNemar p (none below ``core.evaluation.stats.MIN_PAIRS``
pairs), collisions first-only : variant-only, and the episodes that ended otherwise (``changed``). ``--out DIR``
keeps every episode's outcome (episodes.jsonl). ``--players DIR`` writes the first 20 changed episodes of each
variant and suite as side-by-side player pages (the first variant's run and the variant's, ``core.render.player``:
open one in a browser) under ``DIR/<suite>/<variant>/``, and lists them in ``players``.

Usage: python bench/planner_ab.py --variant base='{}' --variant back='{"sampling": {"reverse_speed_ratios": [0.25, 0.5]}}'
         [--suites stress,reference_typical_blind] [--seeds-per-scenario 10] [--replication] [--override KEY=VALUE]
         [--scenarios a,b] [--model cv] [--workers 2] [--out DIR] [--players DIR] [--json]
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "bench"))
os.environ.setdefault("OMP_NUM_THREADS", "1")  # one thread per episode process (set before torch loads)

from navigation_table import REPLICATION, SUITES  # noqa: E402

_JOBS: dict = {}  #: what a forked worker reads: matrices by suite, resolved planners by variant


def _episode(job: tuple[str, str, str, int]) -> dict:
    """One episode in a forked worker (its simulator reused across episodes)."""
    from foresight.core.evaluation.episode import run_one
    from foresight.core.sim.simulator import Simulator

    variant, suite, scenario, seed = job
    sim = _JOBS.get("sim") or _JOBS.setdefault("sim", Simulator())  # built once per worker, not per episode
    resolved = _JOBS["matrices"][suite].get(scenario)
    run = run_one(resolved, seed, _JOBS["planners"][variant], simulator=sim)
    if _JOBS.get("traces"):  # --players: every episode's compact trace, until the changed ones are known
        from foresight.core.render.episode_trace import compact_trace, trace_name, write_compact

        write_compact(
            _JOBS["traces"] / variant / suite / trace_name(scenario, seed), compact_trace(run, resolved.map)
        )
    return {
        "variant": variant,
        "suite": suite,
        "scenario": scenario,
        "seed": seed,
        "outcome": run.record.outcome,
    }


def write_players(result: dict, traces: Path, out: Path, variants: list[str]) -> None:
    """Each suite's changed episodes (the first ``SHOWN_CHANGES`` per variant) as side-by-side player pages of the
    first variant's run and the variant's; their paths go into the result's ``players`` entries."""
    from foresight.core.evaluation.compare import SHOWN_CHANGES
    from foresight.core.render.episode_trace import trace_name
    from foresight.core.render.player import write_pair

    first = variants[0]
    for suite, entry in result.items():
        for v, paired in entry["paired"].items():
            paired["players"] = []
            for scenario, seed, a, b in paired["changed"][:SHOWN_CHANGES]:
                name = trace_name(scenario, seed)
                runs = [(first, a, traces / first / suite / name), (v, b, traces / v / suite / name)]
                title = f"{scenario} seed {seed} ({suite}): {first} and {v}"
                paired["players"].append(str(write_pair(out / suite, v, scenario, seed, runs, title)))


def episodes(args: argparse.Namespace, variants: dict[str, dict]) -> tuple[list[tuple], dict, dict]:
    """(jobs, matrices by suite, resolved planners by variant); costliest episodes first."""
    from foresight.core.errors import ConfigError
    from foresight.core.evaluation.plannerspec import resolve_planner
    from foresight.core.evaluation.runner import expand_seeds, expected_cost
    from foresight.core.runtime.context import StageContext
    from foresight.core.scenarios.loader import load_matrix
    from foresight.core.scenarios.seeds import load_seed_manifest
    from foresight.local import overrides

    model_file = REPO / "model" / "predictor-sim-default.pt"
    ctx = StageContext(
        workdir=Path(args.out or "."),
        resolve_model=lambda ident: model_file if ident == "default" else Path(ident),
    )
    planners = {
        name: resolve_planner(
            {
                "name": "predictive",
                "config": {k: v for k, v in cfg.items() if k != "model"},
                "model": cfg.get("model", args.model),
            },
            ctx,
        )
        for name, cfg in variants.items()
    }
    matrices, jobs = {}, []
    wanted = set(args.scenarios.split(",")) if args.scenarios else None
    for suite in args.suites.split(","):
        path, extra = SUITES[suite]
        m = matrices[suite] = load_matrix(path, overrides=overrides([*extra, *args.override]) or None)
        if args.replication:
            pairs = list(load_seed_manifest(REPLICATION[path], m).pairs())
        else:
            pairs = [
                (n, s)
                for n in m.names
                for s in expand_seeds(m.get(n).scenario.seeds, args.seeds_per_scenario)
            ]
        for scenario, seed in pairs:
            if wanted is None or scenario in wanted:
                cost = expected_cost(m, scenario, None)
                jobs += [(-cost, name, suite, scenario, seed) for name in variants]
    if wanted is not None and (missing := wanted - {n for m in matrices.values() for n in m.names}):
        raise ConfigError(
            f"no scenario {sorted(missing)[0]!r} in the suites {args.suites}", item="--scenarios"
        )
    jobs.sort(key=lambda j: j[0])
    return [j[1:] for j in jobs], matrices, planners


def summary(rows: list[dict], variants: list[str]) -> dict:
    """Per suite: each variant's counts and Wilson intervals, and each later variant against the first, paired."""
    from foresight.core.evaluation.stats import MIN_PAIRS, mcnemar_p, wilson_interval

    out: dict = {}
    for suite in dict.fromkeys(r["suite"] for r in rows):
        got = {
            v: {
                (r["scenario"], r["seed"]): r["outcome"]
                for r in rows
                if r["suite"] == suite and r["variant"] == v
            }
            for v in variants
        }
        entry: dict = {"variants": {}, "paired": {}}
        for v, outcomes in got.items():
            n = len(outcomes)
            counts = {
                k: sum(o.startswith(k) for o in outcomes.values())
                for k in ("success", "collision", "timeout")
            }
            entry["variants"][v] = {
                "episodes": n,
                **counts,
                "success_rate": counts["success"] / n if n else None,
                "success_ci95": list(wilson_interval(counts["success"], n)) if n else None,
                "collision_rate": counts["collision"] / n if n else None,
            }
        first = got[variants[0]]
        for v in variants[1:]:
            keys = sorted(set(first) & set(got[v]))
            won = [first[k] == "success" for k in keys], [got[v][k] == "success" for k in keys]
            hit = (
                [first[k].startswith("collision") for k in keys],
                [got[v][k].startswith("collision") for k in keys],
            )
            a_only = sum(a and not b for a, b in zip(*won, strict=True))
            b_only = sum(b and not a for a, b in zip(*won, strict=True))
            entry["paired"][v] = {
                "against": variants[0],
                "pairs": len(keys),
                "first_only": a_only,
                "variant_only": b_only,
                "mcnemar_p": mcnemar_p(a_only, b_only) if len(keys) >= MIN_PAIRS else None,
                "collisions_first_only": sum(a and not b for a, b in zip(*hit, strict=True)),
                "collisions_variant_only": sum(b and not a for a, b in zip(*hit, strict=True)),
                "changed": [[k[0], k[1], first[k], got[v][k]] for k in keys if first[k] != got[v][k]],
            }
        out[suite] = entry
    return out


def parse_variants(items: list[str]) -> dict[str, dict]:
    """``NAME=JSON`` items -> {name: config}; a malformed one exits with one readable line."""
    from foresight.core.render.episode_trace import safe_name

    variants: dict[str, dict] = {}
    for item in items:
        name, sep, raw = item.partition("=")
        try:
            cfg = json.loads(raw) if sep else None
        except json.JSONDecodeError as exc:
            sys.exit(f"--variant {name}: not JSON ({exc})")
        if (
            not name or safe_name(name) != name or not isinstance(cfg, dict) or name in variants
        ):  # a file name
            sys.exit(
                f"--variant {item!r}: expected a new NAME=JSON object (NAME of letters, digits, '.', '_', '-'), "
                "e.g. base='{}'"
            )
        variants[name] = cfg
    return variants


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "--variant", action="append", required=True, help="NAME=JSON planner config (first: the reference)"
    )
    ap.add_argument("--suites", default=",".join(SUITES), help=f"comma-separated, of {', '.join(SUITES)}")
    ap.add_argument(
        "--seeds-per-scenario",
        type=int,
        help="the first N of each scenario's seeds, extended by the next ones where it has fewer "
        "(default: its own)",
    )
    ap.add_argument(
        "--replication", action="store_true", help="the suites' new seeds (as navigation_table.py)"
    )
    ap.add_argument(
        "--override", action="append", default=[], metavar="KEY=VALUE", help="applied to every suite"
    )
    ap.add_argument("--scenarios", help="comma-separated scenario names (default: all)")
    ap.add_argument(
        "--model", default="default", help="default (the shipped learned model), cv, or a checkpoint"
    )
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--out", help="folder for episodes.jsonl")
    ap.add_argument(
        "--players", type=Path, metavar="DIR", help="the changed episodes as side-by-side player pages"
    )
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    variants = parse_variants(args.variant)
    unknown = [s for s in args.suites.split(",") if s not in SUITES]
    if unknown:
        ap.error(f"unknown suite {unknown[0]!r} (known: {', '.join(SUITES)})")
    from foresight.core.errors import ConfigError

    try:
        jobs, matrices, planners = episodes(args, variants)
    except ConfigError as exc:
        sys.exit(f"planner_ab: {exc}")
    if not jobs:
        sys.exit("planner_ab: no episodes selected (check --scenarios)")
    if (
        args.players
    ):  # before the work: a folder that cannot be written is refused now, not after every episode
        try:
            args.players.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            sys.exit(f"planner_ab: --players {args.players}: cannot write there ({exc.strerror})")
    traces = Path(tempfile.mkdtemp(prefix="planner_ab_traces_")) if args.players else None
    _JOBS.update(matrices=matrices, planners=planners, traces=traces)
    started, rows = time.time(), []
    with mp.get_context("fork").Pool(max(1, min(args.workers, len(jobs)))) as pool:
        for i, row in enumerate(pool.imap_unordered(_episode, jobs, chunksize=1), 1):
            rows.append(row)
            if i % 100 == 0 or i == len(jobs):
                print(
                    f"[{time.strftime('%H:%M:%S')}] {i} / {len(jobs)} episodes", file=sys.stderr, flush=True
                )
    if args.out:
        Path(args.out).mkdir(parents=True, exist_ok=True)
        (Path(args.out) / "episodes.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    suites = summary(rows, list(variants))
    if traces is not None:
        try:
            write_players(suites, traces, args.players, list(variants))
        finally:
            shutil.rmtree(traces, ignore_errors=True)
    result = {
        "benchmark": "planner_ab",
        "model": args.model,
        "overrides": args.override,
        "replication": args.replication,
        "seconds": round(time.time() - started, 1),
        "suites": suites,
    }
    if args.json:
        print(json.dumps(result))
        return 0
    for suite, entry in result["suites"].items():
        for v, c in entry["variants"].items():
            print(
                f"{suite:26s} {v:16s} {c['success']:4d} / {c['episodes']} success, {c['collision']} collisions"
            )
        for v, p in entry["paired"].items():
            mark = "n/a" if p["mcnemar_p"] is None else f"{p['mcnemar_p']:.3g}"
            print(
                f"{suite:26s} {p['against']} : {v}  successes {p['first_only']} : {p['variant_only']} (p {mark}), "
                f"collisions {p['collisions_first_only']} : {p['collisions_variant_only']}"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
