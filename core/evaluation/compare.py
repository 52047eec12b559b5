"""Several evaluations side by side, per family: where is a baseline better than the planner under test?

"Better" is the issue's rule: higher success, or equal success with fewer collisions. Evaluations are
only compared when they ran the same (scenario, seed) episodes, so a table never mixes unlike runs.
"""

from __future__ import annotations

from pathlib import Path

from pydantic import BaseModel

from foresight.core.errors import ConfigError
from foresight.core.evaluation.aggregate import BootstrapConfig, aggregate
from foresight.core.evaluation.record import EpisodeRecord
from foresight.core.evaluation.runner import read_records


class PlannerCell(BaseModel):
    episodes: int
    success: float | None
    collision: float | None


class FamilyRow(BaseModel):
    family: str
    planners: dict[str, PlannerCell]
    better_than_reference: list[str]  #: planners beating the reference planner on this family


class Comparison(BaseModel):
    reference: str
    planners: list[str]
    episodes: int
    overall: dict[str, PlannerCell]
    families: list[FamilyRow]
    families_where_a_baseline_is_better: list[str]


def _better(a: PlannerCell, b: PlannerCell) -> bool:
    """a better than b: higher success, or equal success with fewer collisions."""
    sa, sb = a.success or 0.0, b.success or 0.0
    if abs(sa - sb) > 1e-12:
        return sa > sb
    return (a.collision or 0.0) < (b.collision or 0.0) - 1e-12


def _cell(g) -> PlannerCell:
    return PlannerCell(episodes=g.episodes, success=g.rates["success"].rate, collision=g.rates["collision"].rate)


def compare(runs: dict[str, list[EpisodeRecord]], reference: str) -> Comparison:
    """``runs``: label -> records of one evaluation; ``reference``: the label of the planner under test."""
    if reference not in runs:
        raise ConfigError(f"reference {reference!r} is not among the evaluations ({', '.join(runs)})", item="reference")
    pairs = {label: sorted((r.scenario, r.seed) for r in recs) for label, recs in runs.items()}
    base = pairs[reference]
    for label, p in pairs.items():
        if p != base:
            raise ConfigError(f"evaluation {label!r} ran other episodes than {reference!r}", item=label)
    boot = BootstrapConfig(samples=0)
    aggs = {label: aggregate(recs, boot) for label, recs in runs.items()}
    families = [g.key for g in aggs[reference].per_family]
    rows = []
    for fam in families:
        cells = {label: _cell(next(g for g in a.per_family if g.key == fam)) for label, a in aggs.items()}
        better = [label for label, c in cells.items() if label != reference and _better(c, cells[reference])]
        rows.append(FamilyRow(family=fam, planners=cells, better_than_reference=better))
    return Comparison(
        reference=reference, planners=list(runs), episodes=len(base),
        overall={label: _cell(a.overall) for label, a in aggs.items()}, families=rows,
        families_where_a_baseline_is_better=[r.family for r in rows if r.better_than_reference],
    )


def load_run(workdir: Path) -> tuple[str, list[EpisodeRecord]]:
    """(planner label, records) of an evaluation work folder (its episodes.jsonl)."""
    records = read_records(Path(workdir) / "episodes.jsonl")
    if not records:
        raise ConfigError("no episodes", source=workdir)
    r = records[0]
    label = r.variant or (r.planner if r.provenance.model_id in ("none", "cv") and r.planner != "predictive"
                          else f"{r.planner}[{r.provenance.model_id}]")
    return label, records


def table(c: Comparison) -> str:
    def pct(x: float | None) -> str:
        return "-" if x is None else f"{100 * x:.0f}%"

    head = "| family | " + " | ".join(f"{p} success / coll." for p in c.planners) + " | baseline better |"
    lines = [head, "|---" * (len(c.planners) + 2) + "|"]
    for row in [*c.families, FamilyRow(family="**all**", planners=c.overall, better_than_reference=[])]:
        cells = " | ".join(f"{pct(row.planners[p].success)} / {pct(row.planners[p].collision)}" for p in c.planners)
        lines.append(f"| {row.family} | {cells} | {', '.join(row.better_than_reference) or '-'} |")
    return "\n".join(lines) + "\n"
