"""End to end through `foresight up` (migrate + server + worker) and the CLI client."""

from __future__ import annotations

import json
import signal
import time

from .service import Service, tiny_model_job, wait_job


def test_up_submit_follow_and_read_back(service: Service) -> None:
    service.serve("up", "--concurrency", "2")
    spec = service.tmp / "spec.yaml"
    spec.write_text("seconds: 0.6\nsteps: 3\nartifact: out/hello.txt\n")

    done = json.loads(service.cli("submit", "sleep", "-f", str(spec), "--wait", "--json").stdout)
    assert done["status"] == "succeeded" and done["result"] == {"slept_s": 0.6}
    shown = json.loads(service.cli("jobs", "show", done["id"], "--json").stdout)
    assert [a["name"] for a in shown["artifacts"]] == ["out/hello.txt"]
    logs = service.cli("jobs", "logs", done["id"]).stdout
    assert "step 3/3" in logs and "job ended: succeeded" in logs
    out = service.tmp / "hello.txt"
    service.cli("jobs", "download", done["id"], "out/hello.txt", "-o", str(out))
    assert out.read_text().startswith("slept")

    # a failing job: exit 1 and the error in the record
    bad = service.tmp / "fail.yaml"
    bad.write_text("fail: on purpose\n")
    failed = service.cli("submit", "sleep", "-f", str(bad), "--wait", "--json", check=False)
    assert failed.returncode == 1 and json.loads(failed.stdout)["error"]["type"] == "RuntimeError"
    # invalid input: one readable line, nothing stored
    neg = service.tmp / "neg.yaml"
    neg.write_text("seconds: -1\n")
    refused = service.cli("submit", "sleep", "-f", str(neg), check=False)
    assert refused.returncode == 1 and "HTTP 422" in refused.stderr and "seconds" in refused.stderr
    assert len(refused.stderr.strip().splitlines()) == 1

    with service.client() as client:
        # a simulate stage job: one episode of the builtin matrix, read back as JSON
        body = {"spec": {"kind": "simulate", "scenarios": ["crossing_low"], "seeds": [1000], "render": False}}
        sim = client.post("/v1/jobs", json=body)
        assert sim.status_code == 201, sim.text
        result = wait_job(client, sim.json()["id"])
        assert result["status"] == "succeeded", result
        assert result["result"]["episodes"][0]["scenario"] == "crossing_low"
        summary = client.get(f"/v1/jobs/{result['id']}/artifacts/simulate.json")
        assert summary.status_code == 200 and summary.json()["episodes"][0]["seed"] == 1000

        # an evaluation: submitted over HTTP, run by the worker, read back as JSON (with its taxonomy)
        body = {
            "spec": {
                "kind": "evaluate",
                "scenarios": ["crossing_low"],
                "seeds_per_scenario": 1,
                "max_steps": 50,
                "planner": {"name": "goal"},
            }
        }
        ev = wait_job(client, client.post("/v1/jobs", json=body).json()["id"])
        assert ev["status"] == "succeeded", ev
        evaluation = client.get(f"/v1/evaluations/{ev['id']}").json()
        assert evaluation["metrics"]["episodes"] == 1 and evaluation["bundle_id"] == "builtin"
        assert evaluation["per_scenario"][0]["key"] == "crossing_low"

        # the registry: register the first job's artifact, promote it, read it back
        text = client.post(
            "/v1/models", json={"id": "demo-model", "job_id": done["id"], "artifact": "out/hello.txt"}
        )
        assert (
            text.status_code == 422 and "not a readable checkpoint" in text.text
        )  # only checkpoints register
        trained = tiny_model_job(client)
        reg = client.post("/v1/models", json={"id": "demo-model", "job_id": trained, "artifact": "model.pt"})
        assert reg.status_code == 201, reg.text
        assert (
            client.post(
                "/v1/models", json={"id": "demo-model", "job_id": trained, "artifact": "model.pt"}
            ).status_code
            == 409
        )
        assert (
            client.post("/v1/models/demo-model/promote", json={"to": "default"}).json()["status"] == "default"
        )
        assert client.delete("/v1/models/demo-model").status_code == 409
        listed = {m["id"]: m for m in client.get("/v1/models").json()["data"]}
        assert "demo-model" in listed and listed["demo-model"]["status"] == "default"
        assert listed["predictor-sim-default"]["read_only"] is True  # shipped in model/registry.yaml
        listed = json.loads(service.cli("jobs", "ls", "--kind", "sleep", "--json").stdout)
        assert listed["count"] == 2
        assert "demo-model" in service.cli("models", "export").stdout

        workers = client.get("/v1/workers").json()
        assert workers["count"] == 1 and workers["data"][0]["concurrency"] == 2
        assert workers["queue"]["sleep"] == {"succeeded": 1, "failed": 1}

    up = service.procs[0]
    up.send_signal(signal.SIGTERM)
    assert up.wait(timeout=30) == 0
    with service.client() as _:
        pass
    from foresight.store.session import make_engine

    engine = make_engine(f"sqlite:///{service.tmp / 'data' / 'foresight.db'}")
    with engine.connect() as conn:
        stopped = conn.exec_driver_sql("SELECT stopped_at FROM workers").scalars().all()
    assert stopped and all(s is not None for s in stopped)  # the worker child was stopped cleanly


def test_cancel_and_retry_through_the_cli(service: Service) -> None:
    service.migrate()
    service.serve()
    service.worker()
    with service.client() as client:
        job_id = client.post(
            "/v1/jobs", json={"spec": {"kind": "sleep", "seconds": 60, "steps": 600}}
        ).json()["id"]
        deadline = time.time() + 30
        while client.get(f"/v1/jobs/{job_id}").json()["status"] != "running" and time.time() < deadline:
            time.sleep(0.1)
        t0 = time.time()
        service.cli("jobs", "cancel", job_id)
        assert wait_job(client, job_id, timeout=10)["status"] == "cancelled"
        assert time.time() - t0 < 4.0  # noticed within ~2 s (+ the CLI's start-up)
        again = json.loads(service.cli("jobs", "retry", job_id, "--json").stdout)
        assert again["status"] == "queued"
        client.post(f"/v1/jobs/{job_id}/cancel")
        waited = service.cli("jobs", "wait", job_id, "--json", check=False)
        assert waited.returncode == 1 and json.loads(waited.stdout)["status"] == "cancelled"
        service.cli("jobs", "delete", job_id)
        assert client.get(f"/v1/jobs/{job_id}").status_code == 404
