"""`foresight scenarios witness`: which episodes a robot with the scenario's limits can solve, shown by a plan that does
(``core.evaluation.witness``); with an evaluation's episodes, which of its failures were the planner's to win."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from foresight.cli.common import episode_options
from foresight.core.errors import ConfigError

MAX_SEARCHES = 2_000  #: episodes one command may search (each up to ``max_plans`` plans)


def add_parser(scen: argparse._SubParsersAction) -> None:
    w = scen.add_parser("witness", help="episodes a robot with these limits can solve: a scripted plan along the route "
                                        "(or a wait at a point of it until a release time) that arrives without "
                                        "contact, run with the crowd reacting to it")
    episode_options(w, "only its failed episodes, under its own conditions",
                    conditions="; default with --episodes: the evaluation's own, from its evaluation.json")
    w.add_argument("--players", metavar="DIR", help="each witness as a player page, beside the planner's run where "
                                                    "--episodes' folder kept its trace: DIR/<scenario>__<seed>.html")
    w.add_argument("--max-plans", type=int, help="plans tried at most per episode (default 2000; and at most two "
                                                  "minutes an episode)")
    w.add_argument("--min-clearance", type=float, default=0.0, metavar="M",
                   help="room [m] a witness keeps from every pedestrian (default 0: any plan without contact)")
    w.add_argument("--price", action="store_true",
                   help="replay each witness with the planner riding along (the evaluation's, else the predictive "
                        "planner with the default model) and say where its own cost would have left the witness's "
                        "course, and for which terms")
    w.add_argument("--workers", type=int, default=1, help="processes running plans (default 1)")
    w.add_argument("--json", action="store_true")
    w.set_defaults(func=scenarios_witness)


def scenarios_witness(args: argparse.Namespace) -> int:
    from foresight.cli.common import emit, progress_bar
    from foresight.cli.evaluate import overrides
    from foresight.core.evaluation.episode_trace import trace_name
    from foresight.core.evaluation.runner import expand_seeds, read_outcomes
    from foresight.core.evaluation.witness import WitnessSettings, search, write_player
    from foresight.core.scenarios.loader import load_matrix

    if args.workers < 1:
        raise ConfigError(f"expected at least 1 worker, got {args.workers}", source="command line", item="--workers")
    if args.players and not args.episodes:
        raise ConfigError("--players shows the planner's run beside each witness: give its --episodes",
                          source="command line", item="--players")
    if not 0 <= args.min_clearance <= 2:  # also refuses nan
        raise ConfigError(f"expected 0 to 2 m, got {args.min_clearance}", source="command line", item="--min-clearance")
    try:
        settings = WitnessSettings(min_clearance=args.min_clearance,
                                   **({} if args.max_plans is None else {"max_plans": args.max_plans}))
    except ValueError:
        raise ConfigError(f"expected 1 to 20000 plans, got {args.max_plans}", source="command line",
                          item="--max-plans") from None
    conditions = overrides(args.override) if args.override else _evaluation_conditions(args.episodes)
    matrix = load_matrix(Path(args.matrix), overrides=conditions or None)
    chosen = [matrix.get(n.strip()) for n in args.scenarios.split(",")] if args.scenarios else list(matrix.scenarios)
    outcomes = read_outcomes(args.episodes) if args.episodes else None
    if outcomes is None:
        episodes = [(s, seed) for s in chosen for seed in expand_seeds(s.scenario.seeds, args.seeds_per_scenario)]
    else:  # the evaluation's failures, in its order, among the scenarios asked about
        names = {s.name for s in chosen}
        failed = [(name, seed) for (name, seed), outcome in outcomes.items() if outcome != "success"]
        episodes = [(matrix.get(name), seed) for name, seed in failed if name in names or not args.scenarios]
    if len(episodes) > MAX_SEARCHES:
        raise ConfigError(f"{len(episodes)} episodes to search, over the {MAX_SEARCHES} one command may take: fewer "
                          "scenarios or seeds", source="command line", item="--scenarios")
    pricer = _pricing_planner(args.episodes) if args.price else None
    players = Path(args.players) if args.players else None
    traces = Path(args.episodes).parent if args.episodes else None
    rows: list[dict[str, Any]] = []
    with progress_bar(quiet=args.json) as bar:
        task = bar.add_task("witness", total=len(episodes), message="")
        for s, seed in episodes:
            w = search(s, int(seed), settings, workers=args.workers)
            row: dict[str, Any] = {**w.model_dump(mode="json"), "summary": w.summary()}
            if outcomes is not None:
                row["planner_outcome"] = outcomes[s.name, seed]
            if pricer is not None and w.found:
                from foresight.core.evaluation.witness_cost import price_witness

                cost = price_witness(s, int(seed), w.plan, pricer)
                row["priced"] = {**cost.model_dump(mode="json"), "summary": cost.summary()}
            if players is not None and w.found:
                row["player"] = str(write_player(players, s, w, traces / trace_name(s.name, seed), row["planner_outcome"]))
            rows.append(row)
            bar.update(task, advance=1, message=f"{s.name} {seed}")
    report = {"matrix": args.matrix, "overrides": conditions, "settings": settings.model_dump(mode="json"),
              "failed_only": outcomes is not None, "searched": len(rows),
              "witnessed": sum(r["plan"] is not None for r in rows), "episodes": rows}
    emit(report, args.json, _text)
    return 0


def _pricing_planner(episodes: str | None) -> Any:
    """The planner that prices the witnesses: the evaluation's own (its evaluation.json), else the predictive planner
    with the shipped default model."""
    from foresight.cli.evaluate import ModelArgs
    from foresight.core.evaluation.plannerspec import resolve_planner
    from foresight.core.stages.context import StageContext

    models = ModelArgs()
    spec: dict[str, Any] = {"name": "predictive", "model": models.default()}
    if episodes and (Path(episodes).parent / "evaluation.json").is_file():
        spec = _evaluation(episodes)[1].planner.model_dump(mode="json")
    if spec.get("name") != "predictive":
        raise ConfigError(f"--price rides the predictive planner along; the evaluation ran {spec.get('name')!r}",
                          source="command line", item="--price")
    return resolve_planner(spec, StageContext(workdir=Path("."), resolve_model=models.resolve))


def _evaluation(episodes: str) -> tuple[Path, Any]:
    """The evaluation.json beside ``episodes`` and its typed config."""
    from pydantic import ValidationError

    from foresight.core.evaluation.config import EvaluationConfig
    from foresight.core.evaluation.runner import EvaluationResult

    path = Path(episodes).parent / "evaluation.json"
    try:
        return path, EvaluationConfig.model_validate(EvaluationResult.model_validate_json(path.read_text()).config)
    except (ValidationError, ValueError, ConfigError):
        raise ConfigError("expected an evaluation's result with its config", source=path) from None


def _evaluation_conditions(episodes: str | None) -> dict[str, Any]:
    """The scenario overrides an evaluation ran under (its evaluation.json beside episodes.jsonl), {} for none."""
    if not episodes:
        return {}
    if not (Path(episodes).parent / "evaluation.json").is_file():
        return {}
    return _evaluation(episodes)[1].scenario_overrides


def _text(r: dict[str, Any]) -> str:
    what = "failed episodes" if r["failed_only"] else "episodes"
    room = r["settings"]["min_clearance"]
    keeping = f", keeping {room:g} m from every pedestrian" if room else ""
    lines = [f"{r['witnessed']} of {r['searched']} {what} witnessed solvable by a robot with these limits{keeping}"
             + (f" (conditions: {json.dumps(r['overrides'])})" if r["overrides"] else "")]
    for e in r["episodes"]:
        outcome = f" ({e['planner_outcome']})" if "planner_outcome" in e else ""
        lines.append(f"  {e['scenario']} seed {e['seed']}{outcome}: {e['summary']}")
        if "priced" in e:
            lines.append(f"    priced: {e['priced']['summary']}")
        if "player" in e:
            lines.append(f"    watch: {e['player']}")
    return "\n".join(lines)
