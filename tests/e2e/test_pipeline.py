"""The smoke pipeline end to end through the service: `foresight up` (server + one worker process with two
slots) on a temp SQLite file; one pipeline submitted over HTTP passes its (relaxed) gates and registers a relaxed
model that is never promoted, another (an impossible clearance floor) is run through `foresight pipeline run` and
exits 2 with its summary written. Then the regression gate through the service: the default model with a sabotaged
planner config is refused against the incumbent, the unchanged default against itself passes.

Both run at once (two slots), so the whole test takes about as long as one smoke pipeline: measured ~40 s
on a quiet 2-core machine, 3.5 min on the same machine at load ~10.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from tests.e2e.service import REPO, TOKEN, Up, wait_job

SMOKE = REPO / "configs" / "pipelines" / "smoke.yaml"
CHILD_STAGES = ["collect", "hardcase", "mix", "train", "conformance", "evaluate", "diagnose", "campaign"]
#: reference runs: shared by every pipeline with the same key, so one of the two pipelines may own them
REFERENCE_STAGES = ["incumbent_evaluate", "cv_baseline", "incumbent_diagnose"]
SECTIONS = [
    "## Verdict",
    "## Candidate vs incumbent",
    "## Stages",
    "## Gates",
    "## Best campaign variant",
    "## Promoted model",
    "## Training curves",
    "## Artifacts",
]

pytestmark = pytest.mark.slow


def test_smoke_pipeline_through_the_service(tmp_path: Path) -> None:
    up = Up(tmp_path, concurrency=2).start()
    try:
        spec = {**yaml.safe_load(SMOKE.read_text()), "kind": "pipeline"}
        failing = yaml.safe_load(SMOKE.read_text())
        failing.update(name="smoke-fail", diagnose=None)
        failing["evaluate"]["gate"] = {"min_success_rate": 0.0, "min_mean_clearance": 100.0}  # impossible
        failing["campaign"]["variants"] = failing["campaign"]["variants"][:1]
        failing_file = tmp_path / "failing.yaml"
        failing_file.write_text(yaml.safe_dump(failing))

        with up.client() as client:
            job = client.post("/v1/jobs", json={"spec": spec})
            assert job.status_code == 201, job.text
            job_id = job.json()["id"]
            cli = subprocess.Popen(
                [
                    sys.executable,
                    "-m",
                    "foresight.cli.main",
                    "pipeline",
                    "run",
                    "-f",
                    str(failing_file),
                    "--url",
                    up.url,
                    "--token",
                    TOKEN,
                ],
                cwd=REPO,
                env={**os.environ, **up.env},
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                text=True,
            )
            job = wait_job(client, job_id, timeout=600)
            assert job["status"] == "succeeded", (job.get("error"), up.log())
            result = job["result"]
            # the gates are relaxed on purpose: they pass, and the model is registered as relaxed, never promoted
            assert result["passed"] and result["exit_code"] == 0 and not result["promoted"]
            assert "can never be promoted or become the default" in result["promotion"]
            assert result["incumbent"]["id"] and len(result["incumbent"]["sha256"]) == 64

            # every stage is a real child job that succeeded, with its own records
            children = client.get("/v1/jobs", params={"parent_id": job_id, "limit": 50}).json()["data"]
            by_stage = {c["idempotency_key"].rsplit(":", 1)[-1]: c for c in children}
            assert set(CHILD_STAGES) <= set(by_stage) <= set(CHILD_STAGES + REFERENCE_STAGES)
            assert set(job["children"]) == {c["id"] for c in children}
            stages = {st["name"]: st for st in result["stages"]}
            assert all(stages[s]["status"] == "completed" and stages[s]["job_id"] for s in REFERENCE_STAGES)
            assert all(c["status"] == "succeeded" and c["parent_id"] == job_id for c in children)
            for stage in ("collect", "hardcase", "mix"):
                assert client.get(f"/v1/datasets/{by_stage[stage]['id']}").status_code == 200
            assert client.get(f"/v1/evaluations/{by_stage['evaluate']['id']}").status_code == 200
            assert client.get(f"/v1/campaigns/{by_stage['campaign']['id']}").status_code == 200
            train = client.get(f"/v1/jobs/{by_stage['train']['id']}").json()
            assert "model.pt" in {a["name"] for a in train["artifacts"]}

            # the candidate was registered as relaxed, and stays so: the registry keeps why
            model = client.get(f"/v1/models/{result['model_id']}").json()
            assert model["status"] == "relaxed" and model["job_id"] == by_stage["train"]["id"]
            assert model["metrics"]["promotion"]["promoted"] is False

            # the summary report, as a file and served by the API
            report = (up.store / "jobs" / job_id / "report.md").read_text()
            for section in SECTIONS:
                assert section in report, section
            page = client.get(f"/ui/jobs/{job_id}/files/report.html")
            assert page.status_code == 200 and "performance summary" in page.text

            # the failing gate: a result with exit code 2 (not a crash), summary written, no promotion
            out, err = cli.communicate(timeout=600)
            assert cli.returncode == 2, (out, err[-3000:], up.log())
            assert "GATES FAILED (evaluation)" in out and "report:" in out
            failed = client.get("/v1/jobs", params={"kind": "pipeline", "status": "succeeded"}).json()["data"]
            failed = next(j for j in failed if j["id"] != job_id)
            assert failed["result"]["exit_code"] == 2 and not failed["result"]["promoted"]
            assert client.get(f"/v1/models/{failed['result']['model_id']}").json()["status"] == "relaxed"
            report = (up.store / "jobs" / failed["id"] / "report.md").read_text()
            assert "FAILED" in report and "## Gates" in report
    finally:
        up.stop()


#: the default model on three scenarios it solves within 300 steps (about 170-200 steps each)
EPISODES = {
    "scenarios": ["crossing_low", "crossing_medium", "head_on_corridor_low"],
    "seeds_per_scenario": 1,
    "max_steps": 300,
    "gate": {"min_success_rate": 0.0, "min_mean_clearance": -10.0},
}
#: a planner config that caps the robot at 5 % of its top speed: every episode times out
SABOTAGE = {"max_speed_ratio": 0.05}


def _regression_spec(name: str, planner_config: dict) -> dict:
    """The smoke pipeline evaluating the DEFAULT model with ``planner_config`` against the incumbent (the default
    model with the planner's own config), with its gates not relaxed."""
    spec = yaml.safe_load(SMOKE.read_text())
    spec.update(name=name, kind="pipeline", diagnose=None, incumbent={"model": "auto", "planner_config": {}})
    spec["evaluate"] = {
        **EPISODES,
        "planner": {"name": "predictive", "model": "default", "config": planner_config},
    }
    spec["campaign"].update(variants=spec["campaign"]["variants"][:1], scenarios=["crossing_low"])
    spec["conformance"] = {"steps": 10}
    spec["gates"] = {"require": ["regression"]}  # the regression gate at its defaults: no drop at all
    return spec


def test_the_regression_gate_refuses_a_worse_candidate_and_passes_the_default_against_itself(
    tmp_path: Path,
) -> None:
    up = Up(tmp_path, concurrency=2).start()
    try:
        with up.client() as client:
            ids = {}
            for name, config in (("sabotaged", SABOTAGE), ("unchanged", {})):
                job = client.post("/v1/jobs", json={"spec": _regression_spec(name, config)})
                assert job.status_code == 201, job.text
                ids[name] = job.json()["id"]
            jobs = {name: wait_job(client, job_id, timeout=900) for name, job_id in ids.items()}
            for job in jobs.values():
                assert job["status"] == "succeeded", (job.get("error"), up.log()[-3000:])
            default = next(m for m in client.get("/v1/models").json()["data"] if m["status"] == "default")

            worse = jobs["sabotaged"]["result"]
            assert worse["exit_code"] == 2 and not worse["promoted"] and "regression" in worse["failed_gates"]
            assert (worse["incumbent"]["id"], worse["incumbent"]["sha256"]) == (
                default["id"],
                default["sha256"],
            )
            assert "regression.success_vs_incumbent: 1 (threshold 0)" in worse["failing_checks"]
            regression = worse["summary"]["regression"]
            assert regression["success"]["worse"] == 3 and len(regression["changed"]) == 3
            model = client.get(f"/v1/models/{worse['model_id']}").json()
            assert model["status"] == "candidate" and model["metrics"]["promotion"]["promoted"] is False
            assert (
                "regression.success_vs_incumbent: 1 (threshold 0)"
                in model["metrics"]["promotion"]["failing_checks"]
            )
            page = client.get(f"/ui/jobs/{ids['sabotaged']}").text
            assert "success_vs_incumbent" in page and "FAIL" in page and default["id"] in page
            assert "not promoted" in client.get("/ui/models").text
            report = (up.store / "jobs" / ids["sabotaged"] / "report.md").read_text()
            assert report.index("## Candidate vs incumbent") < report.index("## Stages")
            assert (
                f"/ui/compare/episode?a={regression['incumbent_run']}&b={regression['candidate_run']}"
                in report
            )

            same = jobs["unchanged"]["result"]
            gate = next(g for g in same["summary"]["gates"] if g["name"] == "regression")
            checks = {c["name"]: c for c in gate["checks"]}
            assert gate["passed"] and checks["success_vs_incumbent"]["value"] == 0.0
            assert same["summary"]["regression"]["changed"] == []
            # the incumbent's run is cached: both pipelines used the same job for it
            stage = {n: {s["name"]: s for s in jobs[n]["result"]["stages"]} for n in jobs}
            assert (
                stage["sabotaged"]["incumbent_evaluate"]["job_id"]
                == stage["unchanged"]["incumbent_evaluate"]["job_id"]
            )
            out = up.cli("models", "ls")
            assert worse["model_id"] in out.stdout and "stays a candidate" in out.stdout
    finally:
        up.stop()
