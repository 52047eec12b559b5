"""What a new user types, from a folder outside the checkout: config paths by one rule, a second `foresight up`
refused before it touches the first one's files, short job ids in every id field, and an external planner command
that cannot start named in one line. Real `foresight up` and CLI subprocesses."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest

from .service import REPO, Service, free_port, tiny_model_job

MATRIX = "configs/scenarios/classic_interactions.yaml"
SMALL = ["--scenarios", "crossing_low", "--seeds-per-scenario", "1", "--max-steps", "20"]


@pytest.fixture(scope="module")
def up(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Service]:
    svc = Service(tmp_path_factory.mktemp("up"))
    svc.serve("up")
    yield svc
    svc.stop()


def cli(svc: Service, cwd: Path, *args: str, env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "foresight.cli.main", *args],
        env={**svc.env, **(env or {})},
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=120,
    )


def test_config_paths_mean_the_same_from_any_folder(up: Service, tmp_path: Path) -> None:
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    other_checkout = tmp_path / "checkout2" / "configs" / "scenarios"
    other_checkout.mkdir(parents=True)
    shutil.copy(REPO / MATRIX, other_checkout)
    for matrix in (
        MATRIX,
        "scenarios/classic_interactions.yaml",
        str(other_checkout / "classic_interactions.yaml"),
    ):
        proc = cli(
            up, elsewhere, "evaluate", "--matrix", matrix, "--planner", "social_force", *SMALL, "--no-wait"
        )
        assert proc.returncode == 0, (matrix, proc.stderr)
        with up.client() as client:
            job = client.get(f"/v1/jobs/{proc.stdout.strip()}").json()
        assert (
            job["spec"]["bundle"] == "builtin"
            and job["spec"]["matrix"] == "scenarios/classic_interactions.yaml"
        )

    # an edited copy is a local file: refused for the server in one line, no server path in it
    (other_checkout / "classic_interactions.yaml").write_text((REPO / MATRIX).read_text() + "\n# edited\n")
    proc = cli(
        up, elsewhere, "evaluate", "--matrix", str(other_checkout / "classic_interactions.yaml"), *SMALL
    )
    assert proc.returncode == 1 and "outside the project's configs/" in proc.stderr

    # the server names a wrong bundle name inside its bundle, never by its own folders
    proc = cli(
        up,
        elsewhere,
        "evaluate",
        "--bundle",
        "builtin",
        "--matrix",
        MATRIX,
        "--planner",
        "social_force",
        *SMALL,
    )
    assert proc.returncode == 1 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert (
        "did you mean 'scenarios/classic_interactions.yaml'" in proc.stderr and str(REPO) not in proc.stderr
    )

    # a missing local file names what was typed and the folder it was read from
    proc = cli(up, elsewhere, "evaluate", "--local", "--matrix", "nope/x.yaml", *SMALL)
    assert proc.returncode == 1 and "'nope/x.yaml'" in proc.stderr and str(elsewhere) in proc.stderr


def test_short_ids_name_datasets_and_jobs(up: Service, tmp_path: Path) -> None:
    with up.client() as client:
        trained = tiny_model_job(client)
        dataset = client.get(f"/v1/jobs/{trained}").json()["spec"]["dataset"]
    proc = cli(
        up, tmp_path, "models", "register", "short-id-model", "--job", trained[:12], "--artifact", "model.pt"
    )
    assert proc.returncode == 0, proc.stderr
    # the training config by its project name from another folder, the dataset by the 12 characters the CLI prints
    proc = cli(
        up,
        tmp_path,
        "train",
        "--config",
        "configs/training/smoke.yaml",
        "--dataset",
        dataset[:12],
        "--no-wait",
    )
    assert proc.returncode == 0, proc.stderr
    with up.client() as client:
        assert client.get(f"/v1/jobs/{proc.stdout.strip()}").json()["spec"]["dataset"] == dataset
        client.post(f"/v1/jobs/{proc.stdout.strip()}/cancel")


def test_a_second_up_refuses_before_printing_and_keeps_the_first_ones_files(
    up: Service, tmp_path: Path
) -> None:
    server_file = Path(up.env["FORESIGHT_DATA_DIR"]) / "server.json"
    before = server_file.read_text()
    proc = cli(up, tmp_path, "up", "--port", str(free_port()))
    assert proc.returncode == 1 and proc.stdout == ""
    assert proc.stderr.count("\n") == 1 and "already runs" in proc.stderr and "dashboard" not in proc.stderr
    assert server_file.read_text() == before
    assert httpx.get(f"{up.url}/healthz", timeout=5).status_code == 200
    # another data folder on the same port: refused the same way, nothing written there
    other = tmp_path / "other-data"
    proc = cli(up, tmp_path, "up", "--port", up.url.rsplit(":", 1)[1], env={"FORESIGHT_DATA_DIR": str(other)})
    assert proc.returncode == 1 and proc.stdout == "" and "pick another --port" in proc.stderr
    assert not (other / "server.json").exists()
    assert server_file.read_text() == before


def test_an_external_planner_that_cannot_start_is_one_line(tmp_path: Path) -> None:
    env = {
        "FORESIGHT_EXTERNAL_PLANNERS": json.dumps(
            {"reference": ".venv/bin/python examples/external_planner.py"}
        ),
        "FORESIGHT_DATA_DIR": str(tmp_path / "data"),
    }
    svc = Service(tmp_path)
    proc = cli(
        svc,
        tmp_path,
        "evaluate",
        "--local",
        "--matrix",
        MATRIX,
        "--planner",
        "external",
        "--planner-config",
        '{"command": "reference"}',
        *SMALL,
        env=env,
    )
    assert proc.returncode == 1 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert "'reference'" in proc.stderr and ".venv/bin/python" in proc.stderr and str(tmp_path) in proc.stderr


def test_an_evaluations_episodes_export_from_the_server(up: Service, tmp_path: Path) -> None:
    import pyarrow.parquet as pq

    from .service import wait_job

    spec = {
        "kind": "evaluate",
        "planner": {"name": "social_force"},
        "scenarios": ["crossing_low"],
        "seeds_per_scenario": 3,
        "max_steps": 30,
    }
    with up.client() as client:
        job = wait_job(client, client.post("/v1/jobs", json={"spec": spec}).json()["id"])
        assert job["status"] == "succeeded", job
        csv_text = client.get(f"/v1/evaluations/{job['id'][:12]}/episodes/export", params={"format": "csv"})
        assert csv_text.status_code == 200 and csv_text.headers["content-type"].startswith("text/csv")
        assert (
            csv_text.text.splitlines()[0].startswith("scenario,seed,")
            and len(csv_text.text.splitlines()) == 4
        )
        bad = client.get(f"/v1/evaluations/{job['id']}/episodes/export", params={"format": "xlsx"})
        assert bad.status_code == 422
    proc = cli(up, tmp_path, "evaluations", "episodes", job["id"][:12], "--out", str(tmp_path / "e.parquet"))
    assert proc.returncode == 0, proc.stderr
    table = pq.read_table(tmp_path / "e.parquet")
    assert table.num_rows == 3 and "safety.min_clearance" in table.column_names


def _evaluate(up: Service, tmp_path: Path, planner: str) -> subprocess.CompletedProcess:
    spec = tmp_path / f"{planner}.yaml"
    spec.write_text(
        f"planner: {{name: {planner}}}\nscenarios: [crossing_low]\nseeds_per_scenario: 2\nmax_steps: 30\n"
    )
    return cli(up, tmp_path, "submit", "evaluate", "-f", str(spec), "--wait")


def test_submit_wait_and_jobs_show_lead_with_status_and_artifacts(up: Service, tmp_path: Path) -> None:
    done = _evaluate(up, tmp_path, "social_force")
    assert done.returncode in (0, 2), done.stderr
    first, *rest = done.stdout.splitlines()
    assert first.startswith("evaluate job ") and ": succeeded" in first
    assert any(line.startswith("artifacts (") and "report.html" in line for line in rest)
    assert "success_rate" in done.stdout and "page: http" in done.stdout
    job_id = first.split()[2].rstrip(":")
    show = cli(up, tmp_path, "jobs", "show", job_id[:12]).stdout.splitlines()
    assert show[0] == first
    artifacts = next(i for i, line in enumerate(show) if line.startswith("artifacts ("))
    result = next(i for i, line in enumerate(show) if line.startswith("result"))
    assert artifacts < result < 15 and not any('"speed_ratio"' in line for line in show[:result])


def test_compare_leads_with_metrics_and_names_each_config_key_once(up: Service, tmp_path: Path) -> None:
    ids = []
    for planner in ("social_force", "orca"):
        done = _evaluate(up, tmp_path, planner)
        ids.append(done.stdout.split()[2].rstrip(":"))
    done = cli(up, tmp_path, "compare", ids[0][:12], ids[1][:12])
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    table = next(i for i, line in enumerate(lines) if line.startswith("metric"))
    config = next(i for i, line in enumerate(lines) if line.startswith("config ("))
    assert table < 8 < config, done.stdout
    keys = [
        line.split(":")[0].strip() for line in lines[config + 1 :] if line.startswith("  ") and "->" in line
    ]
    assert "planner.ped_strength" in keys and not any(k.startswith("stage.planner.config.") for k in keys)


def test_dataset_ls_lists_the_servers_datasets(up: Service, tmp_path: Path) -> None:
    from .service import wait_job

    spec = {
        "kind": "collect",
        "scenarios": ["crossing_low"],
        "seeds_per_scenario": 1,
        "max_steps": 40,
        "check_quality": False,
    }
    with up.client() as client:
        job = wait_job(client, client.post("/v1/jobs", json={"spec": spec}).json()["id"])
    assert job["status"] == "succeeded", job
    done = cli(up, tmp_path, "dataset", "ls")
    assert done.returncode == 0 and job["id"] in done.stdout
    listed = json.loads(cli(up, tmp_path, "dataset", "ls", "--json").stdout)
    assert job["id"] in {d["id"] for d in listed}
