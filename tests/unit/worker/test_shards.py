"""Sharded evaluate/campaign jobs on a real SQLite file with real worker threads: one one-slot worker runs a
sharded run alone (no deadlock) with the unsharded result; retry reuses succeeded shards; cancel cancels them."""

from __future__ import annotations

import json
import time
from typing import Any

import pytest
from sqlalchemy import select

from foresight.store import folders, queue, results
from foresight.store.models import Campaign, CampaignCell, Evaluation
from foresight.store.registry import sync_bundles
from tests.results import without

#: wall-clock values: planner timing, run time, the code version (the git head moves while tests run)
NOISE = {"wall_s", "code_version", "fingerprint", "plan_ms_mean", "plan_ms_p95", "shards"}

EVALUATE = {"kind": "evaluate", "scenarios": ["crossing_low", "head_on_corridor_high"], "seeds_per_scenario": 3,
            "max_steps": 30, "planner": {"name": "goal"}}
CAMPAIGN = {"kind": "campaign", "seed_manifest": "seeds/classic_eval_hard_smoke.yaml", "scenarios": ["crossing_medium"],
            "seeds_per_scenario": 1, "max_steps": 10, "checkpoints": ["cv"], "gate": {"baseline_variant": "base"},
            "variants": [{"name": "base", "config": {}}, {"name": "slow", "config": {"max_speed_ratio": 0.5}}]}


@pytest.fixture(autouse=True)
def _builtin_bundle(settings, engine) -> None:  # noqa: ANN001 - as the server registers it at start-up
    sync_bundles(engine, settings)


def _strip(data: Any) -> Any:
    return without(data, NOISE)


def _wait(engine, job_id: str, statuses: set[str], timeout: float = 60.0) -> dict:  # noqa: ANN001
    deadline = time.time() + timeout
    while time.time() < deadline:
        job = queue.get_job(engine, job_id)
        if job["status"] in statuses:
            return job
        time.sleep(0.05)
    raise AssertionError(f"job {job_id} still {job['status']}: {job['message']}")


def _submit(engine, spec: dict) -> str:  # noqa: ANN001
    return queue.submit(engine, kind=spec["kind"], spec=spec)[0]["id"]


def _children(engine, parent_id: str) -> list[dict]:  # noqa: ANN001
    with engine.connect() as conn:
        rows = conn.execute(select(queue.jobs).where(queue.jobs.c.parent_id == parent_id)).mappings()
        return sorted((dict(r) for r in rows), key=lambda r: r["idempotency_key"])


def test_one_worker_runs_a_sharded_evaluation_alone_with_the_unsharded_result(settings, engine, start_worker) -> None:  # noqa: ANN001
    start_worker(concurrency=1)
    whole = _wait(engine, _submit(engine, EVALUATE), {"succeeded", "failed"})
    parent_id = _submit(engine, {**EVALUATE, "shards": 4})
    parent = _wait(engine, parent_id, {"succeeded", "failed"})
    assert parent["status"] == "succeeded", parent["error_message"]
    assert parent["progress"] == 1.0
    assert _strip(parent["result"]) == _strip(whole["result"])
    assert parent["result"]["config"]["shards"] == 4 and parent["result"]["episodes"] == 6

    shards = _children(engine, parent_id)
    assert [s["idempotency_key"] for s in shards] == [f"shard:{parent_id}:{i}/4" for i in range(4)]
    assert {(s["kind"], s["status"], s["attempts"]) for s in shards} == {("evaluate_shard", "succeeded", 1)}
    assert all(s["lease_owner"].endswith("/shards") for s in shards)  # run in the parent's own slot
    assert sorted(i for s in shards for i in s["result"]["items"]) == list(range(6))
    progress = [e["message"] for e in queue.events_after(engine, parent_id, 0) if e["type"] == "progress"]
    assert any(m.startswith("shards ") and "/4 done" in m for m in progress), progress  # the parent follows its shards

    with engine.connect() as conn:  # the evaluation record, as an unsharded job writes it
        rows = {r.id: r for r in conn.execute(select(Evaluation).where(Evaluation.id.in_([whole["id"], parent_id])))}
        names = {r.name for r in conn.execute(select(queue.artifacts).where(queue.artifacts.c.job_id == parent_id))}
    assert _strip(rows[parent_id].metrics) == _strip(rows[whole["id"]].metrics)
    assert _strip(rows[parent_id].per_scenario) == _strip(rows[whole["id"]].per_scenario)
    assert {"evaluation.json", "episodes.jsonl", "report.html"} <= names
    folder = folders.resolve_under(settings.store_root, folders.job_dir(settings.store_root, parent_id))
    assert len((folder / "episodes.jsonl").read_text().splitlines()) == 6
    # every episode's trace (written by the shard that ran it) is found through the parent's evaluation
    from foresight.core.evaluation.episode_trace import trace_name
    from foresight.core.evaluation.runner import read_records

    for rec in read_records(folder / "episodes.jsonl"):
        path = results.episode_trace_file(engine, settings.store_root, parent_id, trace_name(rec.scenario, rec.seed))
        assert path is not None and path.parent.parent.name != parent_id  # in a shard's folder


def test_one_worker_runs_a_sharded_campaign_alone_with_the_unsharded_ranking(engine, start_worker) -> None:  # noqa: ANN001
    start_worker(concurrency=1)
    whole = _wait(engine, _submit(engine, CAMPAIGN), {"succeeded", "failed"})
    assert whole["status"] == "succeeded", whole["error_message"]
    parent_id = _submit(engine, {**CAMPAIGN, "shards": 3})
    parent = _wait(engine, parent_id, {"succeeded", "failed"})
    assert parent["status"] == "succeeded", parent["error_message"]
    assert _strip(parent["result"]) == _strip(whole["result"])
    assert [s["kind"] for s in _children(engine, parent_id)] == ["campaign_shard"] * 3
    with engine.connect() as conn:
        best = dict(conn.execute(select(Campaign.id, Campaign.best)).all())
        cells = conn.execute(select(CampaignCell.campaign_id, CampaignCell.rank, CampaignCell.params,
                                    CampaignCell.metrics)).all()
    assert _strip(best[parent_id]) == _strip(best[whole["id"]])
    ranked = {cid: [(rank, params, json.dumps(_strip(m), sort_keys=True)) for c, rank, params, m in cells if c == cid]
              for cid in (parent_id, whole["id"])}
    assert ranked[parent_id] == ranked[whole["id"]] and len(ranked[parent_id]) == 2


def test_cancelling_the_parent_cancels_its_shards_and_a_retry_reuses_the_finished_ones(engine, start_worker) -> None:  # noqa: ANN001
    # a shard here runs in ~0.2 s; heartbeats every 20 ms notice the cancellation well before the last one ends
    # (with the default 0.2 s a parent may finish first: a cancellation that arrives too late is no cancellation)
    start_worker(concurrency=1, heartbeat_s=0.02)
    long = {**EVALUATE, "seeds_per_scenario": 6, "max_steps": 400, "shards": 3}
    parent_id = _submit(engine, long)
    deadline = time.time() + 60
    while time.time() < deadline:  # shard 1 done, shard 3 not started yet (the parent runs them one by one)
        statuses = [s["status"] for s in _children(engine, parent_id)]
        if len(statuses) == 3 and statuses[0] == "succeeded" and statuses[2] == "queued":
            break
        time.sleep(0.01)
    else:
        raise AssertionError(f"never saw shard 1 done with shard 3 queued: {statuses}")
    queue.request_cancel(engine, parent_id)
    assert _wait(engine, parent_id, {"succeeded", "failed", "cancelled"}, timeout=10)["status"] == "cancelled"
    shards = _children(engine, parent_id)
    statuses = [s["status"] for s in shards]
    assert statuses[0] == "succeeded" and statuses[-1] == "cancelled"  # the queued one too, not left to others
    assert set(statuses) == {"succeeded", "cancelled"}

    queue.retry(engine, parent_id)
    again = _wait(engine, parent_id, {"succeeded", "failed"})
    assert again["status"] == "succeeded" and again["result"]["episodes"] == 12
    after = _children(engine, parent_id)
    assert [s["status"] for s in after] == ["succeeded"] * 3
    for before, now in zip(shards, after, strict=True):  # succeeded shards are not run again
        assert (now["finished_at"] == before["finished_at"]) == (before["status"] == "succeeded")


def test_a_pipeline_stage_may_be_sharded(settings, engine) -> None:  # noqa: ANN001
    """The pipeline's evaluate child with shards: children of a child, all run in the pipeline's one slot."""
    from foresight.core.pipeline.config import load_pipeline_config
    from foresight.core.pipeline.service import ChildJobs
    from foresight.core.stages.refs import BUILTIN_CONFIG_ROOT
    from foresight.worker.runner import Held, JobWorker

    queue.submit(engine, kind="pipeline", spec={"kind": "pipeline"})
    job = queue.claim(engine, "worker-1", ["pipeline"], 30.0)
    workdir = folders.resolve_under(settings.store_root, folders.job_dir(settings.store_root, job["id"]))
    workdir.mkdir(parents=True)
    ctx = JobWorker(settings, engine, worker_id="worker-1").stage_context(Held(job, None), workdir)
    children = ChildJobs(ctx, load_pipeline_config(BUILTIN_CONFIG_ROOT / "pipelines" / "smoke.yaml"))
    try:
        spec = {k: v for k, v in EVALUATE.items() if k != "kind"}
        run = children("evaluate", "evaluate", {**spec, "shards": 2}, lambda fraction, message: None)
    finally:
        children.close()
    assert run.result["episodes"] == 6
    shards = _children(engine, run.job_id)
    assert [(s["status"], s["lease_owner"]) for s in shards] == [("succeeded", "worker-1/pipeline/shards")] * 2
