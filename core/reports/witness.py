"""The witness job's report: each episode searched, its witness (or none), how close it passed, what the planner's own
cost made of it, and a link to its player beside the planner's run."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from foresight.core.evaluation.witness_job import WitnessResult
from foresight.core.reports.common import publish, read
from foresight.core.reports.document import Document


def build_witness_document(r: WitnessResult) -> Document:
    what = "failed episodes of evaluation " + f"`{r.evaluation}`" if r.failed_only else "episodes"
    doc = Document(f"Witnesses: {r.witnessed} of {r.searched} {what}")
    keeping = (
        f", keeping {r.settings.min_clearance:g} m from every pedestrian" if r.settings.min_clearance else ""
    )
    doc.text(
        f"Matrix `{r.matrix}`{keeping}; conditions: `{r.overrides or 'its own'}`. A witness is a scripted plan "
        "that reaches the goal without contact, with the crowd reacting to it: the episode could be solved by a "
        "robot with these limits. No witness among the plans tried is evidence, not proof, that none could."
    )
    rows = []
    for e in r.episodes:
        room = "-" if e.clearance_m is None else f"{e.clearance_m:.2f}"
        rows.append(
            [
                f"{e.scenario} {e.seed}",
                e.planner_outcome or "-",
                e.summary(),
                room,
                e.priced.summary() if e.priced is not None else "-",
            ]
        )
    doc.section("Episodes").table(
        ["episode", "planner", "witness", "closest pedestrian [m]", "priced by the planner"], rows
    )
    players = [(f"{e.scenario} seed {e.seed}", e.player) for e in r.episodes if e.player]
    if players:
        doc.section("Players").text("Each witness beside the planner's own run, on one clock.").links(players)
    return doc


def write_witness_report(result: Any, workdir: str | Path) -> list[Path]:
    """``report.md`` and ``report.html`` of a witness job in ``workdir``; returns their paths."""
    return publish(build_witness_document(read(WitnessResult, result)), Path(workdir))
