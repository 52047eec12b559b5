"""The installed package, as a new user gets it: build the wheel, install it into a fresh venv (the local CPU
torch first, then the wheel with its server extra), and from a folder that holds its own ``core/`` and ``api/``
Python packages run ``foresight up`` with a small evaluation job through the API, and ``foresight evaluate
--local`` with the shipped default model. Nothing of the repository is on the path of those processes."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import httpx
import pytest
import yaml

from tests.integration.service import free_port, wait_job

REPO = Path(__file__).resolve().parents[2]
pytestmark = pytest.mark.slow

#: run-time files the service reads beside its code (one of each kind)
PACKAGE_DATA = [
    "foresight/migrations/env.py",
    "foresight/migrations/script.py.mako",
    "foresight/api/web/templates/job.html",
    "foresight/configs/scenarios/classic_interactions.yaml",
    "foresight/configs/maps/registry.yaml",
    "foresight/model/registry.yaml",
    "foresight/model/predictor-sim-default.pt",
    "foresight/store/queue.py",
    "foresight/core/jobs/kinds.py",
    "foresight/cli/main.py",
    "foresight/worker/runner.py",
]

#: a user's own packages named like ours: importing them would be a bug of ours
SHADOW = (
    "raise ImportError('the user folder\\'s own {name} package was imported instead of foresight.{name}')\n"
)


def _shipped_sha256() -> str:
    """The shipped default model's checksum, read from the repository's registry file."""
    entries = yaml.safe_load((REPO / "model" / "registry.yaml").read_text())["models"]
    return next(m["sha256"] for m in entries if m.get("status") == "default")


def _run(
    args: list, env: dict, cwd: Path, timeout: float = 900, ok: tuple[int, ...] = (0,)
) -> subprocess.CompletedProcess:
    proc = subprocess.run(
        [str(a) for a in args], env=env, cwd=cwd, capture_output=True, text=True, timeout=timeout
    )
    assert proc.returncode in ok, f"{args}\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    return proc


@pytest.fixture(scope="module")
def installed(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """(the fresh venv, the wheel it installed)."""
    tmp = tmp_path_factory.mktemp("wheel")
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV", "PYTHONHOME")}
    _run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            "--no-deps",
            "--no-build-isolation",
            "-q",
            "-w",
            tmp / "dist",
            REPO,
        ],
        env,
        tmp,
    )
    wheel = next((tmp / "dist").glob("foresight-*.whl"))
    venv = tmp / "venv"
    _run([sys.executable, "-m", "venv", venv], env, tmp)
    # --no-compile: no bytecode for the thousands of modules installed; the processes below compile the few hundred
    # they import on first use. Fixture 81 s -> 24 s, the test using it 16 s -> 27 s (2-core machine, load ~4)
    pip = [venv / "bin" / "python", "-m", "pip", "install", "-q", "--no-compile"]
    _run([*pip, "torch==2.13.0"], env, tmp)  # the local CPU build
    _run([*pip, f"{wheel}[server]"], env, tmp)
    return venv, wheel


def test_the_wheel_holds_the_run_time_files_under_one_namespace(installed: tuple[Path, Path]) -> None:
    names = zipfile.ZipFile(installed[1]).namelist()
    assert [n for n in PACKAGE_DATA if n not in names] == []
    assert any(n.startswith("foresight/migrations/versions/") and n.endswith(".py") for n in names)
    assert any(n.startswith("foresight/api/web/static/") for n in names)
    assert (
        "foresight/core/render/player.js" in names
    )  # the episode player (dashboard and compare --local pages)
    tops = {n.split("/")[0] for n in names}
    assert tops == {
        "foresight",
        next(t for t in tops if t.endswith(".dist-info")),
    }  # no generic top-level name
    assert not any(n.endswith(".pyc") for n in names)


def test_a_user_folder_runs_the_service_and_a_local_evaluation(
    installed: tuple[Path, Path], tmp_path: Path
) -> None:
    venv = installed[0]
    work = tmp_path / "user"
    for name in ("core", "api"):
        (work / name).mkdir(parents=True)
        (work / name / "__init__.py").write_text(SHADOW.format(name=name))
    port = free_port()
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV", "PYTHONHOME")}
    env |= {
        "PATH": f"{venv / 'bin'}:{env['PATH']}",
        "FORESIGHT_API_TOKEN": "wheel-token",
        "PYTHONUNBUFFERED": "1",
        "FORESIGHT_HEARTBEAT_S": "0.3",
        "FORESIGHT_POLL_S": "0.05",
        "FORESIGHT_DATA_DIR": str(work / "data"),
    }
    server = subprocess.Popen(
        [venv / "bin" / "foresight", "up", "--port", str(port)],
        env=env,
        cwd=work,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        with httpx.Client(
            base_url=f"http://127.0.0.1:{port}", headers={"Authorization": "Bearer wheel-token"}, timeout=30
        ) as client:
            deadline = time.time() + 120
            while time.time() < deadline and server.poll() is None:
                try:
                    if client.get("/healthz").status_code == 200:
                        break
                except httpx.TransportError:
                    time.sleep(0.3)
            spec = {
                "kind": "evaluate",
                "scenarios": ["crossing_low"],
                "seeds_per_scenario": 2,
                "max_steps": 30,
                "planner": {"name": "predictive"},
            }  # the server's default model: the shipped one
            response = client.post("/v1/jobs", json={"spec": spec})
            assert response.status_code == 201, response.text
            job = wait_job(client, response.json()["id"], timeout=300)
            assert job["status"] == "succeeded", job
            assert job["result"]["episodes"] == 2
            assert job["result"]["planner"]["checkpoint_sha256"] == _shipped_sha256()
            player = client.get("/ui/static/player.js")  # the episode player: core's package data, served
            assert player.status_code == 200 and "data-trace-script" in player.text
    finally:
        server.terminate()
        out = server.communicate(timeout=60)[0]
    assert "instead of foresight" not in out, out[-3000:]
    site = _run(
        [
            venv / "bin" / "python",
            "-c",
            "import foresight, pathlib; print(pathlib.Path(foresight.__file__).parent)",
        ],
        env,
        work,
    ).stdout.strip()
    assert Path(site).is_relative_to(venv)
    local = _run(
        [
            "foresight",
            "evaluate",
            "--local",
            "--matrix",
            f"{site}/configs/scenarios/classic_interactions.yaml",
            "--scenarios",
            "crossing_low",
            "--seeds-per-scenario",
            "1",
            "--max-steps",
            "30",
            "--json",
            "--out",
            work / "local",
        ],
        env,
        work,
        ok=(0, 2),
    )
    result = json.loads(local.stdout)["result"]  # the job envelope, as a server job's
    assert result["exit_code"] == local.returncode  # 2: the evaluation gate failed, a result (one episode)
    assert result["episodes"] == 1 and result["planner"]["model_id"] == "predictor-sim-default"
    assert result["planner"]["checkpoint_sha256"] == _shipped_sha256()
