"""Stage commands in their default mode: submitted to a real `foresight up` (uvicorn server + worker process on
a temporary SQLite file), followed to the end, and read back over the API."""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

from .service import Service

SMOKE_TRAINING = "configs/training/smoke.yaml"


def _job(proc) -> dict:  # noqa: ANN001
    return json.loads(proc.stdout)


def test_collect_train_evaluate_through_the_stage_commands(service: Service) -> None:
    service.serve("up")
    up = service.procs[-1]
    (worker,) = Path(f"/proc/{up.pid}/task/{up.pid}/children").read_text().split()
    # the worker's episodes yield the CPU to the server's requests (clients poll while jobs run)
    assert os.getpriority(os.PRIO_PROCESS, int(worker)) == os.getpriority(os.PRIO_PROCESS, up.pid) + 5

    collect = service.cli(
        "collect",
        "--scenarios",
        "crossing_low,crossing_medium",
        "--seeds-per-scenario",
        "2",
        "--max-steps",
        "80",
        "--json",
    )
    collected = _job(collect)
    assert collected["kind"] == "collect" and collected["status"] == "succeeded", collected
    dataset = collected["id"]  # a collect job's dataset has the job's id

    train = service.cli("train", "--dataset", dataset, "--config", SMOKE_TRAINING, "--json", check=False)
    trained = _job(train)
    assert trained["kind"] == "train" and trained["status"] == "succeeded", trained
    assert train.returncode == (0 if trained["result"]["gates_passed"] else 2)  # a failing gate is a result
    assert (
        trained["spec"]["dataset"] == dataset and trained["spec"]["epochs"] == 2
    )  # the smoke config's values
    assert "model.pt" in {a["name"] for a in trained["artifacts"]}
    service.cli("models", "register", "smoke-model", "--job", trained["id"], "--artifact", "model.pt")

    evaluate = service.cli(
        "evaluate",
        "--matrix",
        "configs/scenarios/classic_interactions.yaml",
        "--scenarios",
        "crossing_low",
        "--seeds-per-scenario",
        "1",
        "--max-steps",
        "40",
        "--model",
        "smoke-model",
        "--min-success",
        "0",
    )  # text mode: the same summary as in-process
    assert "model smoke-model" in evaluate.stdout and "gate: passed" in evaluate.stdout
    assert "evaluate job" in evaluate.stderr  # the submission line; the progress bar follows it on stderr

    with service.client() as client:
        jobs = {j["kind"]: j for j in client.get("/v1/jobs", params={"limit": 10}).json()["data"]}
        assert set(jobs) == {"collect", "train", "evaluate"}  # all three ran on the server
        assert all(j["status"] == "succeeded" for j in jobs.values())
        assert jobs["collect"]["id"] == dataset and jobs["train"]["id"] == trained["id"]
        assert client.get(f"/v1/datasets/{dataset}").json()["summary"]["episodes"] == 4
        evaluation = client.get(f"/v1/evaluations/{jobs['evaluate']['id']}").json()
        assert evaluation["model_id"] == "smoke-model" and evaluation["metrics"]["episodes"] == 1
        assert jobs["evaluate"]["spec"]["bundle"] == "builtin"
        assert (
            jobs["evaluate"]["spec"]["matrix"] == "scenarios/classic_interactions.yaml"
        )  # a name, not a path

    # the same evaluation with constant velocity, then the A/B comparison and the report, read back by the CLI
    cv = _job(
        service.cli(
            "evaluate",
            "--matrix",
            "configs/scenarios/classic_interactions.yaml",
            "--scenarios",
            "crossing_low",
            "--seeds-per-scenario",
            "1",
            "--max-steps",
            "40",
            "--model",
            "cv",
            "--min-success",
            "0",
            "--json",
        )
    )
    compared = _job(service.cli("compare", jobs["evaluate"]["id"], cv["id"], "--json"))
    assert compared["a"] == jobs["evaluate"]["id"] and compared["b"] == cv["id"]
    assert {"a": "smoke-model", "b": "cv"} in [
        v for k, v in compared["config_diff"].items() if k.endswith("model")
    ]
    text = service.cli("compare", jobs["evaluate"]["id"], cv["id"]).stdout
    assert "config (keys that differ:" in text and '"smoke-model" -> "cv"' in text and "success" in text

    report = service.cli("report", cv["id"]).stdout
    assert report.startswith("#") and "crossing_low" in report  # the evaluation's Markdown report
    fetched = _job(service.cli("report", cv["id"], "--out", str(service.tmp / "report"), "--json"))
    assert fetched["kind"] == "evaluate" and {"report.md", "report.html"} <= set(fetched["report"])
    assert (service.tmp / "report" / "report.html").is_file() and any(
        f.endswith(".png") for f in fetched["written"]
    )

    # --no-wait prints the id; the job runs all the same
    job_id = service.cli(
        "mix", "--base", dataset, "--hardcase", dataset, "--repeat", "2", "--no-wait"
    ).stdout.strip()
    waited = _job(service.cli("jobs", "wait", job_id, "--json"))
    assert waited["kind"] == "mix" and waited["status"] == "succeeded"

    # `submit --wait` exits 2 for an evaluation whose gate failed, as `foresight evaluate` does
    spec = service.tmp / "gate.yaml"
    spec.write_text(
        "matrix: scenarios/classic_interactions.yaml\nplanner: {name: goal}\nscenarios: [crossing_low]\n"
        "seeds_per_scenario: 1\nmax_steps: 40\ngate: {min_success_rate: 1.0, min_mean_clearance: 100.0}\n"
    )
    gated = service.cli("submit", "evaluate", "-f", str(spec), "--wait", check=False)
    assert gated.returncode == 2 and "verdict failed_gate" in gated.stdout, (gated.stdout, gated.stderr)
    job_id = re.search(r"job ([0-9a-f]{32})", gated.stdout).group(1)
    short = job_id[:12]  # the 12 characters the CLI prints are accepted as the job id
    shown = service.cli("jobs", "show", short)
    assert job_id in shown.stdout.splitlines()[0] and "failed_gate" in shown.stdout.splitlines()[0], (
        shown.stdout
    )
    assert _job(service.cli("jobs", "show", short, "--json"))["verdict"] == "failed_gate"
    assert service.cli("jobs", "wait", short, "--json", check=False).returncode == 2

    # an unknown input id is refused at submission (404, nothing queued): exit 1, one readable line naming the id
    failed = service.cli("train", "--dataset", "no-such-dataset", "--epochs", "1", check=False)
    lines = failed.stderr.strip().splitlines()
    assert failed.returncode == 1 and lines[-1].startswith("foresight: error: "), failed.stderr
    assert "no-such-dataset" in lines[-1] and "dataset" in lines[-1].replace("no-such-dataset", ""), lines[-1]
    with service.client() as client:
        assert not [
            j
            for j in client.get("/v1/jobs", params={"kind": "train"}).json()["data"]
            if j["spec"]["dataset"] == "no-such-dataset"
        ]


def test_import_an_ethucy_fold_by_root_name_and_use_it_by_id(service: Service, shared_dir: Path) -> None:
    service.env["FORESIGHT_DATA_ROOTS"] = f"ethucy={shared_dir / 'reference' / 'ethucy'}"
    service.serve("up")
    with service.client() as client:
        assert {r["name"]: r["folds"] for r in client.get("/v1/data-roots").json()}["ethucy"] == [
            "eth",
            "hotel",
            "univ",
            "zara1",
            "zara2",
        ]

    imported = _job(service.cli("dataset", "import-ethucy", "--root", "ethucy", "--fold", "zara1", "--json"))
    assert imported["kind"] == "import_dataset" and imported["status"] == "succeeded", imported
    assert imported["spec"] == {
        "kind": "import_dataset",
        "source": "ethucy",
        "root": "ethucy",
        "fold": "zara1",
        "max_agents": 12,
    }
    with service.client() as client:
        summary = client.get(f"/v1/datasets/{imported['id']}").json()["summary"]
    assert summary["fold"] == "zara1" and summary["source"] == "ethucy"
    assert (
        summary["samples"] == sum(summary["samples_per_split"].values())
        and summary["samples_per_split"]["test"] > 0
    )

    # the dataset by id in a predict_eval job: constant velocity on zara1's held-out scene, as in-process
    scored = _job(service.cli("predict-eval", "--model", "cv", "--dataset", imported["id"], "--json"))
    assert scored["kind"] == "predict_eval" and scored["status"] == "succeeded"
    fold = next(iter(scored["result"]["folds"].values()))
    assert fold["split"] == "test" and fold["samples"] == summary["samples_per_split"]["test"]
    assert abs(fold["ade"] - 0.43) <= 0.01  # the published protocol's CV number on zara1 (tests/unit/predict)

    # predict_eval names the ETH/UCY data root (never a server folder): the fold is imported by the worker
    named = _job(
        service.cli("predict-eval", "--model", "cv", "--ethucy", "ethucy", "--fold", "zara1", "--json")
    )
    assert named["status"] == "succeeded" and named["spec"]["ethucy"] == "ethucy"
    assert (
        abs(named["result"]["folds"]["zara1"]["ade"] - fold["ade"]) < 1e-9
    )  # the same test split, the same CV

    unknown = service.cli("dataset", "import-ethucy", "--root", "nope", "--fold", "zara1", check=False)
    assert unknown.returncode == 1
    assert "HTTP 422" in unknown.stderr and "unknown data root 'nope'; known: ethucy" in unknown.stderr
