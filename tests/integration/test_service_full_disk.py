"""A full disk shared by the database and the store (a real tmpfs, filled up): submissions and cancels answer 507,
/healthz says so, deleting a job and `foresight store gc` still work, and the failure of a job that ended while
the disk was full is recorded once space returns. Real server and worker processes."""

from __future__ import annotations

import sqlite3
import subprocess
import time
from pathlib import Path

import pytest

from .service import Service, wait_job


@pytest.fixture
def disk(tmp_path: Path):  # noqa: ANN201
    mount = tmp_path / "disk"
    mount.mkdir()
    done = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=24m", "tmpfs", str(mount)], capture_output=True
    )
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here (needs root): {done.stderr.decode().strip()}")
    yield mount
    subprocess.run(["umount", "-l", str(mount)], check=True)


def _fill(folder: Path) -> Path:
    """Write ballast until the disk refuses more."""
    ballast = folder / "ballast"
    with ballast.open("wb") as handle:
        try:
            while True:
                handle.write(b"\0" * 65536)
                handle.flush()
        except OSError:
            pass
    return ballast


def test_a_full_disk_answers_507_keeps_delete_working_and_recovers(tmp_path: Path, disk: Path) -> None:
    data = disk / "data"
    service = Service(tmp_path, data_dir=str(data))
    try:
        service.migrate()
        service.serve()
        service.worker()
        with service.client() as client:
            assert client.get("/healthz").json()["disk"]["full"] is False
            old = client.post("/v1/jobs", json={"spec": {"kind": "sleep", "artifact": "a.txt"}}).json()
            assert wait_job(client, old["id"])["status"] == "succeeded"
            spec = {"kind": "sleep", "seconds": 4, "steps": 20, "artifact": "b.txt"}
            running = client.post("/v1/jobs", json={"spec": spec}).json()
            deadline = time.time() + 30
            while client.get(f"/v1/jobs/{running['id']}").json()["status"] != "running":
                assert time.time() < deadline
                time.sleep(0.05)
            with sqlite3.connect(
                data / "foresight.db"
            ) as conn:  # an empty write-ahead log: writes must grow it
                conn.execute("PRAGMA wal_checkpoint(TRUNCATE)")
            ballast = _fill(disk)

            r = client.post("/v1/jobs", json={"spec": {"kind": "sleep"}})
            assert r.status_code == 507 and "store is full" in r.json()["detail"], r.text
            health = client.get("/healthz").json()
            assert health["status"].startswith("degraded") and health["disk"]["full"] is True, health
            assert client.post(f"/v1/jobs/{running['id']}/cancel").status_code == 507
            assert client.get("/v1/jobs").status_code == 200  # reads still work

            time.sleep(5)  # the running job ends while the disk is full: its outcome cannot be recorded yet
            assert client.get(f"/v1/jobs/{running['id']}").json()["status"] == "running"
            assert client.delete(f"/v1/jobs/{old['id']}").status_code == 204  # without room to write first
            assert client.get(f"/v1/jobs/{old['id']}").status_code == 404
            gc = service.cli("store", "gc", "--json")
            assert gc.returncode == 0, gc.stderr

            ballast.unlink()  # space returns
            job = wait_job(client, running["id"], timeout=30)
            assert job["status"] == "failed" and job["error"]["type"] in ("StoreFull", "OSError"), job
            assert "full" in job["error"]["message"], job
            deadline = time.time() + 20
            while (health := client.get("/healthz").json())["status"] != "ok":
                assert time.time() < deadline, health
                time.sleep(0.5)
            r = client.post("/v1/jobs", json={"spec": {"kind": "sleep"}})
            assert r.status_code == 201 and wait_job(client, r.json()["id"])["status"] == "succeeded"
    finally:
        service.stop()
