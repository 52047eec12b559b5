"""Aggregates over episode records: global, per scenario, per family (archetype), per archetype x density.

Rates carry Wilson 95 % intervals, means a seeded bootstrap interval. Every group reports its delta to
the global value and the episodes that failed, so that a weak family is visible at a glance (with 3
seeds a family holds 3-9 episodes: read the intervals, not only the means).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable

from pydantic import BaseModel, ConfigDict, Field

from foresight.core.evaluation.record import EpisodeRecord
from foresight.core.evaluation.stats import MeanEstimate, RateEstimate, bootstrap_mean, rate
from foresight.core.evaluation.taxonomy import count_labels

#: rate name -> predicate on a record
RATES: dict[str, Callable[[EpisodeRecord], bool]] = {
    "success": lambda r: r.outcome == "success",
    "collision": lambda r: r.collision,
    "collision_pedestrian": lambda r: r.outcome == "collision_pedestrian",
    "collision_static": lambda r: r.outcome == "collision_static",
    "timeout": lambda r: r.outcome == "timeout",
    "error": lambda r: r.outcome == "error",
    "unsolvable": lambda r: (
        r.taxonomy.reachable is False
    ),  #: failed where no robot could reach the goal in time
}

#: mean name -> value of a record (None = not applicable, excluded)
MEANS: dict[str, Callable[[EpisodeRecord], float | None]] = {
    "min_clearance": lambda r: r.safety.min_clearance,
    "min_distance": lambda r: r.safety.min_distance,
    "avg_speed": lambda r: r.efficiency.avg_speed,
    "path_efficiency": lambda r: r.efficiency.path_efficiency,
    "time_to_goal_s": lambda r: r.time_to_goal_s,
    "near_misses": lambda r: float(r.safety.near_misses),
    "jerk_mean": lambda r: r.smoothness.jerk_mean,
    "plan_ms_mean": lambda r: r.timing.plan_ms_mean,
    "plan_ms_p95": lambda r: r.timing.plan_ms_p95,
}


class BootstrapConfig(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)

    samples: int = Field(default=1000, ge=0, le=100_000)
    seed: int = 123
    confidence: float = Field(default=0.95, gt=0, lt=1)


class FailedEpisode(BaseModel):
    scenario: str
    seed: int
    outcome: str
    label: str | None


class GroupStats(BaseModel):
    key: str  #: scenario name, archetype, or "archetype/density"; "global" for all episodes
    episodes: int
    rates: dict[str, RateEstimate]
    means: dict[str, MeanEstimate]
    delta_to_global: dict[str, float | None] = Field(default_factory=dict)  #: group value - global value
    failed: list[FailedEpisode]
    taxonomy: dict[str, int]

    @property
    def success_rate(self) -> float | None:
        return self.rates["success"].rate


class Aggregates(BaseModel):
    overall: GroupStats  #: every episode (the "global" value the deltas refer to)
    per_scenario: list[GroupStats]
    per_family: list[GroupStats]
    per_family_density: list[GroupStats]


def group_stats(key: str, records: list[EpisodeRecord], boot: BootstrapConfig) -> GroupStats:
    n = len(records)
    return GroupStats(
        key=key,
        episodes=n,
        rates={name: rate(sum(1 for r in records if pred(r)), n) for name, pred in RATES.items()},
        means={
            name: bootstrap_mean(
                [get(r) for r in records], samples=boot.samples, seed=boot.seed, confidence=boot.confidence
            )
            for name, get in MEANS.items()
        },
        failed=[
            FailedEpisode(scenario=r.scenario, seed=r.seed, outcome=r.outcome, label=r.taxonomy.label)
            for r in records
            if r.outcome != "success"
        ],
        taxonomy=count_labels([r.taxonomy.label for r in records]),
    )


def _with_delta(group: GroupStats, glob: GroupStats) -> GroupStats:
    delta: dict[str, float | None] = {}
    for name in ("success", "collision"):
        a, b = group.rates[name].rate, glob.rates[name].rate
        delta[f"{name}_rate"] = None if a is None or b is None else a - b
    for name in ("min_clearance", "min_distance", "avg_speed"):
        a, b = group.means[name].mean, glob.means[name].mean
        delta[name] = None if a is None or b is None else a - b
    return group.model_copy(update={"delta_to_global": delta})


def _grouped(
    records: Iterable[EpisodeRecord], key: Callable[[EpisodeRecord], str]
) -> dict[str, list[EpisodeRecord]]:
    groups: dict[str, list[EpisodeRecord]] = {}
    for r in records:
        groups.setdefault(key(r), []).append(r)
    return groups


def family_density_key(r: EpisodeRecord) -> str:
    return f"{r.provenance.archetype}/{r.provenance.density or '-'}"


def aggregate(records: list[EpisodeRecord], boot: BootstrapConfig | None = None) -> Aggregates:
    """All aggregate levels; groups keep the records' order of first appearance."""
    boot = boot or BootstrapConfig()
    glob = group_stats("global", records, boot)

    def level(key: Callable[[EpisodeRecord], str]) -> list[GroupStats]:
        return [_with_delta(group_stats(k, rs, boot), glob) for k, rs in _grouped(records, key).items()]

    return Aggregates(
        overall=glob,
        per_scenario=level(lambda r: r.scenario),
        per_family=level(lambda r: r.provenance.archetype),
        per_family_density=level(family_density_key),
    )


class SuiteSummary(BaseModel):
    """The headline numbers of one suite of episodes (a campaign cell's hard or global suite)."""

    episodes: int
    success: RateEstimate
    collision: RateEstimate
    mean_min_clearance: MeanEstimate  #: surface gap [m]
    mean_min_distance: MeanEstimate  #: centre distance [m]
    mean_avg_speed: MeanEstimate  #: [m/s]
    taxonomy: dict[str, int]

    @property
    def success_rate(self) -> float:
        return self.success.rate or 0.0


def summarise(records: list[EpisodeRecord], boot: BootstrapConfig | None = None) -> SuiteSummary:
    g = group_stats("suite", records, boot or BootstrapConfig())
    return SuiteSummary(
        episodes=g.episodes,
        success=g.rates["success"],
        collision=g.rates["collision"],
        mean_min_clearance=g.means["min_clearance"],
        mean_min_distance=g.means["min_distance"],
        mean_avg_speed=g.means["avg_speed"],
        taxonomy=g.taxonomy,
    )
