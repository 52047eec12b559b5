"""Sharded evaluations and campaigns: deterministic disjoint slices of the work list, and their merge.

A run's work list is fixed by its config alone: an evaluation's (scenario, seed) episodes in matrix order; a
campaign's cells (checkpoint x variant, grid order) x each cell's episodes (:func:`suite_union` order). Shard
``i`` of ``N`` runs items ``i, i+N, i+2N, ...`` (strided, so every shard gets a mix of scenarios and cells and
about the same cost) and writes their records (``shard_episodes.jsonl``) with a :class:`ShardResult`
(``shard.json``: which items, and a fingerprint of the whole work list).

The merge recomputes the work list and its fingerprint, checks that the shards cover every item exactly once with
the episodes it expects, puts the records back in work-list order (:func:`merge_records`, a pure function), then
builds the result with the very code an unsharded run uses (``finish_evaluation``; ``finish_cell`` +
``campaign_result``). Every episode depends only on (scenario, seed, resolved planner config), so a merged
result has the numbers of an unsharded run (planner timing aside, which is wall-clock).

Who runs the shards is the service's business (``core.evaluation.sharded``: one child job per shard); here a shard is
a stage function like any other (``run_evaluation_shard``, ``run_campaign_shard``).
"""

from __future__ import annotations

import hashlib
import json
import time
from collections import Counter
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel

from foresight.core import files
from foresight.core.errors import CoreError
from foresight.core.evaluation.campaign import (
    CampaignPlan,
    CampaignResult,
    campaign_result,
    cell_fingerprint,
    finish_cell,
    prepare_campaign,
    suite_union,
)
from foresight.core.evaluation.config import (
    CampaignConfig,
    CampaignShardConfig,
    EvaluationConfig,
    EvaluationShardConfig,
    ShardRef,
)
from foresight.core.evaluation.record import EpisodeRecord
from foresight.core.evaluation.runner import (
    EvaluationResult,
    Job,
    PreparedEvaluation,
    finish_evaluation,
    prepare_evaluation,
    read_records,
    run_jobs,
    write_records,
)
from foresight.core.stages.context import StageContext
from foresight.core.version import code_version

SHARD_FORMAT = "foresight.shard/1"
SHARD_FILE = "shard.json"
RECORDS_FILE = "shard_episodes.jsonl"

Pair = tuple[str, int]


class ShardResult(BaseModel):
    """A shard's partial result (``shard.json`` and its job's result summary); its records are in ``records``
    (always ``shard_episodes.jsonl`` next to it)."""

    format: str = SHARD_FORMAT
    stage: Literal["evaluate", "campaign"]
    index: int
    count: int
    fingerprint: str  #: of the whole work list: shards of different runs never merge
    total: int  #: items in the whole work list
    items: list[int]  #: work-list indices this shard ran, in order (one record each)
    episodes: int
    outcomes: dict[str, int]
    code_version: str
    records: str = RECORDS_FILE
    wall_s: float


def shard_items(total: int, index: int, count: int) -> list[int]:
    """The work-list indices of shard ``index`` of ``count``: every ``count``-th from ``index`` on."""
    return list(range(index, total, count))


def _digest(data: Any) -> str:
    return hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()


def evaluation_work(config: EvaluationConfig, prep: PreparedEvaluation) -> tuple[list[Pair], str]:
    """(work list, fingerprint) of an evaluation: its episodes and everything that determines their records."""
    rp = prep.planner
    fp = _digest({"stage": "evaluate", "bundle": config.bundle, "matrix": config.matrix, "pairs": prep.pairs,
                  "planner": rp.config_hash, "model": rp.model_id, "checkpoint": rp.checkpoint_sha256,
                  "max_steps": config.max_steps, "metrics": config.metrics.model_dump(mode="json"),
                  "taxonomy": config.taxonomy.model_dump(mode="json")})
    return list(prep.pairs), fp


def campaign_work(config: CampaignConfig, plan: CampaignPlan) -> tuple[list[tuple[int, Pair]], str]:
    """(work list, fingerprint) of a campaign: (cell index, episode) for every cell in grid order."""
    union = suite_union(plan.hard, plan.glob)
    work = [(c, pair) for c in range(len(plan.cells)) for pair in union]
    cells = [{"checkpoint": ck, "planner": rp.config_hash, "model": rp.model_id, "sha256": rp.checkpoint_sha256}
             for ck, rp in plan.cells]
    fp = _digest({"stage": "campaign", "bundle": config.bundle, "matrix": config.matrix, "hard": plan.hard,
                  "global": plan.glob, "cells": cells, "max_steps": config.max_steps,
                  "metrics": config.metrics.model_dump(mode="json"), "taxonomy": config.taxonomy.model_dump(mode="json")})
    return work, fp


# ------------------------------------------------------------------------------ running one shard


def _write_shard(ctx: StageContext, stage: str, shard: ShardRef, fingerprint: str, total: int, items: list[int],
                 records: list[EpisodeRecord], t0: float) -> ShardResult:
    write_records(ctx.artifact(RECORDS_FILE), records)
    result = ShardResult(stage=stage, index=shard.index, count=shard.count, fingerprint=fingerprint, total=total,
                         items=items, episodes=len(records), outcomes=dict(Counter(r.outcome for r in records)),
                         code_version=code_version(), wall_s=time.perf_counter() - t0)
    files.write_text(ctx.artifact(SHARD_FILE), result.model_dump_json(indent=2))
    return result


def _progress(ctx: StageContext, shard: ShardRef) -> Any:
    def progress(done: int, total: int, rec: EpisodeRecord) -> None:
        ctx.progress(done / total, f"shard {shard.index + 1}/{shard.count}: {rec.scenario} seed {rec.seed}: {rec.outcome}")

    return progress


def run_evaluation_shard(config: EvaluationShardConfig, ctx: StageContext) -> ShardResult:
    """Run this shard's slice of an evaluation's episodes; writes shard.json and shard_episodes.jsonl."""
    t0 = time.perf_counter()
    prep = prepare_evaluation(config, ctx)
    work, fp = evaluation_work(config, prep)
    items = shard_items(len(work), config.shard.index, config.shard.count)
    jobs = [Job(k, *work[g], prep.planner) for k, g in enumerate(items)]
    ctx.progress(0.0, f"shard {config.shard.index + 1}/{config.shard.count}: {len(jobs)} of {len(work)} episodes")
    records = run_jobs(jobs, prep.settings, ctx, matrix=prep.matrix, start_method=config.start_method,
                       executor=config.executor, on_record=_progress(ctx, config.shard))
    return _write_shard(ctx, "evaluate", config.shard, fp, len(work), items, records, t0)


def run_campaign_shard(config: CampaignShardConfig, ctx: StageContext) -> ShardResult:
    """Run this shard's slice of a campaign's (cell, episode) work list; writes shard.json and its records."""
    t0 = time.perf_counter()
    plan = prepare_campaign(config, ctx)
    work, fp = campaign_work(config, plan)
    items = shard_items(len(work), config.shard.index, config.shard.count)
    jobs = [Job(k, *work[g][1], plan.cells[work[g][0]][1]) for k, g in enumerate(items)]
    ctx.progress(0.0, f"shard {config.shard.index + 1}/{config.shard.count}: {len(jobs)} of {len(work)} episodes")
    records = run_jobs(jobs, plan.settings, ctx, matrix=plan.matrix, start_method=config.start_method,
                       executor=config.executor, on_record=_progress(ctx, config.shard))
    return _write_shard(ctx, "campaign", config.shard, fp, len(work), items, records, t0)


def read_shard(folder: str | Path) -> tuple[ShardResult, list[EpisodeRecord]]:
    """A finished shard's result and records from its folder."""
    folder = Path(folder)
    part = ShardResult.model_validate_json((folder / SHARD_FILE).read_text())
    return part, read_records(folder / RECORDS_FILE)  # never a name read from the file: it stays in the folder


# ------------------------------------------------------------------------------ merging


def merge_records(parts: list[tuple[ShardResult, list[EpisodeRecord]]], expected: list[Pair], fingerprint: str,
                  stage: str) -> list[EpisodeRecord]:
    """Every shard's records in work-list order (pure). Refuses shards of another run (fingerprint), shards that
    do not cover the work list exactly once, and records of an episode other than the item's."""
    total = len(expected)
    out: list[EpisodeRecord | None] = [None] * total
    counts = {p.count for p, _ in parts}
    if len(counts) > 1:
        raise CoreError(f"{stage} shards disagree on the shard count: {sorted(counts)}")
    for part, records in parts:
        name = f"{stage} shard {part.index + 1}/{part.count}"
        if part.stage != stage or part.fingerprint != fingerprint or part.total != total:
            raise CoreError(f"{name} ran another work list (its config, bundle or models changed): run it again")
        if part.items != shard_items(total, part.index, part.count) or len(records) != len(part.items):
            raise CoreError(f"{name} holds {len(records)} records for {len(part.items)} items, not its slice")
        for g, rec in zip(part.items, records, strict=True):
            if out[g] is not None:
                raise CoreError(f"{name}: episode {g} is in two shards")
            if (rec.scenario, rec.seed) != tuple(expected[g]):
                raise CoreError(f"{name}: item {g} is {rec.scenario} seed {rec.seed}, expected {expected[g]}")
            out[g] = rec
    missing = [g for g, r in enumerate(out) if r is None]
    if missing:
        raise CoreError(f"{stage} shards miss {len(missing)} of {total} episodes (first: {expected[missing[0]]})")
    return out  # type: ignore[return-value]


def merge_evaluation_shards(config: EvaluationConfig, parts: list[tuple[ShardResult, list[EpisodeRecord]]],
                            ctx: StageContext, t0: float | None = None) -> EvaluationResult:
    """The evaluation result of its shards, as :func:`run_evaluation` would return it; writes the same
    artifacts (evaluation.json, episodes.jsonl). ``t0``: when the sharded run started (for ``wall_s``)."""
    t0 = time.perf_counter() if t0 is None else t0
    prep = prepare_evaluation(config, ctx)
    work, fp = evaluation_work(config, prep)
    records = merge_records(parts, work, fp, "evaluate")
    _note_versions(parts, ctx)
    return finish_evaluation(config, records, prep, ctx, t0)


def merge_campaign_shards(config: CampaignConfig, parts: list[tuple[ShardResult, list[EpisodeRecord]]],
                          ctx: StageContext, t0: float | None = None) -> CampaignResult:
    """The campaign result of its shards, as :func:`run_campaign` would return it; writes the same artifacts
    (cells/, campaign_summary.json, campaign_report.md). Every cell counts as run."""
    t0 = time.perf_counter() if t0 is None else t0
    plan = prepare_campaign(config, ctx)
    work, fp = campaign_work(config, plan)
    records = merge_records(parts, [pair for _, pair in work], fp, "campaign")
    _note_versions(parts, ctx)
    n = len(suite_union(plan.hard, plan.glob))
    cells = [finish_cell(config, ctx, rp, plan.hard, plan.glob, records[c * n:(c + 1) * n], plan.cell_key(c),
                         cell_fingerprint(config, plan, c), ck)
             for c, (ck, rp) in enumerate(plan.cells)]
    return campaign_result(config, ctx, plan, cells, len(cells), t0)


def _note_versions(parts: list[tuple[ShardResult, list[EpisodeRecord]]], ctx: StageContext) -> None:
    versions = sorted({p.code_version for p, _ in parts})
    if len(versions) > 1:  # each record names its own code version; say so where a reader looks first
        ctx.log(f"shards ran different code versions: {versions}")
