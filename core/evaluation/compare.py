"""Several evaluations side by side, per family: where is a baseline better than the planner under test?

"Better" is one rule: higher success, or equal success with fewer collisions. Evaluations are
only compared when they ran the same (scenario, seed) episodes, so a table never mixes unlike runs; every
planner is also compared with the reference pair by pair (``paired``: other - reference, McNemar exact for
success and collisions, Wilcoxon signed-rank for the continuous metrics; per family the success delta), and a
difference is significant only from ``MIN_PAIRS`` episodes on.
"""

from __future__ import annotations

from pathlib import Path

from pydantic import BaseModel

from foresight.core.errors import ConfigError
from foresight.core.evaluation.aggregate import BootstrapConfig, aggregate
from foresight.core.evaluation.delta import Delta, EpisodeChange, changed_episodes, paired_deltas
from foresight.core.evaluation.record import EpisodeRecord
from foresight.core.evaluation.runner import read_records
from foresight.core.evaluation.stats import ALPHA, MIN_PAIRS
from foresight.core.render.episode_trace import episode_stem

SHOWN_CHANGES = 20  #: changed episodes a text listing shows (and ``write_players`` writes) per planner


class PlannerCell(BaseModel):
    episodes: int
    success: float | None
    collision: float | None


class FamilyRow(BaseModel):
    family: str
    planners: dict[str, PlannerCell]
    better_than_reference: list[str]  #: planners beating the reference planner on this family
    paired_success: dict[
        str, Delta
    ] = {}  #: planner -> its success minus the reference's, paired on the family


class Comparison(BaseModel):
    reference: str
    planners: list[str]
    episodes: int
    overall: dict[str, PlannerCell]
    families: list[FamilyRow]
    families_where_a_baseline_is_better: list[str]
    paired: dict[str, dict[str, Delta]] = {}  #: planner -> headline metric -> planner - reference, paired
    changed: dict[
        str, list[EpisodeChange]
    ] = {}  #: planner -> episodes whose outcome differs (a: the reference's)
    players: dict[
        str, list[str]
    ] = {}  #: planner -> side-by-side player pages written of them (``write_players``)


def _better(a: PlannerCell, b: PlannerCell) -> bool:
    """a better than b: higher success, or equal success with fewer collisions."""
    sa, sb = a.success or 0.0, b.success or 0.0
    if abs(sa - sb) > 1e-12:
        return sa > sb
    return (a.collision or 0.0) < (b.collision or 0.0) - 1e-12


def _cell(g) -> PlannerCell:
    return PlannerCell(
        episodes=g.episodes, success=g.rates["success"].rate, collision=g.rates["collision"].rate
    )


def compare(runs: dict[str, list[EpisodeRecord]], reference: str) -> Comparison:
    """``runs``: label -> records of one evaluation; ``reference``: the label of the planner under test."""
    if reference not in runs:
        raise ConfigError(
            f"reference {reference!r} is not among the evaluations ({', '.join(runs)})", item="reference"
        )
    pairs = {label: sorted((r.scenario, r.seed) for r in recs) for label, recs in runs.items()}
    base = pairs[reference]
    for label, p in pairs.items():
        if p != base:
            raise ConfigError(f"evaluation {label!r} ran other episodes than {reference!r}", item=label)
    boot = BootstrapConfig(samples=0)
    aggs = {label: aggregate(recs, boot) for label, recs in runs.items()}
    families = [g.key for g in aggs[reference].per_family]
    others = [label for label in runs if label != reference]

    def paired(fam: str | None) -> dict[str, dict[str, Delta]]:
        def pick(recs: list[EpisodeRecord]) -> list[EpisodeRecord]:
            return [r for r in recs if fam is None or r.provenance.archetype == fam]

        return {label: paired_deltas(pick(runs[reference]), pick(runs[label])) or {} for label in others}

    rows = []
    for fam in families:
        cells = {label: _cell(next(g for g in a.per_family if g.key == fam)) for label, a in aggs.items()}
        better = [label for label, c in cells.items() if label != reference and _better(c, cells[reference])]
        success = {label: d["success"] for label, d in paired(fam).items() if d}
        rows.append(
            FamilyRow(family=fam, planners=cells, better_than_reference=better, paired_success=success)
        )
    return Comparison(
        reference=reference,
        planners=list(runs),
        episodes=len(base),
        overall={label: _cell(a.overall) for label, a in aggs.items()},
        families=rows,
        families_where_a_baseline_is_better=[r.family for r in rows if r.better_than_reference],
        paired=paired(None),
        changed={label: changed_episodes(runs[reference], runs[label]) or [] for label in others},
    )


def write_players(
    c: Comparison, folders: dict[str, Path], out: Path, limit: int = SHOWN_CHANGES
) -> Comparison:
    """For every planner, its first ``limit`` changed episodes as side-by-side player pages (the reference's run
    and its own, ``core.render.player``) under ``out/<planner>/``, where both work folders kept the episode's
    compact trace; the comparison with ``players`` filled in."""
    from foresight.core.render.episode_trace import trace_name
    from foresight.core.render.player import write_pair

    written: dict[str, list[str]] = {}
    for label, changed in c.changed.items():
        written[label] = []
        for e in changed[:limit]:
            name = trace_name(e.scenario, e.seed)
            runs = [(c.reference, e.a, folders[c.reference] / name), (label, e.b, folders[label] / name)]
            if not all(trace.is_file() for _, _, trace in runs):
                continue
            title = f"{e.scenario} seed {e.seed}: {c.reference} and {label}"
            written[label].append(str(write_pair(out, label, e.scenario, e.seed, runs, title)))
    return c.model_copy(update={"players": written})


def load_run(workdir: Path) -> tuple[str, list[EpisodeRecord]]:
    """(planner label, records) of an evaluation work folder or a campaign cell's (its episodes.jsonl)."""
    path = Path(workdir) / "episodes.jsonl"
    if not path.is_file():
        from foresight.core.evaluation.campaign import cell_dir

        cells = sorted(f.parent.name for f in Path(workdir).glob(f"{cell_dir('*')}/episodes.jsonl"))
        hint = (
            f"a campaign's folder: compare its cells, {', '.join(f'cells/{c}' for c in cells[:4])}"
            f"{' ...' if len(cells) > 4 else ''}"
            if cells
            else "the folder of `foresight evaluate --local --out DIR`, or a campaign's cells/<key>"
        )
        raise ConfigError(f"no episodes.jsonl here ({hint})", source=workdir)
    records = read_records(path)
    if not records:
        raise ConfigError("no episodes", source=workdir)
    r = records[0]
    label = r.variant or (
        r.planner
        if r.provenance.model_id in ("none", "cv") and r.planner != "predictive"
        else f"{r.planner}[{r.provenance.model_id}]"
    )
    return label, records


def table(c: Comparison) -> str:
    def pct(x: float | None) -> str:
        return "-" if x is None else f"{100 * x:.0f}%"

    def paired(d: Delta | None) -> str:
        if d is None or d.delta is None:
            return "-"
        return f"{100 * d.delta:+.0f} pp, p={d.p_value:.2g}{' *' if d.significant else ''}"

    others = [p for p in c.planners if p != c.reference]
    head = (
        "| family | "
        + " | ".join(f"{p} success / coll." for p in c.planners)
        + " | baseline better | "
        + " | ".join(f"{p} - {c.reference} success (McNemar)" for p in others)
        + " |"
    )
    lines = [head, "|---" * (len(c.planners) + 2 + len(others)) + "|"]
    overall = {p: d.get("success") for p, d in c.paired.items()}
    for row in [
        *c.families,
        FamilyRow(
            family="**all**",
            planners=c.overall,
            better_than_reference=[],
            paired_success={p: d for p, d in overall.items() if d},
        ),
    ]:
        cells = " | ".join(
            f"{pct(row.planners[p].success)} / {pct(row.planners[p].collision)}" for p in c.planners
        )
        tests = " | ".join(paired(row.paired_success.get(p)) for p in others)
        lines.append(f"| {row.family} | {cells} | {', '.join(row.better_than_reference) or '-'} | {tests} |")
    lines.append(
        f"\npaired on the same (scenario, seed) episodes; * = McNemar exact p < {ALPHA} with at least "
        f"{MIN_PAIRS} pairs"
    )
    for p in others:
        changed = c.changed.get(p, [])
        pages = {Path(page).stem: page for page in c.players.get(p, [])}
        links = [pages.get(episode_stem(e.scenario, e.seed)) for e in changed]
        lines += [
            "",
            f"episodes where {p} ends otherwise than {c.reference}:",
            *changed_lines(changed, links),
        ]
        if p in c.players:
            lines.append(
                f"  {len(c.players[p])} side-by-side player pages"
                + (
                    f" in {Path(c.players[p][0]).parent}"
                    if c.players[p]
                    else " (no episode with both traces)"
                )
            )
    return "\n".join(lines) + "\n"


def changed_lines(changed: list[EpisodeChange], links: list[str | None] | None = None) -> list[str]:
    """The text listing of changed episodes (the first ``SHOWN_CHANGES``; ``--json`` has them all), each followed by
    its link where ``links`` (one per episode) has one."""
    links = links or [None] * len(changed)
    lines = [
        f"  {e.scenario} {e.seed}: {e.a} -> {e.b}" + (f"  {link}" if link else "")
        for e, link in zip(changed[:SHOWN_CHANGES], links, strict=False)
    ] or ["  none"]
    if len(changed) > SHOWN_CHANGES:
        lines.append(f"  ... and {len(changed) - SHOWN_CHANGES} more (--json lists every one)")
    return lines
