"""The witness search as a job, through a real `foresight up`: an evaluation named by its id, its failures searched
under its own conditions, each witness played beside the planner's run from the job's folder."""

from __future__ import annotations

import time

from .service import Service, wait_job


def test_an_evaluations_failures_get_witnesses_as_a_job(service: Service) -> None:
    service.serve("up", "--concurrency", "2")
    with service.client() as client:
        body = {
            "spec": {
                "kind": "evaluate",
                "scenarios": ["crossing_medium"],
                "seeds_per_scenario": 3,
                "scenario_overrides": {"simulation_config": {"ped_speed_tier": "typical"}},
                "planner": {"name": "goal"},
            }
        }
        ev = wait_job(client, client.post("/v1/jobs", json=body).json()["id"])
        assert ev["status"] == "succeeded", ev
        episodes = client.get(f"/v1/evaluations/{ev['id']}/episodes").json()
        failed = [(e["scenario"], e["seed"]) for e in episodes if e["outcome"] != "success"]
        assert failed  # the goal-seeking robot walks into the stream

        # an unknown evaluation: refused before anything is queued
        missing = client.post("/v1/jobs", json={"spec": {"kind": "witness", "evaluation": "no-such-job"}})
        assert missing.status_code == 404 and "no-such-job" in missing.text
        unknown = client.post(
            "/v1/jobs", json={"spec": {"kind": "witness", "scenarios": ["no_such_scenario"]}}
        )
        assert unknown.status_code == 404 and "no_such_scenario" in unknown.text
        listed_before = client.get("/v1/jobs", params={"kind": "witness"}).json()["count"]
        assert listed_before == 0  # nothing queued by the refused submissions
        bad = client.post("/v1/jobs", json={"spec": {"kind": "witness", "settings": {"max_plans": 0}}})
        assert bad.status_code == 422 and "max_plans" in bad.text

        spec = {"kind": "witness", "evaluation": ev["id"], "settings": {"max_plans": 80}, "players": True}
        job = wait_job(client, client.post("/v1/jobs", json={"spec": spec}).json()["id"], timeout=240)
        assert job["status"] == "succeeded", job
        r = job["result"]
        # the evaluation's matrix, conditions and failures, in its order
        assert (
            r["matrix"] == "scenarios/classic_interactions.yaml"
            and r["failed_only"]
            and r["evaluation"] == ev["id"]
        )
        assert r["overrides"] == {"simulation_config": {"ped_speed_tier": "typical"}}
        assert [(e["scenario"], e["seed"]) for e in r["episodes"]] == failed
        found = [e for e in r["episodes"] if e["plan"] is not None]
        assert r["witnessed"] == len(found) >= 1 and all(e["player"] for e in found)
        page = client.get(f"/v1/jobs/{job['id']}/artifacts/{found[0]['player']}")
        assert page.status_code == 200 and "witness: " in page.text and "planner: " in page.text
        # the witness's run as the player draws it, beside the evaluation's own trace of the episode
        scenario, seed = found[0]["scenario"], found[0]["seed"]
        trace = client.get(f"/v1/jobs/{job['id']}/witnesses/{scenario}/{seed}")
        assert trace.status_code == 200 and trace.json()["steps"] * 0.1 == found[0]["arrival_s"]
        assert client.get(f"/v1/jobs/{job['id']}/witnesses/{scenario}/99999").status_code == 404
        assert (
            client.get(f"/v1/jobs/{ev['id']}/witnesses/{scenario}/{seed}").status_code == 404
        )  # not a witness job
        report = client.get(f"/v1/jobs/{job['id']}/artifacts/report.html")
        assert report.status_code == 200 and f'href="{found[0]["player"]}"' in report.text
        # the witness replays as any run: the scripted planner under the same conditions arrives when it said
        replay = {"spec": {**body["spec"], "planner": {"name": "scripted", "config": found[0]["plan"]}}}
        again = wait_job(client, client.post("/v1/jobs", json=replay).json()["id"])
        rows = client.get(f"/v1/evaluations/{again['id']}/episodes").json()
        (row,) = [e for e in rows if (e["scenario"], e["seed"]) == (found[0]["scenario"], found[0]["seed"])]
        assert row["outcome"] == "success" and row["steps"] * 0.1 == found[0]["arrival_s"]

        # a long search (every doorway episode, up to 2,000 plans each) stops within seconds of a cancel
        long = {"kind": "witness", "scenarios": ["doorway_high"], "seeds_per_scenario": 10}
        job_id = client.post("/v1/jobs", json={"spec": long}).json()["id"]
        deadline = time.time() + 60
        while client.get(f"/v1/jobs/{job_id}").json()["status"] != "running" and time.time() < deadline:
            time.sleep(0.1)
        time.sleep(1.0)  # searching
        asked = time.time()
        client.post(f"/v1/jobs/{job_id}/cancel")
        assert wait_job(client, job_id, timeout=15)["status"] == "cancelled"
        assert time.time() - asked < 10
