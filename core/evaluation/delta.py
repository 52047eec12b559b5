"""The runbook's A/B comparison of two results (evaluations or campaign cells): which config keys differ,
and how each headline metric moved, B - A, with a 95 % interval.

The delta's interval combines the two results' own intervals (Wilson for rates, bootstrap for means) by the
MOVER method (Newcombe 1998, "method 10" for a difference of proportions; Zou & Donner 2008 in general):
for independent estimates A and B with intervals [la, ua] and [lb, ub], d = B - A has
``[d - sqrt((B - lb)^2 + (ua - A)^2), d + sqrt((ub - B)^2 + (A - la)^2)]``. It needs no episode data, so a
comparison reads only the stored summaries; an interval that excludes 0 is a difference the data support.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from pydantic import BaseModel

#: headline metric -> its field in a SuiteSummary (a campaign cell's hard or global suite)
SUITE_FIELDS = {"success": "success", "collision": "collision", "min_clearance": "mean_min_clearance",
                "min_distance": "mean_min_distance", "avg_speed": "mean_avg_speed"}  # fmt: skip


class Estimate(BaseModel):
    value: float | None
    low: float | None = None
    high: float | None = None


class Delta(BaseModel):
    a: Estimate
    b: Estimate
    delta: float | None  #: B - A
    low: float | None  #: 95 % interval of the delta (None when either side has no interval)
    high: float | None
    significant: bool  #: the interval excludes 0


def _estimate(raw: Mapping[str, Any]) -> Estimate:
    """A stored RateEstimate (``rate``) or MeanEstimate (``mean``) as one shape."""
    value = raw.get("rate", raw.get("mean"))
    return Estimate(value=value, low=raw.get("low"), high=raw.get("high"))


def headline(summary: Mapping[str, Any]) -> dict[str, Estimate]:
    """Headline estimates of a stored result: an evaluation's ``overall`` GroupStats (``rates``/``means``)
    or a campaign cell's SuiteSummary; both give the same metric names."""
    if "rates" in summary or "means" in summary:
        raw = {**(summary.get("rates") or {}), **(summary.get("means") or {})}
    else:
        raw = {name: summary[f] for name, f in SUITE_FIELDS.items() if isinstance(summary.get(f), Mapping)}
    return {name: _estimate(v) for name, v in sorted(raw.items()) if isinstance(v, Mapping)}


def mover(a: Estimate, b: Estimate) -> Delta:
    """B - A with its MOVER interval (see the module docstring)."""
    if a.value is None or b.value is None:
        return Delta(a=a, b=b, delta=None, low=None, high=None, significant=False)
    d = b.value - a.value
    if None in (a.low, a.high, b.low, b.high):
        return Delta(a=a, b=b, delta=d, low=None, high=None, significant=False)
    low = d - math.hypot(b.value - b.low, a.high - a.value)
    high = d + math.hypot(b.high - b.value, a.value - a.low)
    return Delta(a=a, b=b, delta=d, low=low, high=high, significant=low > 0 or high < 0)


def deltas(a: Mapping[str, Any], b: Mapping[str, Any]) -> dict[str, Delta]:
    """Every headline metric both results have, B - A."""
    ea, eb = headline(a), headline(b)
    return {name: mover(ea[name], eb[name]) for name in ea if name in eb}


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
    return {k: {"a": fa.get(k), "b": fb.get(k)} for k in sorted(fa.keys() | fb.keys()) if fa.get(k) != fb.get(k)}
