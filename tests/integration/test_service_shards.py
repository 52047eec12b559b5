"""A sharded evaluation shared by two worker processes behind a real server (SQLite file, and PostgreSQL): both
run shards, and the merged evaluation read back over HTTP equals the unsharded one."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from tests.results import without

from .service import Service, wait_job

EVALUATE = {"kind": "evaluate", "scenarios": ["crossing_low", "head_on_corridor_high"], "seeds_per_scenario": 4,
            "max_steps": 300, "planner": {"name": "goal"}}
#: wall-clock values: planner timing, run time, the code version
NOISE = {"wall_s", "code_version", "plan_ms_mean", "plan_ms_p95"}


def _strip(data: Any) -> Any:
    return without(data, NOISE)


def test_two_workers_share_a_sharded_evaluation(service: Service) -> None:
    _share(service)


def test_two_workers_share_a_sharded_evaluation_on_postgres(tmp_path: Path, pg_url: str) -> None:
    service = Service(tmp_path, database_url=pg_url)
    try:
        _share(service)
    finally:
        service.stop()


def _share(service: Service) -> None:
    service.migrate()
    service.serve()
    workers = [service.worker(), service.worker()]
    with service.client() as client:
        whole = wait_job(client, client.post("/v1/jobs", json={"spec": EVALUATE}).json()["id"], timeout=120)
        assert whole["status"] == "succeeded", service.logs()
        resp = client.post("/v1/jobs", json={"spec": {**EVALUATE, "shards": 4}})
        assert resp.status_code == 201, resp.text
        parent = wait_job(client, resp.json()["id"], timeout=120)
        assert parent["status"] == "succeeded", (parent["error"], service.logs())
        assert parent["progress"] == 1.0 and len(parent["children"]) == 4

        shards = [client.get(f"/v1/jobs/{cid}").json() for cid in parent["children"]]
        assert {(s["kind"], s["status"], s["parent_id"]) for s in shards} == {("evaluate_shard", "succeeded", parent["id"])}
        # both worker processes ran shards: the parent's worker in its own slot ("<id>/shards"), the other by claiming
        ran_by = {s["worker"].split("/")[0] for s in shards}
        pids = {int(w.split("-")[-2]) for w in ran_by}
        assert pids == {w.pid for w in workers}, [s["worker"] for s in shards]

        merged = client.get(f"/v1/evaluations/{parent['id']}")
        assert merged.status_code == 200, merged.text
        alone = client.get(f"/v1/evaluations/{whole['id']}").json()
        merged = merged.json()
        assert merged["metrics"]["episodes"] == 8
        assert _strip(merged["metrics"]) == _strip(alone["metrics"])
        assert _strip(merged["per_scenario"]) == _strip(alone["per_scenario"])
        assert merged["taxonomy"] == alone["taxonomy"]
        names = {a["name"] for a in parent["artifacts"]}
        assert {"evaluation.json", "episodes.jsonl", "report.html"} <= names
