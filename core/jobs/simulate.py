"""Stage `simulate`: run episodes of a scenario matrix with a planner (goal-seeking by default), render and summarise.

It is the simulator demo and the smallest end-to-end slice of the service (one spec, one job,
JSON back). Heavier stages (collect, evaluate, campaign) follow the same shape.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator

from foresight.core import files
from foresight.core.bounds import BoundedConfig
from foresight.core.errors import ConfigError
from foresight.core.evaluation.plannerspec import (
    PlannerSpec,
    build_planner,
    planner_spec,
    preflight,
    resolve_planner,
)
from foresight.core.runtime.context import StageContext
from foresight.core.runtime.refs import BUILTIN_BUNDLE, BundlePath, Ident, Name, Seed, resolve_in_bundle
from foresight.core.version import code_version


class SimulateConfig(BoundedConfig):
    """Which episodes to run: scenarios of a matrix (default all) x seeds (default each scenario's first)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    bundle: Ident = BUILTIN_BUNDLE
    matrix: BundlePath = "scenarios/classic_interactions.yaml"
    scenarios: list[Name] | None = Field(default=None, max_length=1000)
    seeds: list[Seed] | None = Field(default=None, max_length=1000)
    #: any planner an evaluation takes (name, config, model); a bare name is short for ``{name: NAME}``
    planner: PlannerSpec = Field(default_factory=lambda: planner_spec(name="goal"))
    render: bool = True
    #: the picture's kind: a still of the whole episode (png, svg) or its replay (gif, mp4: the ``video`` extra)
    render_format: Literal["png", "svg", "gif", "mp4"] = "png"

    @field_validator("planner", mode="before")
    @classmethod
    def _name_only(cls, value: Any) -> Any:
        return {"name": value} if isinstance(value, str) else value


class EpisodeSummary(BaseModel):
    scenario: str
    seed: int
    outcome: str
    steps: int
    pedestrians: int
    min_distance: float | None  #: closest robot-pedestrian centre distance [m]; None without pedestrians
    wall_s: float
    render: str | None = None  #: artifact name of the picture (PNG, SVG, GIF or MP4)
    planner: str = "goal"  #: the planner's name
    model_id: str = "none"  #: its model id, "cv", or "none" (planners without a predictor)


class SimulateResult(BaseModel):
    episodes: list[EpisodeSummary]
    outcomes: dict[str, int]
    code_version: str


def _render(trace: Any, scenario: Any, path: Path, kind: str, seed: int) -> None:
    title = f"{scenario.name} seed {seed}"
    if kind in ("png", "svg"):
        from foresight.core.render.trace import render_trace

        render_trace(trace, scenario.map, path, title=title)
        return
    from foresight.core.render.animation import render_replay

    render_replay(
        trace,
        scenario.map,
        path,
        title=title,
        robot_radius=scenario.scenario.robot_config.radius,
        ped_radius=scenario.scenario.simulation_config.ped_radius,
    )


def run_simulate(config: SimulateConfig, ctx: StageContext) -> SimulateResult:
    from foresight.core.scenarios.loader import load_matrix
    from foresight.core.sim.episode import run_episode

    matrix_path = resolve_in_bundle(ctx.resolve_bundle(config.bundle), config.matrix)
    matrix = load_matrix(matrix_path)
    names = config.scenarios or matrix.names
    jobs = []
    for name in names:
        scenario = matrix.get(name)
        for seed in config.seeds or scenario.scenario.seeds[:1]:
            jobs.append((scenario, seed))
    if not jobs:
        raise ConfigError("no episodes selected", source=config.matrix)
    planner = resolve_planner(config.planner, ctx)  # a bad config or model stops here, before any episode
    preflight(planner, [scenario for scenario, _ in jobs])
    episodes = []
    for i, (scenario, seed) in enumerate(jobs):
        ctx.check_cancelled()
        ctx.progress(i / len(jobs), f"{scenario.name} seed {seed}")
        result = run_episode(scenario, seed, build_planner(planner), check=ctx.check_cancelled)
        render_name = None
        if config.render:
            render_name = f"renders/{scenario.name}--{seed}.{config.render_format}"
            _render(result.trace, scenario, ctx.artifact(render_name), config.render_format, seed)
        episodes.append(
            EpisodeSummary(
                scenario=scenario.name,
                seed=seed,
                outcome=result.outcome,
                steps=result.steps,
                pedestrians=int(result.trace.ped_ids.shape[1]),
                min_distance=result.min_distance,
                wall_s=result.wall_s,
                render=render_name,
                planner=planner.name,
                model_id=planner.model_id,
            )
        )
    ctx.progress(1.0, "done")
    outcomes: dict[str, int] = {}
    for e in episodes:
        outcomes[e.outcome] = outcomes.get(e.outcome, 0) + 1
    out = SimulateResult(episodes=episodes, outcomes=outcomes, code_version=code_version())
    files.write_text(ctx.artifact("simulate.json"), json.dumps(out.model_dump(), indent=2))
    return out
