"""Chaos on PostgreSQL (issue 15): workers SIGKILLed at random moments during a sharded evaluation, and the
server SIGKILLed during a burst of submissions. Every acknowledged job and every episode record must exist
exactly once afterwards."""

from __future__ import annotations

import json
import random
import signal
import threading
import time
from collections import Counter
from pathlib import Path

import httpx

from .service import Service, wait_job

EVALUATE = {"kind": "evaluate", "scenarios": ["crossing_low", "head_on_corridor_high"], "seeds_per_scenario": 4,
            "max_steps": 300, "planner": {"name": "goal"}, "shards": 4}


def _all_jobs(client: httpx.Client) -> list[dict]:
    out, offset = [], 0
    while True:
        page = client.get("/v1/jobs", params={"limit": 500, "offset": offset}).json()
        out += page["data"]
        offset += len(page["data"])
        if not page["data"] or offset >= page["count"]:
            return out


def test_server_killed_during_submissions_loses_and_doubles_nothing(tmp_path: Path, pg_url: str) -> None:
    service = Service(tmp_path, database_url=pg_url)
    rng = random.Random(15)
    acked: dict[str, str] = {}
    tried: list[str] = []
    try:
        service.migrate()
        for burst in range(3):
            service.serve()
            server = service.procs[-1]
            stop = threading.Event()

            def submit(burst: int = burst, url: str = service.url, stop: threading.Event = stop) -> None:
                with httpx.Client(base_url=url, headers={"Authorization": "Bearer integration-token"}, timeout=5) as c:
                    i = 0
                    while not stop.is_set():
                        key = f"chaos-{burst}-{i}"
                        tried.append(key)
                        try:
                            r = c.post("/v1/jobs", json={"spec": {"kind": "sleep"}, "idempotency_key": key})
                        except httpx.HTTPError:
                            return  # the server is gone
                        if r.status_code in (200, 201):
                            acked[key] = r.json()["id"]
                        i += 1

            threads = [threading.Thread(target=submit) for _ in range(4)]
            for t in threads:
                t.start()
            time.sleep(rng.uniform(0.5, 2.0))
            server.send_signal(signal.SIGKILL)
            server.wait()
            stop.set()
            for t in threads:
                t.join(timeout=30)
        service.serve()
        with service.client() as client:
            for key in tried:  # a client retries what it never saw acknowledged: still exactly once
                if key not in acked:
                    r = client.post("/v1/jobs", json={"spec": {"kind": "sleep"}, "idempotency_key": key})
                    assert r.status_code in (200, 201), r.text
                    acked[key] = r.json()["id"]
            rows = _all_jobs(client)
        keys = Counter(r["idempotency_key"] for r in rows)
        assert len(acked) > 20, len(acked)
        assert all(n == 1 for n in keys.values()), [k for k, n in keys.items() if n > 1]
        by_key = {r["idempotency_key"]: r["id"] for r in rows}
        assert all(by_key.get(k) == job_id for k, job_id in acked.items())
    finally:
        service.stop()


def test_workers_killed_at_random_during_a_sharded_evaluation(tmp_path: Path, pg_url: str) -> None:
    service = Service(tmp_path, database_url=pg_url)
    rng = random.Random(7)
    try:
        service.migrate()
        service.serve()
        workers = [service.worker(), service.worker()]
        with service.client() as client:
            resp = client.post("/v1/jobs", json={"spec": EVALUATE})
            assert resp.status_code == 201, resp.text
            parent_id = resp.json()["id"]
            kills = 0
            deadline = time.time() + 60
            while kills < 3 and time.time() < deadline:
                time.sleep(rng.uniform(1.0, 4.0))
                if client.get(f"/v1/jobs/{parent_id}").json()["status"] not in ("queued", "running"):
                    break
                victim = workers.pop(rng.randrange(len(workers)))
                victim.send_signal(signal.SIGKILL)
                victim.wait()
                workers.append(service.worker())
                kills += 1
            parent = wait_job(client, parent_id, timeout=300)
            assert parent["status"] == "succeeded", (parent["error"], service.logs())
            assert kills >= 1
            records = [json.loads(line) for line in
                       client.get(f"/v1/jobs/{parent_id}/artifacts/episodes.jsonl").text.splitlines() if line.strip()]
            episodes = Counter((r["scenario"], r["seed"]) for r in records)
            assert len(episodes) == 8 and set(episodes.values()) == {1}, episodes
            assert client.get(f"/v1/evaluations/{parent_id}").json()["metrics"]["episodes"] == 8  # one row per job id
            for child in parent["children"]:
                shard = client.get(f"/v1/jobs/{child}").json()
                assert shard["status"] == "succeeded" and shard["error"] is None, shard
    finally:
        service.stop()
