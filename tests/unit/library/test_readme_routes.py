"""The tutorial "Evaluate your own planner" (docs/tutorials/own-planner.md): every code block of the section runs as written, from the repository root
(the Python route, the plugin route with the installed toy plugin, the external-process route, the environment)."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from tests.readme import DOCS, section_blocks

REPO = Path(__file__).resolve().parents[3]


def _blocks() -> list[tuple[str, str]]:
    return [
        (b.lang, b.code)
        for b in section_blocks("Evaluate your own planner", page=DOCS / "tutorials" / "own-planner.md")
    ]


def test_the_section_has_the_three_routes_and_the_environment() -> None:
    kinds = [kind for kind, _ in _blocks()]
    assert kinds == ["python", "bash", "bash", "python"]


@pytest.mark.parametrize("index", range(4))
def test_readme_block_runs(index: int) -> None:
    kind, code = _blocks()[index]
    argv = [sys.executable, "-c", code] if kind == "python" else ["bash", "-c", code]
    env = {
        "PATH": f"{Path(sys.executable).parent}:/usr/bin:/bin",
        "HOME": str(Path.home()),
        "FORESIGHT_DATA_DIR": os.environ["FORESIGHT_DATA_DIR"],
    }  # the tests' data folder (tests/conftest.py)
    proc = subprocess.run(argv, cwd=REPO, capture_output=True, text=True, timeout=300, env=env)
    assert proc.returncode in (0, 2), proc.stderr[-3000:]  # 2: a failing gate, still a result
    if kind == "bash":
        result = json.loads(proc.stdout)["result"]  # --json: the job, its result inside
        assert result["episodes"] == 2 and result["taxonomy"].get("planner_error", 0) == 0
    elif index == 0:
        assert re.search(r"success \d+%, collisions \d+%", proc.stdout), proc.stdout
    else:
        assert proc.stdout.split()[0] in ("success", "timeout", "collision_pedestrian", "collision_static")
