"""The runbook's A/B comparison of two results (evaluations or campaign cells): which config keys differ,
and how each headline metric moved, B - A, with a 95 % interval.

The delta's interval combines the two results' own intervals (Wilson for rates, bootstrap for means) by the
MOVER method (Newcombe 1998, "method 10" for a difference of proportions; Zou & Donner 2008 in general):
for independent estimates A and B with intervals [la, ua] and [lb, ub], d = B - A has
``[d - sqrt((B - lb)^2 + (ua - A)^2), d + sqrt((ub - B)^2 + (A - la)^2)]``. It needs no episode data, so a
comparison reads only the stored summaries; an interval that excludes 0 is a difference the data support.
That is the **unpaired** method (``method: unpaired_mover``), for results that did not run the same episodes.

Two results that ran the same (scenario, seed) episodes are **paired** (``method: paired``, see
:func:`paired_deltas`): B - A is the mean of the per-episode differences, its interval the exact conditional
one of McNemar's test (success, collision) or a paired bootstrap (continuous metrics), and its p-value McNemar's exact test (success, collision) or the Wilcoxon signed-rank test (continuous
metrics), ``core.evaluation.stats``. Either way nothing is marked significant below ``MIN_PAIRS`` episodes.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel

from foresight.core.evaluation.aggregate import MEANS, RATES, GroupStats, SuiteSummary
from foresight.core.evaluation.record import EpisodeRecord
from foresight.core.evaluation.stats import (
    ALPHA,
    MIN_PAIRS,
    MeanEstimate,
    RateEstimate,
    mcnemar_interval,
    mcnemar_p,
    paired_bootstrap,
    wilcoxon_p,
)

#: headline metric -> its field in a SuiteSummary (a campaign cell's hard or global suite)
SUITE_FIELDS = {
    "success": "success",
    "collision": "collision",
    "min_clearance": "mean_min_clearance",
    "min_distance": "mean_min_distance",
    "avg_speed": "mean_avg_speed",
}


#: headline metric -> per-episode value (booleans as 0/1; None = not applicable, the pair is left out)
EPISODE_VALUES: dict[str, Callable[[EpisodeRecord], float | bool | None]] = {
    "success": RATES["success"],
    "collision": RATES["collision"],
    **{k: MEANS[k] for k in ("min_clearance", "min_distance", "avg_speed")},
}
BINARY = ("success", "collision")


class Estimate(BaseModel):
    value: float | None
    low: float | None = None
    high: float | None = None
    n: int | None = None  #: episodes behind the estimate, when known


class Delta(BaseModel):
    a: Estimate
    b: Estimate
    delta: float | None  #: B - A
    low: float | None  #: 95 % interval of the delta (None when either side has no interval)
    high: float | None
    significant: bool  #: paired: p < ALPHA; unpaired: the interval excludes 0; never below MIN_PAIRS episodes
    method: Literal["unpaired_mover", "paired"] = "unpaired_mover"
    test: Literal["mcnemar_exact", "wilcoxon_signed_rank"] | None = None  #: paired only
    n_pairs: int | None = None  #: paired only: episodes both results ran (with a value on both sides)
    discordant: tuple[int, int] | None = None  #: McNemar's (A only, B only) pairs
    p_value: float | None = None  #: paired only, two-sided


def _estimate(e: RateEstimate | MeanEstimate) -> Estimate:
    """A RateEstimate or a MeanEstimate as one shape."""
    return Estimate(value=e.rate if isinstance(e, RateEstimate) else e.mean, low=e.low, high=e.high, n=e.n)


def headline(summary: GroupStats | SuiteSummary) -> dict[str, Estimate]:
    """Headline estimates of a result: an evaluation's ``overall`` GroupStats (``rates``/``means``) or a campaign
    cell's SuiteSummary; both give the same metric names."""
    if isinstance(summary, GroupStats):
        raw: dict[str, RateEstimate | MeanEstimate] = {**summary.rates, **summary.means}
    else:
        raw = {name: getattr(summary, f) for name, f in SUITE_FIELDS.items()}
    return {name: _estimate(v) for name, v in sorted(raw.items())}


def mover(a: Estimate, b: Estimate) -> Delta:
    """B - A with its MOVER interval (see the module docstring)."""
    if a.value is None or b.value is None:
        return Delta(a=a, b=b, delta=None, low=None, high=None, significant=False)
    d = b.value - a.value
    if None in (a.low, a.high, b.low, b.high):
        return Delta(a=a, b=b, delta=d, low=None, high=None, significant=False)
    low = d - math.hypot(b.value - b.low, a.high - a.value)
    high = d + math.hypot(b.high - b.value, a.value - a.low)
    enough = all(e.n is None or e.n >= MIN_PAIRS for e in (a, b))
    return Delta(a=a, b=b, delta=d, low=low, high=high, significant=enough and (low > 0 or high < 0))


def deltas(a: GroupStats | SuiteSummary, b: GroupStats | SuiteSummary) -> dict[str, Delta]:
    """Every headline metric both results have, B - A (unpaired: from the stored summaries)."""
    ea, eb = headline(a), headline(b)
    return {name: mover(ea[name], eb[name]) for name in ea if name in eb}


def pair_keys(records: Sequence[EpisodeRecord]) -> list[tuple[str, int]]:
    return sorted((r.scenario, r.seed) for r in records)


def paired_delta(
    name: str, a: Sequence[float | bool | None], b: Sequence[float | bool | None], *, seed: int = 123
) -> Delta:
    """B - A of one metric over paired episodes (``a[i]`` and ``b[i]`` from the same scenario and seed)."""
    keep = [i for i, (x, y) in enumerate(zip(a, b, strict=True)) if x is not None and y is not None]
    va = np.array([float(a[i]) for i in keep])
    vb = np.array([float(b[i]) for i in keep])
    n = len(keep)
    if n == 0:
        return Delta(
            a=Estimate(value=None),
            b=Estimate(value=None),
            delta=None,
            low=None,
            high=None,
            significant=False,
            method="paired",
            n_pairs=0,
        )
    diff = vb - va
    discordant = None
    if name in BINARY:
        discordant = (int(((va == 1) & (vb == 0)).sum()), int(((va == 0) & (vb == 1)).sum()))
        test, p = "mcnemar_exact", mcnemar_p(*discordant)
        low, high = mcnemar_interval(*discordant, n)
    else:
        test, p = "wilcoxon_signed_rank", wilcoxon_p(diff)
        low, high = paired_bootstrap(diff, seed=seed)
    return Delta(
        a=Estimate(value=float(va.mean()), n=n),
        b=Estimate(value=float(vb.mean()), n=n),
        delta=float(diff.mean()),
        low=low,
        high=high,
        significant=n >= MIN_PAIRS and p < ALPHA,
        method="paired",
        test=test,
        n_pairs=n,
        discordant=discordant,
        p_value=p,
    )


def paired_deltas(a: Sequence[EpisodeRecord], b: Sequence[EpisodeRecord]) -> dict[str, Delta] | None:
    """Every headline metric, B - A, paired by (scenario, seed); None when the two ran other episodes
    (then only the unpaired :func:`deltas` apply)."""
    if not a or pair_keys(a) != pair_keys(b):
        return None
    by_pair = {(r.scenario, r.seed): r for r in b}
    pairs = [(r, by_pair[(r.scenario, r.seed)]) for r in a]
    return {
        name: paired_delta(name, [get(x) for x, _ in pairs], [get(y) for _, y in pairs])
        for name, get in EPISODE_VALUES.items()
    }


class EpisodeChange(BaseModel):
    """One paired episode whose outcome differs between A and B: where a paired test's discordant pairs are."""

    scenario: str
    seed: int
    a: str  #: A's outcome (success, timeout, collision_pedestrian, ...)
    b: str  #: B's outcome


def changed_episodes(a: Sequence[EpisodeRecord], b: Sequence[EpisodeRecord]) -> list[EpisodeChange] | None:
    """The (scenario, seed) episodes whose outcome differs, in that order; None when the two ran other episodes.
    The episodes a success delta's McNemar test counts are the ones here where exactly one side succeeded."""
    if not a or pair_keys(a) != pair_keys(b):
        return None
    by_pair = {(r.scenario, r.seed): r.outcome for r in b}
    return [
        EpisodeChange(scenario=r.scenario, seed=r.seed, a=r.outcome, b=by_pair[(r.scenario, r.seed)])
        for r in sorted(a, key=lambda r: (r.scenario, r.seed))
        if r.outcome != by_pair[(r.scenario, r.seed)]
    ]


def flatten(value: Any, prefix: str = "") -> dict[str, Any]:
    """Nested mappings as dotted keys (lists and scalars are leaves)."""
    if not isinstance(value, Mapping):
        return {prefix: value}
    out: dict[str, Any] = {}
    for key, item in value.items():
        out.update(flatten(item, f"{prefix}.{key}" if prefix else str(key)))
    return out


def diff_configs(a: Mapping[str, Any], b: Mapping[str, Any]) -> dict[str, dict[str, Any]]:
    """Keys whose values differ between two (nested) configs, as dotted keys."""
    fa, fb = flatten(a), flatten(b)
    return {
        k: {"a": fa.get(k), "b": fb.get(k)} for k in sorted(fa.keys() | fb.keys()) if fa.get(k) != fb.get(k)
    }


#: what a comparison leads with: the run-level choices two results may differ in (``run_setup``)
SETUP_KEYS = ("planner", "model", "matrix", "episodes", "horizon")


def run_setup(
    planner: str, model: str | None, bundle: str | None, matrix: str | None, episodes: str, horizon: Any
) -> dict[str, Any]:
    """One canonical shape of "what was run" for an evaluation and a campaign cell alike, so that their
    comparison names the real differences (planner, model, matrix, episodes, horizon) first."""
    return {
        "planner": planner,
        "model": model or None,
        "matrix": f"{bundle}:{matrix}" if bundle else matrix,
        "episodes": episodes,
        "horizon": None if horizon in (None, "scenario") else horizon,
    }


def what_differs(a: Mapping[str, Any], b: Mapping[str, Any]) -> dict[str, dict[str, Any]]:
    """The setup keys (``SETUP_KEYS``) whose values differ, in that order."""
    return {k: {"a": a.get(k), "b": b.get(k)} for k in SETUP_KEYS if a.get(k) != b.get(k)}
