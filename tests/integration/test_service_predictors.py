"""Bring your own predictor over HTTP (`foresight up`: real server and worker processes): the installed example
plug-in and the reference external client drive the planner in evaluate jobs and are scored by predict_eval; the
predictor names a server cannot run are 4xx at submission, nothing queued; a hanging external predictor is a
recorded episode error, never a hung worker."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from .service import REPO, Service, wait_job

HANGS = REPO / "tests" / "unit" / "predict" / "hanging_predictor.py"
SMALL = {"scenarios": ["crossing_low"], "seeds_per_scenario": 1, "max_steps": 60}


def _evaluate(client, model: str):  # noqa: ANN001
    return client.post("/v1/jobs", json={"spec": {"kind": "evaluate", **SMALL, "planner": {"model": model}}})


def test_predictor_plugins_over_the_service(tmp_path: Path) -> None:
    table = {
        "reference": [sys.executable, str(REPO / "examples" / "external_predictor.py")],
        "hangs": [sys.executable, str(HANGS)],
    }
    service = Service(tmp_path, external_predictors=json.dumps(table), predictor_timeout_s="0.5")
    try:
        service.serve("up", "--concurrency", "1")
        with service.client() as client:
            listed = client.get("/v1/predictors").json()
            noise = next(p for p in listed["data"] if p["name"] == "cv_noise")
            assert noise["origin"] == "plugin foresight-cv-noise 0.1.0" and noise["modes"] == 20
            assert noise["timebase"] == {"dt": 0.4, "history": 8, "horizon": 12} and noise["frame"] == "world"
            assert listed["external"] == ["hangs", "reference"] and "python" not in json.dumps(listed)
            # names a server cannot run: refused at submission, each naming the predictor
            r = _evaluate(client, "tests.unit.predict.plugin_predictors:StraightOn")
            assert r.status_code == 422 and "in-process only" in r.text, r.text
            r = _evaluate(client, "external:nobody")
            assert r.status_code == 422 and "'external:nobody' is not configured" in r.text, r.text
            r = _evaluate(client, "no_such_predictor")
            assert r.status_code == 404 and "no_such_predictor" in r.text, r.text
            assert client.get("/v1/jobs").json()["count"] == 0

            for model, origin in (
                ("cv_noise", "plugin:cv_noise"),
                ("external:reference", "external:reference_cv"),
            ):
                job = wait_job(client, _evaluate(client, model).json()["id"], timeout=300)
                assert job["status"] == "succeeded", (job, service.logs())
                result = job["result"]
                assert (
                    result["planner"]["model_id"] == model
                    and result["planner"]["checkpoint_sha256"] == origin
                )
                assert result["taxonomy"]["planner_error"] == 0

            job = wait_job(client, _evaluate(client, "external:hangs").json()["id"], timeout=120)
            assert job["status"] == "succeeded", (job, service.logs())
            (rec,) = [
                json.loads(x)
                for x in client.get(f"/v1/jobs/{job['id']}/artifacts/episodes.jsonl").text.splitlines()
            ]
            assert rec["outcome"] == "error" and "predictor 'external:hangs'" in rec["error"]
            assert "no answer within 0.5 s" in rec["error"]

            body = {
                "spec": {"kind": "predict_eval", "model": "cv_noise", "ethucy": "ethucy", "folds": ["hotel"]}
            }
            job = wait_job(client, client.post("/v1/jobs", json=body).json()["id"], timeout=300)
            assert job["status"] == "succeeded", (job, service.logs())
            hotel = job["result"]["folds"]["hotel"]
            assert hotel["modes"] == 20 and hotel["best_of"] == 20 and hotel["min_ade"] < hotel["ade"]
            assert abs(hotel["ade"] - hotel["cv_ade"]) < 1e-6
    finally:
        service.stop()
