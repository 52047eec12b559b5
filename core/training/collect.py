"""Stages ``collect`` and ``mix``: roll out episodes, cut them into samples, write datasets.

Base collection = every selected scenario × ``seeds_per_scenario`` seeds derived from
``base_seed`` (scenario i gets base_seed + i·100000 + k, deterministic); hard-case collection =
the (scenario, seed) pairs of a TRAINING seed manifest (never the evaluation manifest). The
driving policy is selectable (goal-seeking, goal-seeking with noise, or any registered planner),
so the data can cover the states the planner itself visits. Episodes are split train/val here,
before any oversampling. Each episode depends only on (scenario, seed, policy), so its samples are the same on
either ``executor`` (this process, or one Ray task per episode: core.evaluation.ray_executor).
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterable
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from foresight.core.bounds import BoundedConfig
from foresight.core.errors import ConfigError
from foresight.core.predict.dataset import (
    DatasetMeta,
    EpisodeRecord,
    config_hash,
    file_sha256,
    load_dataset,
    resolve_dataset_path,
    save_dataset,
)
from foresight.core.predict.mixing import assign_splits, dataset_from_episodes, mix_datasets
from foresight.core.predict.quality import check_quality
from foresight.core.predict.samples import samples_from_trace
from foresight.core.predict.timebase import PLANNER_TIMEBASE, TimeBase
from foresight.core.runtime.context import StageContext
from foresight.core.runtime.execution import Execution, Executor, execution
from foresight.core.runtime.refs import BUILTIN_BUNDLE, BundlePath, Ident, Name, resolve_in_bundle
from foresight.core.scenarios.model import MAX_EPISODE_STEPS
from foresight.core.sim.observation import Observation
from foresight.core.sim.planner import EpisodeInfo


class TimeBaseSpec(BoundedConfig):
    model_config = ConfigDict(extra="forbid", frozen=True)
    dt: float = Field(default=PLANNER_TIMEBASE.dt, gt=0)  #: [s]
    history: int = Field(default=PLANNER_TIMEBASE.history, ge=1, le=1000)
    horizon: int = Field(default=PLANNER_TIMEBASE.horizon, ge=1, le=1000)

    def build(self) -> TimeBase:
        return TimeBase(self.dt, self.history, self.horizon)


class CollectConfig(BoundedConfig):
    model_config = ConfigDict(extra="forbid", frozen=True)
    bundle: Ident = BUILTIN_BUNDLE
    matrix: BundlePath = "scenarios/classic_interactions.yaml"
    scenarios: list[Name] | None = Field(
        default=None, max_length=1000
    )  #: default: all of the matrix (base mode)
    seeds_per_scenario: int = Field(default=4, ge=1, le=10_000)
    base_seed: int = Field(
        default=50_000, ge=0, le=2**31 - 1 - 10_000_000
    )  #: above the matrices' own (evaluation) seeds, all < 10000; room for base_seed + i 100000 + k
    hard_seeds: BundlePath | None = None  #: training seed manifest -> hard-case mode
    evaluation_seeds: BundlePath | None = (
        None  #: evaluation manifest: collecting any of its episodes is an error
    )
    policy: Literal["goal", "goal_noisy", "planner"] = "goal"
    planner: dict[str, Any] | None = (
        None  #: {name, config, model: "cv" | "static" | model id} when policy = planner
    )
    timebase: TimeBaseSpec = TimeBaseSpec()
    max_agents: int = Field(default=12, ge=1, le=256)
    max_steps: int | None = Field(default=300, ge=1, le=MAX_EPISODE_STEPS)  #: cap on episode length
    sample_every: int | None = Field(
        default=None, ge=1, le=MAX_EPISODE_STEPS
    )  #: simulator steps between samples (default: stride)
    val_fraction: float = Field(default=0.2, ge=0, lt=1)
    split_seed: int = 0
    output: str = "dataset.npz"
    check_quality: bool = True
    #: deep-merged into every scenario after the matrix's own overrides (as EpisodeSelection.scenario_overrides)
    scenario_overrides: dict[str, Any] = Field(default_factory=dict)
    executor: Executor = "local"  #: where episodes run (the dataset does not depend on it)


class DatasetSummary(BaseModel):
    """A dataset's counts and statistics (core.predict.quality.summarize); imports add their origin fields."""

    model_config = ConfigDict(extra="allow")

    samples: int
    episodes: int
    samples_per_split: dict[str, int]
    episodes_per_split: dict[str, int]
    active_agent_ratio: float
    active_target_ratio: float
    target_std_m: float
    final_displacement_m: dict[str, float]  #: mean, p50, p95


class CollectResult(BaseModel):
    dataset: str  #: artifact path of the .npz
    sha256: str
    summary: DatasetSummary
    outcomes: dict[str, int]
    execution: Execution | None = None  #: which executor ran the episodes, on how many CPUs (collect only)


class _Recorder:
    """Wraps the driving policy and records the waypoint it was shown at every step."""

    def __init__(self, inner):
        self.inner, self.name, self.waypoints = inner, getattr(inner, "name", "policy"), {}

    def reset(self, info: EpisodeInfo) -> None:
        self.waypoints = {}
        self.inner.reset(info)

    def plan(self, obs: Observation) -> tuple[float, float]:
        self.waypoints[obs.step] = np.asarray(obs.waypoint, float).copy()
        return self.inner.plan(obs)

    @property
    def diagnostics(self):
        return self.inner.diagnostics

    def waypoint_array(self, steps: int) -> np.ndarray:
        """(steps + 1, 2); the final post-step row (never a sample's step) repeats the last seen."""
        last = self.waypoints[max(self.waypoints)]
        return np.stack([self.waypoints.get(t, last) for t in range(steps + 1)])


def _model_path(config: CollectConfig, ctx: StageContext) -> str | None:
    """The checkpoint file of a ``planner`` policy's model (None: no model, constant velocity, a plug-in)."""
    from foresight.core.predict import plugins

    model = (config.planner or {}).get("model") if config.policy == "planner" else None
    if model in (None, "cv", "static") or plugins.kind(
        model
    ):  # a predictor plug-in is built by name (make_planner)
        return None
    return str(ctx.resolve_model(model))


def _policy(config: CollectConfig, model_path: str | None):
    from foresight.core.planners.goal import GoalSeeking

    if config.policy == "goal":
        return GoalSeeking()
    if config.policy == "goal_noisy":
        return GoalSeeking(noise_v=0.15, noise_w=0.3)
    from foresight.core.planners.registry import make_planner

    spec = dict(config.planner or {})
    if "name" not in spec:
        raise ConfigError("policy 'planner' needs planner.name", item="planner.name")
    model = spec.get("model")
    if model_path is not None:
        from foresight.core.predict.nn.checkpoint import load_predictor

        model = load_predictor(model_path)
    return make_planner(spec["name"], spec.get("config"), model=model)


#: one episode to collect: (index, scenario name, seed, role, split)
CollectJob = tuple[int, str, int, str, str]


class CollectWorker:
    """Rolls out a run's episodes one by one with its policy (reset per episode: episodes are independent)."""

    def __init__(
        self,
        config: CollectConfig,
        matrix: Any,
        model_path: str | None = None,
        check: Callable[[], None] | None = None,
    ):
        self.config, self.matrix, self.check = config, matrix, check
        self.timebase = config.timebase.build()
        self.recorder = _Recorder(_policy(config, model_path))

    def run(self, job: CollectJob) -> tuple[int, EpisodeRecord, Any, str]:
        """(index, episode record, its samples, outcome) of one episode."""
        from foresight.core.sim.episode import run_episode

        index, name, seed, role, split = job
        result = run_episode(
            self.matrix.get(name), seed, self.recorder, max_steps=self.config.max_steps, check=self.check
        )
        samples = samples_from_trace(
            result.trace,
            self.timebase,
            self.config.max_agents,
            self.recorder.waypoint_array(result.trace.steps),
            self.config.sample_every,
        )
        return index, EpisodeRecord(name, int(seed), split, role), samples, result.outcome


def episode_list(config: CollectConfig, matrix, manifest_path=None) -> list[tuple[Any, int, str]]:
    """(scenario, seed, role) of every episode to collect."""
    if manifest_path is not None:
        from foresight.core.scenarios.seeds import load_seed_manifest

        manifest = load_seed_manifest(manifest_path, matrix)
        return [(matrix.get(name), seed, "hardcase") for name, seed in manifest.pairs()]
    names = config.scenarios or matrix.names
    return [
        (matrix.get(n), config.base_seed + i * 100_000 + k, "base")
        for i, n in enumerate(names)
        for k in range(config.seeds_per_scenario)
    ]


def _refuse_evaluation_episodes(jobs, path, matrix) -> None:
    """Training data must never contain an episode we evaluate on."""
    from foresight.core.scenarios.seeds import load_seed_manifest

    held = set(load_seed_manifest(path, matrix).pairs())
    clash = [(s.name, seed) for s, seed, _ in jobs if (s.name, seed) in held]
    if clash:
        raise ConfigError(
            f"{len(clash)} collected episodes are evaluation episodes, e.g. {clash[0]}",
            source=path,
            item="evaluation_seeds",
        )


def run_collect(config: CollectConfig, ctx: StageContext) -> CollectResult:
    from foresight.core.scenarios.loader import load_matrix

    root = ctx.resolve_bundle(config.bundle)
    matrix = load_matrix(resolve_in_bundle(root, config.matrix), overrides=config.scenario_overrides)
    manifest = resolve_in_bundle(root, config.hard_seeds) if config.hard_seeds else None
    jobs = episode_list(config, matrix, manifest)
    if config.evaluation_seeds is not None:
        _refuse_evaluation_episodes(jobs, resolve_in_bundle(root, config.evaluation_seeds), matrix)
    timebase = config.timebase.build()
    splits = assign_splits(len(jobs), config.val_fraction, config.split_seed)
    items = [(i, s.name, int(seed), role, splits[i]) for i, (s, seed, role) in enumerate(jobs)]
    model_path = _model_path(config, ctx)
    ctx.check_cancelled()
    results: Iterable[tuple[int, EpisodeRecord, Any, str]]
    if config.executor == "ray":
        from foresight.core.evaluation.ray_executor import run_workers_on_ray

        results = run_workers_on_ray(items, functools.partial(CollectWorker, config, matrix), model_path, ctx)
    else:
        worker = CollectWorker(config, matrix, model_path, ctx.check_cancelled)
        results = (worker.run(item) for item in items)
    done: list[tuple[EpisodeRecord, Any, str] | None] = [None] * len(items)
    for n, (i, rec, samples, outcome) in enumerate(results, start=1):
        done[i] = (rec, samples, outcome)
        ctx.progress(n / len(items), f"{rec.scenario} seed {rec.seed}: {outcome}")
        ctx.check_cancelled()
    episodes, outcomes = [], {}
    for rec, samples, outcome in (d for d in done if d is not None):  # episode order, whoever ran them
        outcomes[outcome] = outcomes.get(outcome, 0) + 1
        episodes.append((rec, samples))
    # the executor is where episodes ran, not what they are: the dataset (and its hash) does not name it
    generator = {"stage": "collect", **config.model_dump(mode="json", exclude={"executor"})}
    meta = DatasetMeta(timebase, config.max_agents, "robot", "sim", [], generator=generator)
    ds = dataset_from_episodes(episodes, meta)
    path = ctx.artifact(config.output)
    if config.check_quality:
        check_quality(ds, str(path))
    record = save_dataset(ds, path)
    ctx.progress(1.0, f"{len(ds)} samples from {len(jobs)} episodes")
    return CollectResult(
        dataset=config.output,
        sha256=record["sha256"],
        summary=record["summary"],
        outcomes=outcomes,
        execution=execution(config.executor, ctx.workers if config.executor == "ray" else 1),
    )


class MixConfig(BoundedConfig):
    model_config = ConfigDict(extra="forbid", frozen=True)
    base: str  #: dataset id or local .npz path
    hardcase: str
    hardcase_repeat: int = Field(default=3, ge=1, le=100)
    output: str = "mixed.npz"


def run_mix(config: MixConfig, ctx: StageContext) -> CollectResult:
    paths = {k: resolve_dataset_path(getattr(config, k), ctx) for k in ("base", "hardcase")}
    base, hard = load_dataset(paths["base"]), load_dataset(paths["hardcase"])
    mixed = mix_datasets(base, hard, config.hardcase_repeat, source=config.output)
    mixed.meta.lineage = [
        {"role": k, "id": getattr(config, k), "sha256": file_sha256(p)} for k, p in paths.items()
    ]
    mixed.meta.generator_config_hash = config_hash(mixed.meta.generator)
    record = save_dataset(mixed, ctx.artifact(config.output))
    return CollectResult(
        dataset=config.output, sha256=record["sha256"], summary=record["summary"], outcomes={}
    )
