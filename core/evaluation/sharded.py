"""Sharded evaluations and campaigns in the service: a parent job, its shard jobs, the merge.

An ``evaluate`` or ``campaign`` job whose spec says ``shards: N`` (N > 1) becomes a parent. It submits N child
jobs of kind ``evaluate_shard`` / ``campaign_shard``: the parent's config as given plus ``shard: {index, count}``,
under the idempotency key ``shard:<parent id>:<index>/<count>``. Shards are kinds of their own rather than the
same kind with a field because a shard's result is a partial (a :class:`~core.evaluation.shards.ShardResult`
and its records, no evaluation/campaign rows, no report), never to be mistaken for a whole run. Any worker may
claim a shard; the parent runs still-queued shards in its own slot and waits for those other workers took
(``ctx.children``, the child-job facility the pipeline uses too), so one worker with one slot finishes a sharded
run alone.
Its progress is the mean of its shards' progress. Then it merges the shards in core
(:func:`~core.evaluation.shards.merge_evaluation_shards` / ``merge_campaign_shards``) into the result, artifacts,
report and records an unsharded run produces.

Cancelling the parent cancels its shards. A retried parent finds its shards by key: succeeded shards are not run
again (a campaign resumes at shard granularity), failed or cancelled ones are retried.
"""

from __future__ import annotations

import time
from typing import Any

from pydantic import BaseModel, ValidationError

from foresight.core.errors import CoreError
from foresight.core.evaluation.shards import merge_campaign_shards, merge_evaluation_shards, read_shard
from foresight.core.stages.context import StageContext

#: parent kind -> its shard kind (both in core.stages.kinds)
SHARD_KINDS = {"evaluate": "evaluate_shard", "campaign": "campaign_shard"}
SUCCEEDED, RUNNING = "succeeded", "running"  #: job statuses (the store's queue)


def run_sharded(kind: str, config: Any, ctx: StageContext) -> BaseModel:
    """Run the ``kind`` stage's ``config`` (with ``config.shards`` > 1) as shard jobs and merge them."""
    t0 = time.perf_counter()
    count = int(config.shards)
    shard_kind = SHARD_KINDS[kind]
    runner = ctx.children("shards", ctx.workers)
    try:
        body = config.model_dump(mode="json")
        ids = []
        for i in range(count):
            spec = {**body, "shard": {"index": i, "count": count}}
            job, _ = runner.submit(f"shard {i + 1}/{count}", shard_kind, spec, key=f"shard:{runner.parent_id}:{i}/{count}")
            ids.append(job["id"])
        ctx.log(f"{kind} split into {count} {shard_kind} jobs")
        fractions = dict.fromkeys(ids, 0.0)

        def report(message: str) -> None:
            done = sum(1 for f in fractions.values() if f >= 1.0)
            ctx.progress(0.99 * sum(fractions.values()) / count, f"shards {done}/{count} done; {message}"[:2000])

        def on_wait(rows: dict[str, dict[str, Any]]) -> None:
            for cid, row in rows.items():
                fractions[cid] = 1.0 if row["status"] == SUCCEEDED else float(row["progress"] or 0.0)
            report(f"{sum(r['status'] == RUNNING for r in rows.values())} running")

        def on_progress(child_id: str, fraction: float, message: str) -> None:
            fractions[child_id] = float(fraction)
            report(message)

        runner.run(f"{kind} shards", ids, on_progress=on_progress, on_wait=on_wait)
    finally:
        runner.close()
    ctx.progress(0.99, f"merging {count} shards")
    parts = []
    for cid in ids:
        try:
            parts.append(read_shard(runner.folder(cid)))
        except (OSError, ValidationError) as exc:
            raise CoreError(f"{shard_kind} job {cid}: its shard files cannot be read ({exc})") from None
    merge = merge_evaluation_shards if kind == "evaluate" else merge_campaign_shards
    return merge(config, parts, ctx, t0)
