"""What a first-time user of the CLI reads: --version, a help line for every option, examples in the help, `ls`
everywhere (`scenarios list` kept), "did you mean" for a mistyped scenario, gate lines with readable numbers."""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

from foresight.cli.main import build_parser
from foresight.core.evaluation.gates import GateCheck

MATRIX = "configs/scenarios/classic_interactions.yaml"
REPO = Path(__file__).resolve().parents[3]


def _cli(*args: str, cwd: Path = REPO) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "foresight.cli.main", *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, "PYTHONPATH": str(REPO)},
    )


def test_version() -> None:
    done = _cli("--version")
    assert done.returncode == 0 and done.stdout.startswith("foresight 0.") and done.stdout.count("\n") == 1


def test_every_option_and_argument_has_help() -> None:
    missing = []

    def walk(parser: argparse.ArgumentParser, path: list[str]) -> None:
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, sub in action.choices.items():
                    walk(sub, [*path, name])
            elif not isinstance(action, argparse._HelpAction) and not action.help:
                missing.append(f"foresight {' '.join(path)} {'/'.join(action.option_strings) or action.dest}")

    walk(build_parser(), [])
    assert not missing, missing


def test_help_has_examples() -> None:
    done = _cli("--help")
    assert (
        done.returncode == 0 and "examples:" in done.stdout and "foresight evaluate --matrix" in done.stdout
    )


def test_scenarios_ls_and_its_old_name() -> None:
    ls, old = _cli("scenarios", "ls", "--matrix", MATRIX), _cli("scenarios", "list", "--matrix", MATRIX)
    assert ls.returncode == old.returncode == 0 and ls.stdout == old.stdout and "crossing_low" in ls.stdout


def test_a_mistyped_scenario_gets_a_suggestion(tmp_path: Path) -> None:
    done = _cli(
        "sim", "run", "--local", "--matrix", MATRIX, "--scenario", "crosing_low", "--seed", "1", cwd=tmp_path
    )
    assert done.returncode == 1 and done.stderr.count("\n") == 1
    assert "did you mean 'crossing_low'" in done.stderr


def test_gate_lines_print_readable_numbers() -> None:
    line = GateCheck(name="mean_min_clearance", passed=True, value=1.1859514423931077, threshold=0.25).line()
    assert line == "mean_min_clearance: ok (1.19 vs 0.25)"
    assert GateCheck(name="success_rate", passed=False, value=None, threshold=0.3).line() == (
        "success_rate: FAIL (- vs 0.3)"
    )
