"""The per-user data folder: `foresight up` started in one folder, the CLI used from another (a second terminal),
with nothing configured but HOME: the client finds the server's URL and its write token there."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import httpx

from .service import REPO, free_port


def test_up_in_one_folder_and_the_cli_in_another(tmp_path: Path) -> None:
    home, a, b = tmp_path / "home", tmp_path / "a", tmp_path / "b"
    for folder in (home, a, b):
        folder.mkdir()
    env = {
        k: v
        for k, v in os.environ.items()
        if k not in ("FORESIGHT_DATA_DIR", "FORESIGHT_API_URL", "FORESIGHT_API_TOKEN", "XDG_DATA_HOME")
    }
    env |= {
        "HOME": str(home),
        "PYTHONPATH": str(REPO),
        "PYTHONUNBUFFERED": "1",
        "FORESIGHT_HEARTBEAT_S": "0.3",
        "FORESIGHT_POLL_S": "0.05",
        "FORESIGHT_SHUTDOWN_GRACE_S": "1",
    }
    data = home / ".local" / "share" / "foresight"
    port = free_port()  # not the default 8000: the client learns it from the data folder
    with (tmp_path / "up.log").open("w") as log:
        up = subprocess.Popen(
            [sys.executable, "-m", "foresight.cli.main", "up", "--port", str(port)],
            cwd=a,
            env=env,
            stdout=log,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
    try:
        deadline = time.time() + 90
        while True:
            assert up.poll() is None and time.time() < deadline, (tmp_path / "up.log").read_text()
            try:
                if httpx.get(f"http://127.0.0.1:{port}/healthz", timeout=1).status_code == 200:
                    break
            except httpx.HTTPError:
                time.sleep(0.2)
        printed = (tmp_path / "up.log").read_text()
        assert f"dashboard http://127.0.0.1:{port}/ui" in printed
        assert f"write token  {data / 'api-token'}" in printed and f"data folder  {data}" in printed
        assert json.loads((data / "server.json").read_text())["url"] == f"http://127.0.0.1:{port}"

        (b / "spec.yaml").write_text("seconds: 0\n")
        submitted = subprocess.run(
            [
                sys.executable,
                "-m",
                "foresight.cli.main",
                "submit",
                "sleep",
                "-f",
                "spec.yaml",
                "--wait",
                "--json",
            ],
            cwd=b,
            env=env,
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert submitted.returncode == 0, submitted.stderr  # a write: the token was found (no 401)
        job = json.loads(submitted.stdout)
        assert job["status"] == "succeeded"
        listed = subprocess.run(
            [sys.executable, "-m", "foresight.cli.main", "jobs", "ls", "--json"],
            cwd=b,
            env=env,
            capture_output=True,
            text=True,
            timeout=60,
        )
        assert listed.returncode == 0, listed.stderr
        assert job["id"] in {j["id"] for j in json.loads(listed.stdout)["data"]}
        read, write = os.pipe()  # `foresight jobs ls | head`: the reader is gone before the first line
        os.close(read)
        try:
            piped = subprocess.run(
                [sys.executable, "-m", "foresight.cli.main", "jobs", "ls"],
                cwd=b,
                env=env,
                stdout=write,
                stderr=subprocess.PIPE,
                text=True,
                timeout=60,
            )
        finally:
            os.close(write)
        assert piped.returncode == 0 and "Broken pipe" not in piped.stderr, piped.stderr
    finally:
        os.killpg(up.pid, signal.SIGTERM)
        try:
            up.wait(timeout=30)
        except subprocess.TimeoutExpired:
            os.killpg(up.pid, signal.SIGKILL)
            up.wait()
    assert not (data / "server.json").exists()  # a stopped server is not advertised
    assert not (a / ".foresight").exists() and not (b / ".foresight").exists()  # nothing per current folder
