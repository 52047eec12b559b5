"""How the CLI writes: one progress-bar style everywhere, and a closed pipe (`foresight ... | head`) is not an error."""

from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[3]


def test_one_progress_bar_style() -> None:
    """Only foresight.local.progress_bar builds a rich Progress; no command draws its own carriage-return bar."""
    offenders = []
    for path in sorted((REPO / "cli").glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            call = isinstance(node, ast.Call) and getattr(node.func, "id", getattr(node.func, "attr", None))
            if call == "Progress" and path.name != "common.py":
                offenders.append(f"{path.name}:{node.lineno} Progress(...)")
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and node.value.startswith("\r"):
                offenders.append(f"{path.name}:{node.lineno} carriage-return line")
            if (
                isinstance(node, ast.JoinedStr)
                and node.values
                and isinstance(node.values[0], ast.Constant)
                and str(node.values[0].value).startswith("\r")
            ):
                offenders.append(f"{path.name}:{node.lineno} carriage-return line")
    assert offenders == []


def test_a_closed_pipe_is_not_an_error() -> None:
    """`foresight scenarios list | head -1`: the reader went away; exit 0 and no 'Broken pipe' or traceback."""
    read, write = os.pipe()
    os.close(read)  # the reader is gone before the first write: every write fails with EPIPE
    try:
        done = subprocess.run(
            [
                sys.executable,
                "-m",
                "foresight.cli.main",
                "scenarios",
                "list",
                "--matrix",
                str(REPO / "configs" / "scenarios" / "classic_interactions.yaml"),
            ],
            stdout=write,
            stderr=subprocess.PIPE,
            text=True,
            cwd=REPO,
            timeout=120,
        )
    finally:
        os.close(write)
    assert done.returncode == 0 and "Broken pipe" not in done.stderr and "Traceback" not in done.stderr, (
        done.stderr
    )
