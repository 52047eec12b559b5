"""A real `foresight up` (API server + worker process) on a temp SQLite file and store, for browser tests."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import httpx

from tests.integration.service import free_port, wait_job  # noqa: F401 (the e2e tests' helpers too)

REPO = Path(__file__).resolve().parents[2]
TOKEN = "e2e-dashboard-token"
#: how long a page may take to show what a test waits for: a bound for a loaded CI machine, not a speed claim
WAIT_MS = 60_000


class Up:
    """``python -m cli.main up`` in its own process group; :meth:`stop` ends it (and its worker)."""

    def __init__(self, tmp: Path, concurrency: int = 2, read_requires_token: bool = False):
        self.tmp = tmp
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.log_path = tmp / "foresight-up.log"
        self.store = tmp / "data" / "store"  #: the default artifact store of the data dir
        self.env = {
            **os.environ,
            "FORESIGHT_DATA_DIR": str(tmp / "data"),
            "FORESIGHT_API_TOKEN": TOKEN,
            "FORESIGHT_HEARTBEAT_S": "0.3",
            "FORESIGHT_POLL_S": "0.05",
            "FORESIGHT_SHUTDOWN_GRACE_S": "1",
            "PYTHONUNBUFFERED": "1",
        }
        self.env.pop("FORESIGHT_DATABASE_URL", None)
        self.env.pop("FORESIGHT_STORE", None)
        self.env["FORESIGHT_READ_REQUIRES_TOKEN"] = "true" if read_requires_token else "false"
        self.concurrency = concurrency
        self.proc: subprocess.Popen | None = None

    def start(self, timeout_s: float = 60.0) -> Up:
        log = self.log_path.open("w")
        self.proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "foresight.cli.main",
                "up",
                "--host",
                "127.0.0.1",
                "--port",
                str(self.port),
                "--concurrency",
                str(self.concurrency),
            ],
            env=self.env,
            cwd=REPO,
            stdout=log,
            stderr=subprocess.STDOUT,
            start_new_session=True,
        )
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if self.proc.poll() is not None:
                raise AssertionError(f"foresight up exited with {self.proc.returncode}:\n{self.log()}")
            try:
                if httpx.get(f"{self.url}/healthz", timeout=2).status_code == 200:
                    workers = self.client().get("/v1/workers", timeout=2).json()
                    if workers["count"] >= 1:
                        return self
            except httpx.HTTPError:
                pass
            time.sleep(0.3)
        self.stop()
        raise AssertionError(
            f"foresight up not ready (server and worker) within {timeout_s} s:\n{self.log()}"
        )

    def client(self) -> httpx.Client:
        return httpx.Client(base_url=self.url, headers={"Authorization": f"Bearer {TOKEN}"}, timeout=30)

    def cli(self, *args: str) -> subprocess.CompletedProcess:
        """``foresight ARGS`` as a user runs it against this service (its URL, token and data folder)."""
        env = {
            **os.environ,
            "FORESIGHT_API_URL": self.url,
            "FORESIGHT_API_TOKEN": TOKEN,
            "FORESIGHT_DATA_DIR": str(self.tmp / "data"),
        }
        return subprocess.run(
            [sys.executable, "-m", "foresight.cli.main", *args],
            env=env,
            cwd=REPO,
            capture_output=True,
            text=True,
            timeout=120,
        )

    def log(self) -> str:
        return self.log_path.read_text()[-6000:] if self.log_path.is_file() else ""

    def stop(self) -> None:
        """SIGINT (uvicorn's graceful stop, which stops the worker), then the process group if it lingers."""
        if self.proc is None or self.proc.poll() is not None:
            return
        self.proc.send_signal(signal.SIGINT)
        try:
            self.proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            os.killpg(self.proc.pid, signal.SIGKILL)
            self.proc.wait(timeout=10)


def wait_player(page: Any) -> None:  # noqa: ANN401 (playwright's Page)
    """Wait until every pane of the episode player has its trace (``#player[data-ready]``); if one never does,
    fail with what each pane says (a failed fetch shows its status and body there) and what the browser logged,
    so a failure on a loaded CI machine names its cause instead of only the wait."""
    from playwright.sync_api import TimeoutError as PageTimeout

    try:
        page.wait_for_selector('#player[data-ready="1"]', timeout=WAIT_MS)
    except PageTimeout:
        panes = page.eval_on_selector_all(
            ".pane",
            "ps => ps.map(p => (p.dataset.trace || p.id) + ': ' + (p.querySelector('.status') || {}).textContent)",
        )
        logged = getattr(page, "foresight_log", [])
        raise AssertionError(
            f"the player at {page.url} never became ready in {WAIT_MS / 1000:.0f} s; panes: {panes}; "
            f"browser log: {logged[-20:]}"
        ) from None
