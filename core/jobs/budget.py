"""A job's size before it runs: episodes x simulation steps, and pedestrians x steps, checked against a budget.

Sizes count every episode at its full horizon (``max_steps`` or the scenario's ``max_episode_steps``), the
most it can cost, and every episode's crowd (a crowd over the simulator's limits is refused by name; a job's
pedestrian-steps may be :data:`BUDGET_CROWD` times its step budget). The service checks them at submission (422 naming the fields and the budget) and the
worker again before a stage starts (child jobs of pipelines never pass the API).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from foresight.core.errors import ConfigError
from foresight.core.runtime.context import StageContext

DEFAULT_STEP_BUDGET = (
    200_000_000  #: simulation steps of one job (about 6 h of a 16-pedestrian crowd on one core)
)


BUDGET_CROWD = 16  #: pedestrians per step the step budget assumes: pedestrian-steps may be this many times it


@dataclass(frozen=True)
class WorkSize:
    episodes: int
    steps: int  #: simulation steps with every episode at its full horizon
    fields: tuple[str, ...]  #: the spec fields that set the size
    ped_steps: int = 0  #: pedestrians x simulation steps, summed over the episodes


def _steps(matrix: Any, pairs: list[tuple[str, int]], max_steps: int | None) -> int:
    return sum(
        max_steps or matrix.get(name).scenario.simulation_config.max_episode_steps for name, _ in pairs
    )


def _ped_steps(matrix: Any, pairs: list[tuple[str, int]], max_steps: int | None) -> int:
    """Pedestrians x steps of the episodes; ConfigError naming the scenario whose crowd is over the limits."""
    from foresight.core.sim.population import check_crowd

    crowds: dict[str, int] = {}
    total = 0
    for name, _ in pairs:
        scenario = matrix.get(name)
        horizon = max_steps or scenario.scenario.simulation_config.max_episode_steps
        if name not in crowds:
            crowds[name] = check_crowd(scenario, horizon)
        total += crowds[name] * horizon
    return total


def _size(
    matrix: Any, pairs: list[tuple[str, int]], max_steps: int | None, fields: tuple[str, ...], times: int = 1
) -> WorkSize:
    return WorkSize(
        times * len(pairs),
        times * _steps(matrix, pairs, max_steps),
        fields,
        times * _ped_steps(matrix, pairs, max_steps),
    )


def work_size(config: Any, ctx: StageContext, load: Callable[..., Any] | None = None) -> WorkSize | None:
    """The size of a stage config's work (None for stages without episodes), loading its matrix through ``ctx``
    (with ``load``, default ``load_matrix``); an unknown bundle, matrix, scenario or seed manifest fails here as
    it would in the run."""
    from foresight.core.evaluation.campaign import load_variants, suite_union
    from foresight.core.evaluation.config import (
        CampaignConfig,
        DiagnosticsConfig,
        EpisodeSelection,
        EvaluationConfig,
    )
    from foresight.core.evaluation.runner import load_selection
    from foresight.core.jobs.simulate import SimulateConfig
    from foresight.core.training.collect import CollectConfig, episode_list

    selection = ("scenarios", "seeds_per_scenario", "seed_manifest", "max_steps")
    if isinstance(config, EvaluationConfig | DiagnosticsConfig):
        _, matrix, pairs = load_selection(config, ctx, load)
        return _size(matrix, pairs, config.max_steps, selection)
    if isinstance(config, CampaignConfig):
        sel = dict(bundle=config.bundle, matrix=config.matrix, max_steps=config.max_steps)
        _, matrix, hard = load_selection(
            EpisodeSelection(**sel, seed_manifest=config.seed_manifest), ctx, load
        )
        _, _, glob = load_selection(
            EpisodeSelection(**sel, scenarios=config.scenarios, seeds_per_scenario=config.seeds_per_scenario),
            ctx,
            load,
        )
        cells = len(config.checkpoints) * len(load_variants(config, ctx))
        union = suite_union(hard, glob)
        return _size(matrix, union, config.max_steps, ("checkpoints", "variants", "grid", *selection), cells)
    if isinstance(config, CollectConfig | SimulateConfig):
        from foresight.core.runtime.refs import resolve_in_bundle
        from foresight.core.scenarios.loader import load_matrix

        root = ctx.resolve_bundle(config.bundle)
        matrix = (load or load_matrix)(resolve_in_bundle(root, config.matrix))
        if isinstance(config, SimulateConfig):
            pairs = [
                (n, s)
                for n in config.scenarios or matrix.names
                for s in config.seeds or matrix.get(n).scenario.seeds[:1]
            ]
            return _size(matrix, pairs, None, ("scenarios", "seeds"))
        manifest = resolve_in_bundle(root, config.hard_seeds) if config.hard_seeds else None
        pairs = [(s.name, seed) for s, seed, _ in episode_list(config, matrix, manifest)]
        return _size(
            matrix, pairs, config.max_steps, ("scenarios", "seeds_per_scenario", "hard_seeds", "max_steps")
        )
    return None


def check_budget(size: WorkSize | None, budget: int) -> None:
    """ConfigError naming the fields and the budget when ``size`` exceeds ``budget`` simulation steps, or
    :data:`BUDGET_CROWD` x ``budget`` pedestrian-steps."""
    if size is not None and size.steps > budget:
        raise ConfigError(
            f"{size.episodes} episodes of {size.steps} simulation steps (at full horizon) exceed this "
            f"server's budget of {budget} steps per job; lower {', '.join(size.fields)}",
            item=", ".join(size.fields),
        )
    if size is not None and size.ped_steps > BUDGET_CROWD * budget:
        raise ConfigError(
            f"{size.episodes} episodes of {size.ped_steps} pedestrian-steps (crowd x horizon) exceed this "
            f"server's budget of {BUDGET_CROWD * budget} per job; lower {', '.join(size.fields)} or the crowds",
            item=", ".join(size.fields),
        )
