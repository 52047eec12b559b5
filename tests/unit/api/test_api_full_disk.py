"""A full store: 507 with nothing left behind, DELETE removes a job's whole folder, and
`foresight store gc` finds what crashes and full disks left. The full disk is a real 1 MiB tmpfs."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time

from foresight.store import folders, queue
from foresight.store.gc import collect_garbage
from foresight.store.settings import REPO_ROOT
from tests.archives import tar_of


def _bundle(extra_bytes: int) -> bytes:
    files = {
        p.relative_to(REPO_ROOT / "configs").as_posix(): p.read_bytes()
        for p in sorted((REPO_ROOT / "configs" / "maps").rglob("*"))
        if p.is_file() and p.suffix in (".yaml", ".svg")
    }
    files["scenarios/m.yaml"] = (
        REPO_ROOT / "configs" / "scenarios" / "classic_interactions.yaml"
    ).read_bytes()
    for p in sorted((REPO_ROOT / "configs" / "scenarios").rglob("*.yaml")):
        files.setdefault(p.relative_to(REPO_ROOT / "configs").as_posix(), p.read_bytes())
    files["notes.txt"] = os.urandom(extra_bytes).hex().encode()[:extra_bytes]
    return tar_of(files, "w:gz")


def test_an_upload_into_a_full_store_is_507_and_leaves_no_staging(small_store, settings, auth) -> None:  # noqa: ANN001
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        from fastapi.testclient import TestClient
    from foresight.api.main import create_app

    with TestClient(
        create_app(settings.model_copy(update={"store": small_store})), raise_server_exceptions=False
    ) as c:
        r = c.post("/v1/bundles", params={"name": "big"}, content=_bundle(2 << 20), headers=auth)
        assert r.status_code == 507, r.text
        assert "store is full" in r.json()["detail"]
        assert c.get("/v1/bundles/big").status_code == 404
        assert list((small_store / "bundles").iterdir()) == []  # no staging folder left
        small = c.post("/v1/bundles", params={"name": "small"}, content=_bundle(10), headers=auth)
        assert small.status_code == 201, small.text  # the store still works once it has room


def test_delete_removes_the_whole_job_folder(client, auth, engine, settings) -> None:  # noqa: ANN001
    job = client.post("/v1/jobs", json={"spec": {"kind": "sleep"}}, headers=auth).json()
    c = queue.claim(engine, "w", ["sleep"], 30)
    folder = folders.resolve_under(settings.store_root, f"jobs/{job['id']}")
    (folder / "renders").mkdir(parents=True)
    (folder / "renders" / "partial.png").write_bytes(b"x" * 1000)  # written before ENOSPC, never recorded
    (folder / ".episodes.jsonl.abc.tmp").write_bytes(b"y" * 1000)
    queue.fail_or_retry(
        engine, job["id"], "w", c["attempts"], "OSError", "[Errno 28] No space left on device", retry=False
    )
    assert client.delete(f"/v1/jobs/{job['id']}", headers=auth).status_code == 204
    assert not folder.exists()


def test_store_gc_lists_then_removes_orphans_only(client, auth, engine, settings) -> None:  # noqa: ANN001
    root = settings.store_root
    live = client.post("/v1/jobs", json={"spec": {"kind": "sleep"}}, headers=auth).json()
    (root / "jobs" / live["id"]).mkdir(parents=True)
    (root / "jobs" / live["id"] / "keep.txt").write_text("live job")
    (root / "jobs" / "gone-job").mkdir(parents=True)
    (root / "jobs" / "gone-job" / "partial.npz").write_bytes(b"z" * 5000)
    stale = root / "bundles" / ".mine.x1y2"
    stale.mkdir(parents=True)
    (stale / "m.yaml").write_text("scenarios: []\n")
    fresh = root / "bundles" / ".other.a1b2"  # an upload being staged right now
    fresh.mkdir()
    old_tmp = root / "jobs" / live["id"] / ".out.json.q.tmp"
    old_tmp.write_text("{")
    hour_ago = time.time() - 7200
    for p in (stale, old_tmp):
        os.utime(p, (hour_ago, hour_ago))

    dry = collect_garbage(engine, root, dry_run=True)
    assert sorted(dry.paths) == sorted(
        ["jobs/gone-job/", "bundles/.mine.x1y2/", f"jobs/{live['id']}/.out.json.q.tmp"]
    )
    assert dry.bytes == 5000 + len("scenarios: []\n") + 1
    assert (root / "jobs" / "gone-job").exists()

    env = {**os.environ, "FORESIGHT_DATA_DIR": str(settings.data_dir), "FORESIGHT_STORE": str(root)}
    out = subprocess.run(
        [sys.executable, "-m", "foresight.cli.main", "store", "gc", "--json"],
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    assert json.loads(out.stdout) == {"paths": dry.paths, "bytes": dry.bytes, "dry_run": False}
    assert not (root / "jobs" / "gone-job").exists() and not stale.exists() and not old_tmp.exists()
    assert (root / "jobs" / live["id"] / "keep.txt").exists() and fresh.exists()
    assert collect_garbage(engine, root).paths == []


def test_store_gc_removes_attempt_folders_a_lost_lease_left(client, auth, engine, settings) -> None:  # noqa: ANN001
    root = settings.store_root
    done = client.post("/v1/jobs", json={"spec": {"kind": "sleep"}}, headers=auth).json()
    c = queue.claim(engine, "w", ["sleep"], 30)
    queue.finish(engine, done["id"], "w", c["attempts"], {})
    failed = client.post("/v1/jobs", json={"spec": {"kind": "sleep"}}, headers=auth).json()
    c = queue.claim(engine, "w", ["sleep"], 30)
    queue.fail_or_retry(engine, failed["id"], "w", c["attempts"], "E", "m", retry=False)
    for job_id in (done["id"], failed["id"]):  # written by a worker that woke up after its lease was gone
        folders.start_attempt(root, job_id)
    assert collect_garbage(engine, root, dry_run=True).paths == [f"jobs/{done['id']}/.attempts/"]
    collect_garbage(engine, root)
    assert not (root / "jobs" / done["id"] / ".attempts").exists()
    assert (root / "jobs" / failed["id"] / ".attempts").is_dir()  # a retry resumes from it
