"""`foresight scenarios witness`: which episodes a robot with the scenario's limits can solve, shown by a plan that does
(``core.evaluation.witness``); with an evaluation's episodes, which of its failures were the planner's to win."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from foresight.cli.common import episode_options
from foresight.core.errors import ConfigError


def add_parser(scen: argparse._SubParsersAction) -> None:
    w = scen.add_parser(
        "witness",
        help="episodes a robot with these limits can solve: a scripted plan along the route "
        "(or a wait at a point of it until a release time) that arrives without "
        "contact, run with the crowd reacting to it",
    )
    episode_options(
        w,
        "only its failed episodes, under its own conditions",
        conditions="; default with --episodes: the evaluation's own, from its evaluation.json",
    )
    w.add_argument(
        "--players",
        metavar="DIR",
        help="each witness as a player page, beside the planner's run where "
        "--episodes' folder kept its trace: DIR/<scenario>__<seed>.html, "
        "and DIR/report.html listing them all",
    )
    w.add_argument(
        "--max-plans",
        type=int,
        help="plans tried at most per episode (default 2000; and at most two minutes an episode)",
    )
    w.add_argument(
        "--min-clearance",
        type=float,
        default=0.0,
        metavar="M",
        help="room [m] a witness keeps from every pedestrian (default 0: any plan without contact)",
    )
    w.add_argument(
        "--price",
        action="store_true",
        help="replay each witness with the planner riding along (the evaluation's, else the predictive "
        "planner with the default model) and say where its own cost would have left the witness's "
        "course, and for which terms",
    )
    w.add_argument("--workers", type=int, default=1, help="processes running plans (default 1)")
    w.add_argument("--json", action="store_true")
    w.set_defaults(func=scenarios_witness)


def scenarios_witness(args: argparse.Namespace) -> int:
    """Builds the ``witness`` job's spec (the API takes the same, naming an evaluation by id) and runs it in-process."""
    from foresight.cli.common import emit
    from foresight.core.jobs.kinds import KINDS
    from foresight.local import ModelArgs, bundle_of, config_of, finish_local, local_context, overrides, spec

    if args.workers < 1:
        raise ConfigError(
            f"expected at least 1 worker, got {args.workers}", source="command line", item="--workers"
        )
    if args.players and not args.episodes:
        raise ConfigError(
            "--players shows the planner's run beside each witness: give its --episodes",
            source="command line",
            item="--players",
        )
    if not 0 <= args.min_clearance <= 2:  # also refuses nan
        raise ConfigError(
            f"expected 0 to 2 m, got {args.min_clearance}", source="command line", item="--min-clearance"
        )
    if args.max_plans is not None and not 1 <= args.max_plans <= 20_000:
        raise ConfigError(
            f"expected 1 to 20000 plans, got {args.max_plans}", source="command line", item="--max-plans"
        )
    if args.episodes and not Path(args.episodes).is_file():
        raise ConfigError("file does not exist", source=args.episodes)
    bundle, (matrix,), roots = bundle_of(args.matrix)
    models = ModelArgs()
    values: dict[str, Any] = {
        "bundle": bundle,
        "matrix": matrix,
        "seeds_per_scenario": args.seeds_per_scenario,
        "price": args.price,
        "scenarios": [n.strip() for n in args.scenarios.split(",")] if args.scenarios else None,
        "settings": {
            "min_clearance": args.min_clearance,
            **({} if args.max_plans is None else {"max_plans": args.max_plans}),
        },
        "evaluation": args.episodes,
        "players": bool(args.players),
    }
    if args.override:
        values["scenario_overrides"] = overrides(args.override)
    if args.price and not args.episodes:
        values["planner"] = {"name": "predictive", "model": models.default()}
    players = Path(args.players) if args.players else None
    ctx = local_context(players, roots, quiet=args.json)
    ctx.resolve_model, ctx.workers = models.resolve, args.workers
    result = KINDS["witness"].run(
        config_of(spec("witness", {k: v for k, v in values.items() if v is not None})), ctx
    )
    report = (
        [p for p in finish_local("witness", result, players) if p.name == "report.html"] if players else []
    )
    emit(result, args.json, lambda r: _text(r, players) + "".join(f"\nreport: {p.resolve()}" for p in report))
    return 0


def _text(r: Any, players: Path | None) -> str:
    what = "failed episodes" if r.failed_only else "episodes"
    keeping = (
        f", keeping {r.settings.min_clearance:g} m from every pedestrian" if r.settings.min_clearance else ""
    )
    lines = [
        f"{r.witnessed} of {r.searched} {what} witnessed solvable by a robot with these limits{keeping}"
        + (f" (conditions: {json.dumps(r.overrides)})" if r.overrides else "")
    ]
    for e in r.episodes:
        outcome = f" ({e.planner_outcome})" if e.planner_outcome else ""
        lines.append(f"  {e.scenario} seed {e.seed}{outcome}: {e.summary()}")
        if e.priced is not None:
            lines.append(f"    priced: {e.priced.summary()}")
        if e.player:
            lines.append(f"    watch: {players / e.player if players else e.player}")
    return "\n".join(lines)
