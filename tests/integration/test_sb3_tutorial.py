"""docs/tutorials/sb3.md as written: PPO trained a few thousand steps in foresight/CrowdNav-v0 and saved, then the
saved policy evaluated as planner `sb3` in-process and through a real `foresight up` (policy in an uploaded bundle),
its episodes recorded under the policy's name and checksum."""

from __future__ import annotations

import hashlib
import json
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from tests.readme import blocks, commands

from .service import REPO, Service

TUTORIAL = REPO / "docs" / "tutorials" / "sb3.md"

pytestmark = pytest.mark.slow


def _section(name: str, lang: str) -> list[str]:
    found = [b.code for b in blocks(lang, TUTORIAL) if b.section.startswith(name)]
    assert found, f"{TUTORIAL.name} has no {lang} block under {name!r}"
    return found


def _run(svc: Service, cwd: Path, command: str) -> subprocess.CompletedProcess:
    """A tutorial ``foresight ...`` command, run by this interpreter."""
    argv = shlex.split(command)
    if argv[0] == "foresight":
        argv = [sys.executable, "-m", "foresight.cli.main", *argv[1:]]
    return subprocess.run(argv, cwd=cwd, env=svc.env, capture_output=True, text=True, timeout=300)


def test_the_tutorial_trains_saves_and_evaluates_its_policy(tmp_path: Path) -> None:
    work = tmp_path / "work"
    work.mkdir()
    svc = Service(tmp_path)
    (train,) = _section("2. Train", "python")
    done = subprocess.run(
        [sys.executable, "-c", train], cwd=work, env=svc.env, capture_output=True, text=True, timeout=600
    )
    assert done.returncode == 0, done.stderr[-3000:]
    policy = work / "ppo_crowdnav.zip"
    assert policy.stat().st_size > 10_000

    (local,) = _section("3. Evaluate in-process", "bash")
    (cmd,) = commands(local)
    done = _run(svc, work, cmd + " --json")
    assert done.returncode == 0, done.stderr[-3000:]
    result = json.loads(done.stdout)["result"]
    assert result["planner"]["name"] == "sb3" and result["episodes"] == 6
    assert result["planner"]["model_id"] == "sb3:ppo_crowdnav.zip"

    svc.serve("up")
    try:
        (server,) = _section("4. Evaluate on the server", "bash")
        for cmd in commands(server):
            if not cmd.startswith("foresight"):  # the shell's own (mkdir, cp)
                subprocess.run(["bash", "-c", cmd], cwd=work, check=True, timeout=30)
            else:
                done = _run(svc, work, cmd)
                assert done.returncode == 0, (cmd, done.stderr[-3000:])
        assert "sb3 (config" in done.stdout and "gate: passed" in done.stdout, done.stdout
        with svc.client() as client:
            (evaluation,) = client.get("/v1/evaluations").json()["data"]
            episodes = client.get(
                f"/v1/evaluations/{evaluation['id']}/episodes/export", params={"format": "jsonl"}
            ).text.splitlines()
        rows = [json.loads(line) for line in episodes]
        assert len(rows) == 6 and {r["planner"] for r in rows} == {"sb3"}
        assert {r["provenance.model_id"] for r in rows} == {"sb3:my-policies/ppo_crowdnav.zip"}
        assert {r["provenance.checkpoint_sha256"] for r in rows} == {
            hashlib.sha256(policy.read_bytes()).hexdigest()
        }
    finally:
        svc.stop()
