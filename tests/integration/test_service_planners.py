"""Bring your own planner over HTTP (`foresight up`: real server and worker processes): the installed toy plugin in a
campaign over two variants of its config, the reference external client through an operator-configured command,
crashing and hanging external planners as planner_error episodes, and the 422s of bad planner specs."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from .service import REPO, Service, wait_job

BAD = REPO / "tests" / "unit" / "planners" / "bad_external_planner.py"
SMALL = {"scenarios": ["crossing_low"], "seeds_per_scenario": 2}


def _episodes(client, job_id: str, name: str = "episodes.jsonl") -> list[dict]:  # noqa: ANN001
    text = client.get(f"/v1/jobs/{job_id}/artifacts/{name}").text
    return [json.loads(line) for line in text.splitlines()]


def _refused(client, planner: dict) -> str:  # noqa: ANN001
    r = client.post("/v1/jobs", json={"spec": {"kind": "evaluate", **SMALL, "planner": planner}})
    assert r.status_code == 422, r.text
    return r.text


def test_plugin_campaign_external_planners_and_bad_specs(tmp_path: Path) -> None:
    table = {
        "reference": [sys.executable, str(REPO / "examples" / "external_planner.py")],
        "crash": [sys.executable, str(BAD), "crash"],
        "hang": [sys.executable, str(BAD), "hang"],
    }
    service = Service(tmp_path, external_planners=json.dumps(table))
    try:
        service.serve("up", "--concurrency", "1")
        with service.client() as client:
            listed = client.get("/v1/planners").json()
            toy = next(p for p in listed["data"] if p["name"] == "toy")
            assert toy["origin"] == "plugin foresight-toy-planner 0.1.0" and not toy["takes_model"]
            assert {"speed", "caution_distance"} <= set(toy["config_schema"]["properties"])
            assert listed["external_commands"] == ["crash", "hang", "reference"]
            assert "python" not in json.dumps(listed)  # names only, never the operator's command lines
            assert json.loads(service.cli("planners", "--json").stdout) == listed

            # bad input: each a 422 naming what is wrong, nothing queued
            text = _refused(client, {"name": "dwa"})
            assert (
                "unknown planner 'dwa'" in text
                and "predictive, orca, social_force, goal, scripted, sb3, external" in text
            )
            assert "toy" in text
            assert "'rm -rf /' is not configured by the operator" in _refused(
                client, {"name": "external", "config": {"command": "rm -rf /"}}
            )
            text = _refused(client, {"name": "toy", "config": {"sped": 1.0}})
            assert '"toy","config","sped"' in text.replace(" ", "")
            text = _refused(
                client, {"name": "predictive", "model": "cv", "config": {"safety": {"colision_margin": 0.2}}}
            )
            assert '"config","safety","colision_margin"' in text.replace(" ", "")
            assert "in-process only" in _refused(
                client, {"name": "tests.unit.planners.user_planner:Cautious"}
            )
            assert client.get("/v1/jobs").json()["count"] == 0

            # the plugin in a campaign over two variants of its config
            body = {
                "spec": {
                    "kind": "campaign",
                    **SMALL,
                    "max_steps": 150,
                    "planner": {"name": "toy"},
                    "seed_manifest": "seeds/classic_eval_hard_smoke.yaml",
                    "variants": [
                        {"name": "slow", "config": {"speed": 0.5}},
                        {"name": "fast", "config": {"speed": 1.5}},
                    ],
                }
            }
            r = client.post("/v1/jobs", json=body)
            assert r.status_code == 201, r.text
            camp = wait_job(client, r.json()["id"], timeout=300)
            assert camp["status"] == "succeeded", (camp, service.logs())
            cells = {c["variant"]: c for c in camp["result"]["ranked"]}
            assert set(cells) == {"slow", "fast"}
            assert (
                cells["slow"]["planner"]["config"]["speed"] == 0.5
                and cells["fast"]["planner"]["config"]["speed"] == 1.5
            )
            assert cells["slow"]["planner"]["name"] == "toy" and cells["slow"]["checkpoint"] == "none"
            assert (
                cells["slow"]["planner"]["origin"] == "plugin foresight-toy-planner 0.1.0"
            )  # its version, recorded
            slow = _episodes(client, camp["id"], cells["slow"]["episodes_file"])
            fast = _episodes(client, camp["id"], cells["fast"]["episodes_file"])
            assert max(r["efficiency"]["avg_speed"] for r in slow) <= 0.5 + 1e-6
            assert max(r["efficiency"]["avg_speed"] for r in fast) > 0.5  # the variants really differ

            # the reference external client, through the operator's command
            body = {
                "spec": {
                    "kind": "evaluate",
                    **SMALL,
                    "max_steps": 400,
                    "planner": {"name": "external", "config": {"command": "reference"}},
                }
            }
            ev = wait_job(client, client.post("/v1/jobs", json=body).json()["id"], timeout=300)
            assert ev["status"] == "succeeded", (ev, service.logs())
            assert ev["result"]["episodes"] == 2 and ev["result"]["taxonomy"].get("planner_error", 0) == 0
            assert ev["result"]["success_rate"] > 0

            # a crashing and a hanging planner: planner_error episodes with the reason; the jobs end
            for mode, reason in (("crash", "exited (code 3) at step 2"), ("hang", "no answer within 0.5 s")):
                body = {
                    "spec": {
                        "kind": "evaluate",
                        **SMALL,
                        "max_steps": 100,
                        "planner": {"name": "external", "config": {"command": mode, "step_timeout_s": 0.5}},
                    }
                }
                job = wait_job(client, client.post("/v1/jobs", json=body).json()["id"], timeout=120)
                assert job["status"] == "succeeded", (job, service.logs())
                assert job["result"]["taxonomy"]["planner_error"] == 2
                assert all(
                    r["outcome"] == "error" and reason in r["error"] for r in _episodes(client, job["id"])
                )
    finally:
        service.stop()
