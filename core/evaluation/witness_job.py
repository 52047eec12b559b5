"""The witness search as a stage (job kind ``witness``): which episodes a robot with the scenario's limits can solve
(``core.evaluation.witness``), and, given an evaluation, which of its failures were the planner's to win.

The same function serves the API's jobs and ``foresight scenarios witness``: an evaluation is named by its id (its
run folder resolved by whoever runs the job, ``StageContext.resolve_run``; an in-process run may name the folder),
its failed episodes are searched under its own conditions (its matrix and overrides unless the config names its own),
each witness can be priced by the planner riding along (``core.evaluation.witness_cost``; the evaluation's planner,
else the predictive planner with the default model), and played beside the planner's run (``<scenario>__<seed>.html``
in the job's folder).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from foresight.core.errors import ConfigError
from foresight.core.evaluation.config import EpisodeSelection, EvaluationConfig
from foresight.core.evaluation.plannerspec import PlannerSpec, resolve_planner
from foresight.core.evaluation.witness import Witness, WitnessSettings, search, witness_run, write_player
from foresight.core.evaluation.witness_cost import WitnessCost, price_witness
from foresight.core.render.episode_trace import compact_trace, trace_name, write_compact
from foresight.core.runtime.context import StageContext
from foresight.core.runtime.refs import BUILTIN_BUNDLE, BundlePath, Ident
from foresight.core.scenarios.model import ResolvedScenario, ScenarioMatrix

DEFAULT_MATRIX = EpisodeSelection.model_fields["matrix"].default  #: the classic matrix of the builtin bundle

MAX_SEARCHES = 2_000  #: episodes one job may search (each up to ``max_plans`` plans)


class WitnessConfig(EpisodeSelection):
    """Episodes to search (a matrix's, or an evaluation's failures) and how."""

    bundle: Ident | None = None  #: default: the evaluation's, else ``builtin``
    matrix: BundlePath | None = None  #: default: the evaluation's, else the classic matrix
    #: an evaluation id: search only its failed episodes, under its conditions (its matrix and bundle unless
    #: ``matrix`` is given, its overrides unless ``scenario_overrides`` are not empty); an in-process run may name its
    #: folder
    evaluation: str | None = Field(default=None, min_length=1, max_length=500)
    settings: WitnessSettings = WitnessSettings()
    price: bool = False  #: price each witness with the planner riding along (``witness_cost``)
    #: the planner that prices: default the evaluation's, else the predictive planner with the default model
    planner: PlannerSpec | None = None
    players: bool = False  #: each witness beside the planner's run (where the evaluation kept its trace)


class WitnessEpisode(Witness):
    """One episode searched: the witness (or none) and what comes with it."""

    planner_outcome: str | None = None  #: the evaluation's outcome of this episode
    priced: WitnessCost | None = None
    player: str | None = None  #: the player page, relative to the job's folder
    trace: str | None = (
        None  #: the witness's compact trace, relative to the job's folder (the dashboard plays it)
    )


class WitnessResult(BaseModel):
    """The search's answer, episode by episode, in the evaluation's (or the matrix's) order."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    matrix: str
    evaluation: str | None = None
    overrides: dict[str, Any]  #: the conditions the episodes ran under
    settings: WitnessSettings
    failed_only: bool  #: only an evaluation's failed episodes
    searched: int
    witnessed: int
    episodes: list[WitnessEpisode]


@dataclass(frozen=True)
class Search:
    """What a witness config searches: the evaluation (its run folder, config and outcomes) and the episodes."""

    run: Path | None
    evaluation: EvaluationConfig | None
    selection: WitnessConfig  #: the config with the evaluation's matrix, conditions and horizon filled in
    matrix: ScenarioMatrix
    pairs: list[tuple[str, int]]  #: (scenario, seed) in the evaluation's (or the matrix's) order
    outcomes: dict[tuple[str, int], str] | None


def plan_search(config: WitnessConfig, ctx: StageContext) -> Search:
    """The episodes a witness config searches; an unknown evaluation, matrix or scenario, or too many episodes, fail
    here (the API's admission calls it before queueing: 404 / 422)."""
    from foresight.core.evaluation.runner import load_selection, read_outcomes

    run, evaluation = _evaluation(config.evaluation, ctx) if config.evaluation else (None, None)
    fill: dict[str, Any] = {}
    if config.matrix is None:
        fill["matrix"] = evaluation.matrix if evaluation is not None else DEFAULT_MATRIX
        fill["bundle"] = config.bundle or (evaluation.bundle if evaluation is not None else BUILTIN_BUNDLE)
    elif config.bundle is None:
        fill["bundle"] = BUILTIN_BUNDLE
    if evaluation is not None:  # its conditions, where the config names none; its failures whatever the seeds
        fill.update(seeds_per_scenario=None, seed_manifest=None)
        if not config.scenario_overrides:
            fill["scenario_overrides"] = evaluation.scenario_overrides
        if config.max_steps is None:  # a failure within a shorter horizon is judged within it
            fill["max_steps"] = evaluation.max_steps
    sel = config.model_copy(update=fill)
    _, matrix, pairs = load_selection(sel, ctx)
    outcomes = read_outcomes(run / "episodes.jsonl") if run is not None else None
    if outcomes is not None:  # the evaluation's failures, in its order, among the scenarios asked about
        names = {name for name, _ in pairs}
        pairs = [
            (name, seed)
            for (name, seed), outcome in outcomes.items()
            if outcome != "success" and name in names
        ]
    if len(pairs) > MAX_SEARCHES:
        raise ConfigError(
            f"{len(pairs)} episodes to search, over the {MAX_SEARCHES} one job may take: fewer scenarios "
            "or seeds",
            item="scenarios",
        )
    return Search(run, evaluation, sel, matrix, pairs, outcomes)


def run_witness(config: WitnessConfig, ctx: StageContext) -> WitnessResult:
    found = plan_search(config, ctx)
    run, sel, matrix, pairs, outcomes = found.run, found.selection, found.matrix, found.pairs, found.outcomes
    pricer = _pricer(config, found.evaluation, ctx) if config.price else None
    rows: list[WitnessEpisode] = []
    for i, (name, seed) in enumerate(pairs):
        ctx.check_cancelled()
        scenario = _within(matrix.get(name), sel.max_steps)
        w = search(scenario, int(seed), config.settings, workers=ctx.workers, check=ctx.check_cancelled)
        extra: dict[str, Any] = {}
        if outcomes is not None:
            extra["planner_outcome"] = outcomes[name, seed]
        if (
            w.plan is not None
        ):  # its run, once, kept as an evaluation keeps one (the dashboard plays it), priced, played
            witnessed = witness_run(scenario, int(seed), w.plan)
            compact = compact_trace(witnessed, scenario.map)
            extra["trace"] = trace_name(name, seed)
            write_compact(ctx.artifact(extra["trace"]), compact)
            if pricer is not None:
                extra["priced"] = price_witness(scenario, int(seed), w.plan, pricer, run=witnessed)
            if config.players:
                trace = run / trace_name(name, seed) if run is not None else None
                page = write_player(ctx.workdir, scenario, w, trace, extra.get("planner_outcome"), compact)
                extra["player"] = page.relative_to(ctx.workdir).as_posix()
        rows.append(WitnessEpisode(**w.model_dump(), **extra))
        ctx.progress((i + 1) / len(pairs), f"{name} {seed}: {'witness' if w.found else 'none'}")
    return WitnessResult(
        matrix=sel.matrix,
        evaluation=config.evaluation,
        overrides=sel.scenario_overrides,
        settings=config.settings,
        failed_only=outcomes is not None,
        searched=len(rows),
        witnessed=sum(r.found for r in rows),
        episodes=rows,
    )


def _within(scenario: ResolvedScenario, max_steps: int | None) -> ResolvedScenario:
    """The scenario with its horizon cut to ``max_steps`` (an evaluation's smoke horizon), so every plan, its player
    and its price run within it."""
    sim = scenario.scenario.simulation_config
    if max_steps is None or max_steps >= sim.max_episode_steps:
        return scenario
    inner = scenario.scenario.model_copy(
        update={"simulation_config": sim.model_copy(update={"max_episode_steps": max_steps})}
    )
    return scenario.model_copy(update={"scenario": inner})


def _evaluation(ref: str, ctx: StageContext) -> tuple[Path, EvaluationConfig | None]:
    """The run folder of an evaluation (an id; in-process also its folder or its episodes.jsonl) and its config (None
    where the folder keeps no evaluation.json: in-process runs of older folders)."""
    from foresight.core.evaluation.evaluation_result import EvaluationResult

    local = Path(ref) if ctx.local_files and Path(ref).exists() else None
    folder = (local.parent if local.is_file() else local) if local is not None else ctx.resolve_run(ref)
    path = folder / "evaluation.json"
    if not path.is_file():
        if local is None:
            raise ConfigError(f"evaluation {ref!r} keeps no evaluation.json", item="evaluation")
        return folder, None
    try:
        return folder, EvaluationConfig.model_validate(
            EvaluationResult.model_validate_json(path.read_text()).config
        )
    except (ValidationError, ValueError):
        raise ConfigError("expected an evaluation's result with its config", source=path) from None


def _pricer(config: WitnessConfig, evaluation: EvaluationConfig | None, ctx: StageContext) -> Any:
    """The resolved planner that prices the witnesses."""
    spec = config.planner or (
        evaluation.planner if evaluation is not None else PlannerSpec(name="predictive", model="default")
    )
    if spec.name != "predictive":
        raise ConfigError(
            f"a witness is priced by the predictive planner riding along; "
            f"{'the evaluation ran' if config.planner is None else 'got'} {spec.name!r}",
            item="planner",
        )
    return resolve_planner(spec, ctx)
