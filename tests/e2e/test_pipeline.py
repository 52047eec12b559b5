"""The smoke pipeline end to end through the service: `foresight up` (server + one worker process with two
slots) on a temp SQLite file; one pipeline submitted over HTTP passes its gates, another (an impossible
clearance floor) is run through `foresight pipeline run` and exits 2 with its summary written.

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
CHILD_STAGES = ["collect", "hardcase", "mix", "train", "evaluate", "diagnose", "campaign"]
SECTIONS = [
    "## Verdict",
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
            assert result["passed"] and result["exit_code"] == 0 and result["promoted"]

            # every stage is a real child job that succeeded, with its own records
            children = client.get("/v1/jobs", params={"parent_id": job_id, "limit": 50}).json()["data"]
            by_stage = {c["idempotency_key"].rsplit(":", 1)[-1]: c for c in children}
            assert sorted(by_stage) == sorted(CHILD_STAGES)
            assert set(job["children"]) == {c["id"] for c in children}
            assert all(c["status"] == "succeeded" and c["parent_id"] == job_id for c in children)
            for stage in ("collect", "hardcase", "mix"):
                assert client.get(f"/v1/datasets/{by_stage[stage]['id']}").status_code == 200
            assert client.get(f"/v1/evaluations/{by_stage['evaluate']['id']}").status_code == 200
            assert client.get(f"/v1/campaigns/{by_stage['campaign']['id']}").status_code == 200
            train = client.get(f"/v1/jobs/{by_stage['train']['id']}").json()
            assert "model.pt" in {a["name"] for a in train["artifacts"]}

            # the candidate was registered, then promoted because the gates passed
            model = client.get(f"/v1/models/{result['model_id']}").json()
            assert model["status"] == "promoted" and model["job_id"] == by_stage["train"]["id"]

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
            assert client.get(f"/v1/models/{failed['result']['model_id']}").json()["status"] == "candidate"
            report = (up.store / "jobs" / failed["id"] / "report.md").read_text()
            assert "FAILED" in report and "## Gates" in report
    finally:
        up.stop()
