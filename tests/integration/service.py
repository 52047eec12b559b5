"""Helpers for tests with real processes: `foresight serve` / `worker` / `up` subprocesses on a temp SQLite file or a fresh PostgreSQL
database (created per test, dropped afterwards)."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import httpx

REPO = Path(__file__).resolve().parents[2]
TOKEN = "integration-token"


def wait_job(client: httpx.Client, job_id: str, timeout: float = 90) -> dict:
    """The job once it ended (succeeded, failed or cancelled), polled over the API."""
    deadline = time.time() + timeout
    while time.time() < deadline:
        job = client.get(f"/v1/jobs/{job_id}").json()
        if job["status"] in ("succeeded", "failed", "cancelled"):
            return job
        time.sleep(0.2)
    raise AssertionError(f"job {job_id} did not finish: {job}")


def tiny_model_job(client: httpx.Client, timeout: float = 180) -> str:
    """A succeeded train job whose ``model.pt`` is a real (tiny) checkpoint: registration takes nothing else."""
    collect = {
        "kind": "collect",
        "scenarios": ["crossing_low"],
        "seeds_per_scenario": 2,
        "max_steps": 60,
        "check_quality": False,
    }
    data = wait_job(client, client.post("/v1/jobs", json={"spec": collect}).json()["id"], timeout)
    assert data["status"] == "succeeded", data
    train = {
        "kind": "train",
        "dataset": data["id"],
        "epochs": 1,
        "hidden": 8,
        "blocks": 0,
        "edge_dim": 0,
        "allow_degenerate": True,
    }
    done = wait_job(client, client.post("/v1/jobs", json={"spec": train}).json()["id"], timeout)
    assert done["status"] == "succeeded", done
    return done["id"]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Service:
    """Processes sharing one database and one store; everything is stopped at teardown."""

    def __init__(self, tmp: Path, database_url: str | None = None, **settings: str):
        self.env = {
            **os.environ,
            "FORESIGHT_DATA_DIR": str(tmp / "data"),
            "FORESIGHT_API_TOKEN": TOKEN,
            "FORESIGHT_LEASE_S": "1.5",
            "FORESIGHT_HEARTBEAT_S": "0.3",
            "FORESIGHT_POLL_S": "0.05",
            "FORESIGHT_SHUTDOWN_GRACE_S": "1",
            "PYTHONUNBUFFERED": "1",
            **{f"FORESIGHT_{k.upper()}": v for k, v in settings.items()},
        }
        if database_url:
            self.env["FORESIGHT_DATABASE_URL"] = database_url
        self.tmp = tmp
        self.procs: list[subprocess.Popen] = []
        self.url: str | None = None

    def cli(self, *args: str, check: bool = True, timeout: float = 120) -> subprocess.CompletedProcess:
        proc = subprocess.run(
            [sys.executable, "-m", "foresight.cli.main", *args],
            env=self.env,
            cwd=REPO,
            capture_output=True,
            text=True,
            timeout=timeout,
        )
        if check and proc.returncode != 0:
            raise AssertionError(
                f"foresight {' '.join(args)} -> {proc.returncode}\n{proc.stdout}\n{proc.stderr}"
            )
        return proc

    def spawn(self, *args: str) -> subprocess.Popen:
        log = open(self.tmp / f"proc-{len(self.procs)}.log", "w")  # noqa: SIM115 (kept open while the process runs)
        proc = subprocess.Popen(
            [sys.executable, "-m", "foresight.cli.main", *args],
            env=self.env,
            cwd=REPO,
            stdout=log,
            stderr=subprocess.STDOUT,
        )
        self.procs.append(proc)
        return proc

    def migrate(self) -> None:
        self.cli("db", "upgrade")

    def serve(self, command: str = "serve", *extra: str) -> str:
        port = free_port()
        self.url = f"http://127.0.0.1:{port}"
        self.env["FORESIGHT_API_URL"] = self.url
        proc = self.spawn(command, "--port", str(port), *extra)
        deadline = time.time() + 60
        while time.time() < deadline:
            if proc.poll() is not None:
                raise AssertionError(f"server exited: {self.logs()}")
            try:
                if httpx.get(f"{self.url}/healthz", timeout=1).status_code == 200:
                    return self.url
            except httpx.HTTPError:
                time.sleep(0.2)
        raise AssertionError("server did not start")

    def worker(self, concurrency: int = 1) -> subprocess.Popen:
        return self.spawn("worker", "--concurrency", str(concurrency))

    def client(self) -> httpx.Client:
        return httpx.Client(base_url=self.url, headers={"Authorization": f"Bearer {TOKEN}"}, timeout=30)

    def logs(self) -> str:
        return "\n".join(p.read_text()[-3000:] for p in sorted(self.tmp.glob("proc-*.log")))

    def stop(self) -> None:
        for proc in self.procs:
            if proc.poll() is None:
                proc.send_signal(signal.SIGTERM)
        for proc in self.procs:
            try:
                proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
