"""Stage ``campaign``: checkpoints x planner-grid variants, each on a hard suite and a global suite.

Ranking is the reference's (code) order: descending lexicographic on (hard success, global success, hard
clearance, global clearance, global average speed); cells with integrity violations rank last. Each
finished cell is written to ``cells/`` with a fingerprint of everything that determines it, so a
resumed campaign skips finished cells. The optional closed-loop gate compares the best cell with the
baseline variant on the same checkpoint; a failing gate is a result with exit code 2. A cell's episodes run on
the campaign's executor (``local`` or ``ray``: core.evaluation.runner.run_jobs), with the same result.

Each cell is also a run folder, ``cells/<key>/``, laid out as an evaluation's work folder: its ``episodes.jsonl``
and its episodes' compact traces under ``traces/``. So two cells compare paired and play side by side as two
evaluations do (``foresight compare --local A=RUN/cells/X B=RUN/cells/Y --players OUT``, the API's cell ids).
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import re
import time
from dataclasses import dataclass
from pathlib import Path

from pydantic import ValidationError

from foresight.core import files
from foresight.core.errors import ConfigError
from foresight.core.evaluation.aggregate import SuiteSummary, summarise
from foresight.core.evaluation.campaign_result import (
    CampaignResult,
    CellResult,
)
from foresight.core.evaluation.campaign_text import report
from foresight.core.evaluation.config import CampaignConfig, EpisodeSelection, GridVariant, variant_spec
from foresight.core.evaluation.delta import changed_episodes, paired_deltas
from foresight.core.evaluation.evaluation_result import planner_provenance
from foresight.core.evaluation.gates import GATE_FAILED_EXIT, ClosedLoopGateResult, closed_loop_gate
from foresight.core.evaluation.integrity import check_integrity
from foresight.core.evaluation.plannerspec import (
    NO_MODEL,
    ResolvedPlanner,
    config_diff,
    preflight,
    resolve_planner,
)
from foresight.core.evaluation.runner import (
    EpisodeSettings,
    Job,
    bundle_file,
    expected_cost,
    iter_jobs,
    load_selection,
    read_records,
    write_records,
)
from foresight.core.runtime.context import StageContext
from foresight.core.runtime.execution import execution
from foresight.core.scenarios.model import ScenarioMatrix
from foresight.core.version import code_version


def load_variants(config: CampaignConfig, ctx: StageContext) -> list[GridVariant]:
    if config.variants is not None:
        variants, source = config.variants, "variants"
    else:
        from foresight.core.scenarios.loader import read_yaml

        source = config.grid or "grid"
        data = read_yaml(bundle_file(ctx, config.bundle, source))
        if not isinstance(data, dict) or not isinstance(data.get("variants"), list):
            raise ConfigError("a planner grid needs a 'variants' list", source=source)
        try:
            variants = [GridVariant.model_validate(v) for v in data["variants"]]
        except ValidationError as exc:
            raise ConfigError(exc.errors()[0]["msg"], source=source, item="variants") from None
    names = [v.name for v in variants]
    if not names or len(set(names)) != len(names):
        raise ConfigError("variant names must be unique and at least one", source=source, item="variants")
    return variants


def ranking_key(hard: SuiteSummary, glob: SuiteSummary, integrity_ok: bool) -> list[float]:
    def val(x: float | None) -> float:
        return float("-inf") if x is None else float(x)

    return [
        1.0 if integrity_ok else 0.0,
        val(hard.success.rate),
        val(glob.success.rate),
        val(hard.mean_min_clearance.mean),
        val(glob.mean_min_clearance.mean),
        val(glob.mean_avg_speed.mean),
    ]


def rank(cells: list[CellResult]) -> list[CellResult]:
    """Descending lexicographic on the ranking key; ties keep grid order (stable sort)."""
    return sorted(cells, key=lambda c: tuple(c.ranking_key), reverse=True)


def _cell_key(checkpoint: str, variant: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "_", f"{variant}__{checkpoint}")[:150]


def _fingerprint(rp: ResolvedPlanner, config: CampaignConfig, hard: list, glob: list) -> str:
    data = {
        "config_hash": rp.config_hash,
        "model": rp.model_id,
        "checkpoint": rp.checkpoint_sha256,
        "bundle": config.bundle,
        "matrix": config.matrix,
        "hard": hard,
        "global": glob,
        "max_steps": config.max_steps,
        "metrics": config.metrics.model_dump(),
        "taxonomy": config.taxonomy.model_dump(),
        "bootstrap": config.bootstrap.model_dump(),
        "code": code_version(),
        **({"overrides": config.scenario_overrides} if config.scenario_overrides else {}),
    }
    return hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()


def _checkpoints(config: CampaignConfig) -> list[str]:
    """The checkpoints of the cells: the config's, or ``none`` for a planner without a model."""
    from foresight.core.planners.registry import entry

    if entry(config.planner.name).takes_model:
        return list(config.checkpoints)
    if config.checkpoints != ["cv"]:
        raise ConfigError(
            f"planner {config.planner.name!r} takes no model; leave checkpoints out", item="checkpoints"
        )
    return [NO_MODEL]


def _load_cell(ctx: StageContext, key: str, fingerprint: str) -> CellResult | None:
    path = ctx.workdir / "cells" / f"{key}.json"
    if not path.is_file():
        return None
    try:
        cell = CellResult.model_validate_json(path.read_text())
    except ValidationError:
        return None  # a cell file from another version: run the cell again
    return cell if cell.fingerprint == fingerprint else None


def _run_cells(
    config: CampaignConfig,
    ctx: StageContext,
    plan: CampaignPlan,
    todo: list[int],
    cells: list[CellResult | None],
) -> None:
    """Run the cells ``todo`` (indices into ``plan.cells``), filling ``cells``.

    Their episodes are ONE stream of jobs, cell after cell (each cell's costliest episodes first), so an executor
    with more CPUs than a cell has episodes (a Ray cluster) works on the next cells while a cell's last episodes
    finish, rather than idling through every cell's tail. A cell is finished and written (``cells/<key>.json``,
    the resume point) as soon as its last episode is in."""
    union = suite_union(plan.hard, plan.glob)
    order = sorted(
        range(len(union)), key=lambda k: -expected_cost(plan.matrix, union[k][0], config.max_steps)
    )
    jobs: list[Job] = []
    where: list[tuple[int, int]] = []  #: job position -> (cell, position in the cell's episode list)
    for i in todo:
        for k in order:
            jobs.append(
                Job(
                    len(jobs),
                    union[k][0],
                    union[k][1],
                    plan.cells[i][1],
                    trace_dir=cell_dir(plan.cell_key(i)),
                )
            )
            where.append((i, k))
    got: dict[int, list] = {i: [None] * len(union) for i in todo}
    left = dict.fromkeys(todo, len(union))
    with contextlib.closing(
        iter_jobs(
            jobs,
            plan.settings,
            ctx,
            matrix=plan.matrix,
            start_method=config.start_method,
            executor=config.executor,
            longest_first=False,
        )
    ) as results:
        for done, (pos, record) in enumerate(results, start=1):
            i, k = where[pos]
            got[i][k] = record
            left[i] -= 1
            if left[i] == 0:
                checkpoint, rp = plan.cells[i]
                cells[i] = finish_cell(
                    config,
                    ctx,
                    rp,
                    plan.hard,
                    plan.glob,
                    got.pop(i),
                    plan.cell_key(i),
                    cell_fingerprint(config, plan, i),
                    checkpoint,
                )
                ctx.progress(
                    done / len(jobs), f"{plan.cell_key(i)}: done ({len(todo) - len(got)}/{len(todo)} cells)"
                )
            ctx.check_cancelled()


def cell_dir(key: str) -> str:
    """A cell's run folder, relative to the campaign's work folder."""
    return f"cells/{key}"


def suite_union(hard: list[tuple[str, int]], glob: list[tuple[str, int]]) -> list[tuple[str, int]]:
    """A cell's episodes: the global suite, then the hard episodes not in it (each runs once)."""
    return list(dict.fromkeys([*glob, *hard]))


def finish_cell(
    config: CampaignConfig,
    ctx: StageContext,
    rp: ResolvedPlanner,
    hard: list[tuple[str, int]],
    glob: list[tuple[str, int]],
    records: list,
    key: str,
    fingerprint: str,
    checkpoint: str,
) -> CellResult:
    """A cell from its records (in :func:`suite_union` order); writes ``cells/<key>.json`` and ``.jsonl``."""
    union = suite_union(hard, glob)
    by_pair = {(r.scenario, r.seed): r for r in records}
    hard_recs, glob_recs = [by_pair[p] for p in hard], [by_pair[p] for p in glob]
    integrity = check_integrity(records, expected=union)
    hs, gs = summarise(hard_recs, config.bootstrap), summarise(glob_recs, config.bootstrap)
    episodes = f"{cell_dir(key)}/episodes.jsonl"
    write_records(ctx.artifact(episodes), records)
    cell = CellResult(
        key=key,
        fingerprint=fingerprint,
        checkpoint=checkpoint,
        variant=rp.variant or rp.name,
        planner=planner_provenance(rp),
        hard=hs,
        global_=gs,
        integrity=integrity,
        ranking_key=ranking_key(hs, gs, integrity.ok),
        episodes_file=episodes,
        run_dir=cell_dir(key),
    )
    files.write_text(ctx.artifact(f"cells/{key}.json"), cell.model_dump_json(indent=2))
    return cell


def baseline_variant(config: CampaignConfig, cells: list[CellResult]) -> str:
    """The variant every cell is compared with: the gate's baseline, else the grid's first variant."""
    return config.gate.baseline_variant if config.gate else cells[0].variant


def with_paired_stats(
    config: CampaignConfig, ctx: StageContext, plan: CampaignPlan, cells: list[CellResult]
) -> list[CellResult]:
    """Each cell with its paired comparison against the baseline variant's cell of the same checkpoint on both
    suites (same (scenario, seed) episodes: McNemar / Wilcoxon, ``core.evaluation.delta.paired_deltas``)."""
    name = baseline_variant(config, cells)
    base = {c.checkpoint: c for c in cells if c.variant == name}
    records = {
        c.key: {(r.scenario, r.seed): r for r in read_records(ctx.artifact(c.episodes_file))} for c in cells
    }
    out = []
    for c in cells:
        b = base.get(c.checkpoint)
        if b is None or b.key == c.key:
            out.append(c)
            continue
        vs, changed = {}, {}
        for suite, pairs in (("hard", plan.hard), ("global", plan.glob)):
            ours, theirs = [records[b.key][p] for p in pairs], [records[c.key][p] for p in pairs]
            vs[suite], changed[suite] = paired_deltas(ours, theirs), changed_episodes(ours, theirs) or []
        out.append(
            c.model_copy(update={"baseline": b.key, "vs_baseline": vs, "changed_vs_baseline": changed})
        )
    return out


def _gate(config: CampaignConfig, best: CellResult, cells: list[CellResult]) -> ClosedLoopGateResult | None:
    if config.gate is None:
        return None
    base = next(
        c for c in cells if c.variant == config.gate.baseline_variant and c.checkpoint == best.checkpoint
    )
    return closed_loop_gate(
        (best.key, best.hard, best.global_),
        (base.key, base.hard, base.global_),
        config.gate,
        paired=best.vs_baseline,
    )


def run_campaign(config: CampaignConfig, ctx: StageContext) -> CampaignResult:
    """Run (or resume) every cell, rank, gate; writes campaign_summary.json and campaign_report.md."""
    t0 = time.perf_counter()
    plan = prepare_campaign(config, ctx)
    cells: list[CellResult | None] = [
        _load_cell(ctx, plan.cell_key(i), cell_fingerprint(config, plan, i)) for i in range(len(plan.cells))
    ]
    todo = [i for i, cell in enumerate(cells) if cell is None]
    ctx.progress(0.0, f"{len(cells) - len(todo)} cells resumed, {len(todo)} to run")
    if todo:
        _run_cells(config, ctx, plan, todo, cells)
    ctx.progress(1.0, "done")
    return campaign_result(config, ctx, plan, [c for c in cells if c is not None], len(todo), t0)


@dataclass(frozen=True)
class CampaignPlan:
    """What a campaign runs: its suites and its cells (checkpoint, resolved planner) in grid order."""

    path: Path
    matrix: ScenarioMatrix
    hard: list[tuple[str, int]]
    glob: list[tuple[str, int]]
    cells: list[tuple[str, ResolvedPlanner]]
    settings: EpisodeSettings

    def cell_key(self, i: int) -> str:
        ck, rp = self.cells[i]
        return _cell_key(ck, rp.variant or rp.name)


def prepare_campaign(config: CampaignConfig, ctx: StageContext) -> CampaignPlan:
    """Load the suites and the grid, resolve every cell's planner, check every checkpoint fits every scenario."""
    sel = dict(
        bundle=config.bundle,
        matrix=config.matrix,
        max_steps=config.max_steps,
        scenario_overrides=config.scenario_overrides,
    )
    path, matrix, hard = load_selection(EpisodeSelection(**sel, seed_manifest=config.seed_manifest), ctx)
    _, _, glob = load_selection(
        EpisodeSelection(**sel, scenarios=config.scenarios, seeds_per_scenario=config.seeds_per_scenario), ctx
    )
    variants = load_variants(config, ctx)
    if config.gate and config.gate.baseline_variant not in {v.name for v in variants}:
        raise ConfigError(
            f"baseline variant {config.gate.baseline_variant!r} is not in the grid", item="gate"
        )
    cells_rp = [
        (ck, resolve_planner(variant_spec(config.planner, v, None if ck == NO_MODEL else ck), ctx))
        for ck in _checkpoints(config)
        for v in variants
    ]
    scenarios = [matrix.get(s) for s in dict.fromkeys(s for s, _ in [*glob, *hard])]
    for rp in {rp.model_id: rp for _, rp in cells_rp}.values():  # every checkpoint fits before any episode
        preflight(rp, scenarios)
    settings = EpisodeSettings(
        str(path),
        config.max_steps,
        config.metrics,
        config.taxonomy,
        overrides=config.scenario_overrides,
        trace_root=str(ctx.workdir),
    )
    return CampaignPlan(path, matrix, hard, glob, cells_rp, settings)


def cell_fingerprint(config: CampaignConfig, plan: CampaignPlan, i: int) -> str:
    return _fingerprint(plan.cells[i][1], config, plan.hard, plan.glob)


def campaign_result(
    config: CampaignConfig,
    ctx: StageContext,
    plan: CampaignPlan,
    cells: list[CellResult],
    ran: int,
    t0: float,
) -> CampaignResult:
    """Rank the cells (in grid order), gate, write campaign_summary.json and campaign_report.md."""
    hard, glob = plan.hard, plan.glob
    cells = with_paired_stats(config, ctx, plan, cells)
    ranked = rank(cells)
    gate = _gate(config, ranked[0], cells)
    ref = next(
        (
            c
            for c in cells
            if config.gate
            and c.variant == config.gate.baseline_variant
            and c.checkpoint == ranked[0].checkpoint
        ),
        cells[0],
    )
    diff = config_diff(ranked[0].planner.config, ref.planner.config)
    status = "completed" if gate is None else ("passed" if gate.passed else "failed_gate")
    result = CampaignResult(
        status=status,
        exit_code=0 if gate is None or gate.passed else GATE_FAILED_EXIT,
        best=ranked[0],
        ranked=ranked,
        gate=gate,
        best_vs_reference={k: list(v) for k, v in diff.items()},
        cells_run=ran,
        cells_resumed=len(cells) - ran,
        matrix=config.matrix,
        seed_manifest=config.seed_manifest,
        grid=config.grid or "inline",
        horizon=str(config.max_steps or "scenario"),
        hard_episodes=len(hard),
        global_episodes=len(glob),
        suites={"hard": hard, "global": glob},
        code_version=code_version(),
        execution=execution(config.executor, ctx.workers),
        artifacts={"summary": "campaign_summary.json", "report": "campaign_report.md", "cells": "cells/"},
        wall_s=time.perf_counter() - t0,
        config=config.model_dump(mode="json"),
    )
    files.write_text(ctx.artifact("campaign_summary.json"), result.model_dump_json(indent=2))
    files.write_text(ctx.artifact("campaign_report.md"), report(result))
    return result
