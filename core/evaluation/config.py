"""Stage configs of the evaluation engine (evaluate, diagnose, campaign), defined once for YAML, API and CLI.

Inputs are named by bundle id + bundle-relative path and by model id, never by server paths.
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from foresight.core.bounds import BoundedConfig
from foresight.core.errors import ConfigError
from foresight.core.evaluation.aggregate import BootstrapConfig
from foresight.core.evaluation.gates import ClosedLoopGateConfig, EvaluationGateConfig
from foresight.core.evaluation.metrics import MetricsConfig
from foresight.core.evaluation.plannerspec import PlannerSpec, planner_config, planner_spec
from foresight.core.evaluation.taxonomy import TaxonomyConfig
from foresight.core.runtime.execution import Executor
from foresight.core.runtime.refs import BUILTIN_BUNDLE, BundlePath, Ident, Name
from foresight.core.scenarios.model import MAX_EPISODE_STEPS

StartMethod = Literal["spawn", "fork", "forkserver"]


def refuse_shards(data: Any) -> Any:
    """``shards`` (shard child jobs) is gone: episodes spread over machines on Ray. A spec still sending it gets
    this one error, naming what to use instead, rather than an anonymous "extra input"."""
    if isinstance(data, dict) and "shards" in data:
        raise ValueError(
            "'shards' was removed: to spread episodes over machines use 'executor: ray' "
            "(a Ray cluster at FORESIGHT_RAY_ADDRESS, see docs/tutorials/scaling-out.md)"
        )
    return data


class _Config(BoundedConfig):
    model_config = ConfigDict(extra="forbid", frozen=True)


class EpisodeSelection(_Config):
    """Which episodes: scenarios of a matrix x seeds (the matrix's own, N per scenario, or a seed manifest)."""

    bundle: Ident = BUILTIN_BUNDLE
    matrix: BundlePath = "scenarios/classic_interactions.yaml"
    scenarios: list[Name] | None = Field(default=None, max_length=1000)  #: default: every scenario
    seeds_per_scenario: int | None = Field(
        default=None, ge=1, le=1000
    )  #: own seeds, extended by max+1, max+2 ...
    seed_manifest: BundlePath | None = None  #: only these (scenario, seed) pairs
    max_steps: int | None = Field(
        default=None, ge=1, le=MAX_EPISODE_STEPS
    )  #: horizon override (smoke runs); default: the scenario's
    #: deep-merged into every scenario after the matrix's own overrides: run a matrix under other conditions,
    #: e.g. ``{simulation_config: {ped_speed_tier: typical, peds_have_robot_repulsion: false}}``
    scenario_overrides: dict[str, Any] = Field(default_factory=dict)

    @model_validator(mode="after")
    def _one_seed_source(self) -> EpisodeSelection:
        if self.seed_manifest is not None and self.seeds_per_scenario is not None:
            raise ValueError("give seeds_per_scenario or seed_manifest, not both")
        return self


class EvaluationConfig(EpisodeSelection):
    planner: PlannerSpec = Field(default_factory=planner_spec)
    metrics: MetricsConfig = MetricsConfig()
    taxonomy: TaxonomyConfig = TaxonomyConfig()
    gate: EvaluationGateConfig = EvaluationGateConfig()
    bootstrap: BootstrapConfig = BootstrapConfig()
    start_method: StartMethod = "spawn"  #: worker processes (results do not depend on it)
    executor: Executor = "local"

    _no_shards = model_validator(mode="before")(refuse_shards)


class DiagnosticsConfig(EpisodeSelection):
    """Hard-seed diagnostics: every (scenario, seed) of a seed manifest, traced step by step."""

    seed_manifest: BundlePath  #: required here
    planner: PlannerSpec = Field(default_factory=planner_spec)
    metrics: MetricsConfig = MetricsConfig()
    taxonomy: TaxonomyConfig = TaxonomyConfig()
    render: bool = True  #: a PNG and an animated GIF replay per seed
    max_predicted_peds: int = Field(
        default=4, ge=0, le=200
    )  #: per-step predicted-vs-actual for the nearest N peds
    executor: Executor = "local"


class GridVariant(_Config):
    """One planner-grid variant: our keys (``config``, merged into the base planner's config) and/or, for the
    predictive planner, reference keys (``params``, mapped by the planner)."""

    name: Name
    params: dict[str, Any] = Field(default_factory=dict)
    config: dict[str, Any] = Field(default_factory=dict)


def _merge(base: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    """``base`` with ``over``'s keys, nested mappings merged key by key."""
    out = dict(base)
    for key, value in over.items():
        out[key] = (
            _merge(out[key], value) if isinstance(value, dict) and isinstance(out.get(key), dict) else value
        )
    return out


def variant_spec(base: Any, variant: GridVariant, checkpoint: str | None) -> Any:
    """The planner spec of one grid variant on ``base`` (the campaign's planner) with ``checkpoint`` as model.

    ConfigError naming the variant and the field when the merged config does not fit the planner's model.
    """
    config = base.config.model_dump(exclude_unset=True) if isinstance(base.config, BaseModel) else base.config
    over = variant.config
    try:
        upgrade = getattr(type(base.config), "upgrade_keys", None)  # old key names -> today's, before merging
        if upgrade is not None:
            over = upgrade(over)
        return planner_spec(
            name=base.name,
            config=_merge(config or {}, over),
            reference_params={**(base.reference_params or {}), **variant.params} or None,
            variant=variant.name,
            model=checkpoint,
        )
    except ConfigError as exc:
        raise ConfigError(exc.detail, source=f"grid variant {variant.name}", item=exc.item) from None


class CampaignConfig(_Config):
    """Checkpoints x planner-grid variants, each on a hard suite (seed manifest) and a global suite (matrix)."""

    bundle: Ident = BUILTIN_BUNDLE
    matrix: BundlePath = "scenarios/classic_interactions.yaml"
    seed_manifest: BundlePath  #: the hard suite: an evaluation manifest, never the training one
    grid: BundlePath | None = None  #: planner-grid YAML (``variants: [{name, params}]``)
    variants: list[GridVariant] | None = Field(
        default=None, max_length=200
    )  #: inline grid (instead of ``grid``)
    checkpoints: list[str] = Field(
        default_factory=lambda: ["cv"], min_length=1, max_length=50
    )  #: model ids or "cv"
    scenarios: list[Name] | None = Field(
        default=None, max_length=1000
    )  #: global suite scenarios (default: all)
    planner: PlannerSpec = Field(default_factory=planner_spec)  #: base planner config the variants modify
    seeds_per_scenario: int | None = Field(default=None, ge=1, le=1000)  #: global suite seeds
    max_steps: int | None = Field(default=None, ge=1, le=MAX_EPISODE_STEPS)
    scenario_overrides: dict[str, Any] = Field(
        default_factory=dict
    )  #: both suites' conditions (EpisodeSelection's)
    gate: ClosedLoopGateConfig | None = None
    metrics: MetricsConfig = MetricsConfig()
    taxonomy: TaxonomyConfig = TaxonomyConfig()
    bootstrap: BootstrapConfig = BootstrapConfig()
    start_method: StartMethod = "spawn"
    executor: Executor = "local"

    _no_shards = model_validator(mode="before")(refuse_shards)

    @model_validator(mode="after")
    def _grid(self) -> CampaignConfig:
        if (self.grid is None) == (self.variants is None):
            raise ValueError("give exactly one of grid (a file) or variants (inline)")
        for variant in self.variants or ():  # an inline variant's config is checked now, naming the field
            spec = variant_spec(self.planner, variant, None)
            if variant.params:  # reference keys: mapped (and so checked) only by the planner's config
                planner_config(spec)
        if len(set(self.checkpoints)) != len(self.checkpoints):
            raise ValueError("checkpoints listed twice")
        return self
