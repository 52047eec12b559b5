"""Chaos on PostgreSQL: workers SIGKILLed at random moments during a campaign, and the server SIGKILLed
during a burst of submissions. Every acknowledged job and every committed episode record must exist exactly once
afterwards (a reclaimed campaign resumes from its finished cells and runs each unfinished cell's episodes again,
whole)."""

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

#: six cells of ~10 short episodes each: several moments to be killed at, each a different amount of work done
CAMPAIGN = {
    "kind": "campaign",
    "scenarios": ["crossing_low", "head_on_corridor_high"],
    "seeds_per_scenario": 4,
    "max_steps": 300,
    "planner": {"name": "goal"},
    "seed_manifest": "seeds/classic_eval_hard_smoke.yaml",
    "variants": [{"name": f"speed{v}", "config": {"speed": v}} for v in (0.6, 0.8, 1.0, 1.2, 1.4, 1.6)],
}


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
                with httpx.Client(
                    base_url=url, headers={"Authorization": "Bearer integration-token"}, timeout=5
                ) as c:
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


def test_workers_killed_at_random_during_a_campaign(tmp_path: Path, pg_url: str) -> None:
    service = Service(tmp_path, database_url=pg_url)
    rng = random.Random(7)
    try:
        service.migrate()
        service.serve()
        workers = [service.worker(), service.worker()]
        with service.client() as client:
            resp = client.post("/v1/jobs", json={"spec": CAMPAIGN, "max_attempts": 5})  # 3 kills + a last run
            assert resp.status_code == 201, resp.text
            job_id = resp.json()["id"]
            kills = 0  #: of the worker running the campaign
            deadline = time.time() + 90
            while kills < 3 and time.time() < deadline:
                time.sleep(rng.uniform(1.0, 4.0))
                job = client.get(f"/v1/jobs/{job_id}").json()
                if job["status"] not in ("queued", "running"):
                    break
                # the worker running the campaign (its id holds its pid), else any: killed mid-cell or idle
                holder = [
                    w for w in workers if job["status"] == "running" and f"-{w.pid}-" in (job["worker"] or "")
                ]
                victim = holder[0] if holder else workers[rng.randrange(len(workers))]
                workers.remove(victim)
                victim.send_signal(signal.SIGKILL)
                victim.wait()
                workers.append(service.worker())
                kills += bool(holder)
            job = wait_job(client, job_id, timeout=300)
            assert job["status"] == "succeeded", (job["error"], service.logs())
            assert kills >= 1 and job["attempts"] >= 2  # killed mid-run at least once, then reclaimed
            result = job["result"]
            assert (
                result["cells_run"] + result["cells_resumed"] == 6
            )  # the last attempt ran only what was left
            expected = None
            for cell in result[
                "ranked"
            ]:  # every cell's episodes exactly once, the same episodes in every cell
                text = client.get(f"/v1/jobs/{job_id}/artifacts/{cell['episodes_file']}").text
                episodes = Counter(
                    (r["scenario"], r["seed"]) for r in map(json.loads, text.splitlines()) if r
                )
                assert set(episodes.values()) == {1}, (cell["key"], episodes)
                assert expected in (None, set(episodes)), cell["key"]
                expected = set(episodes)
            record = client.get(f"/v1/campaigns/{job_id}").json()  # one campaign row, one row per cell
            assert sorted(c["params"]["variant"] for c in record["cells"]) == sorted(
                v["name"] for v in CAMPAIGN["variants"]
            )
    finally:
        service.stop()
