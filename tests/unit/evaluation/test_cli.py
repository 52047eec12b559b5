"""`foresight evaluate` prints JSON with the rates at top level and exits 2 on a failing gate."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from foresight.cli.main import main
from foresight.core.stages.refs import BUILTIN_CONFIG_ROOT

MATRIX = str(BUILTIN_CONFIG_ROOT / "scenarios" / "classic_interactions.yaml")


def test_evaluate_json_and_gate_exit_code(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["evaluate", "--matrix", MATRIX, "--planner", "goal", "--scenarios", "crossing_low",
            "--seeds-per-scenario", "1", "--max-steps", "20", "--json", "--out", str(tmp_path), "--local"]
    rc = main([*argv, "--min-success", "1.0"])  # 20 steps cannot reach the goal: the gate fails
    data = json.loads(capsys.readouterr().out)
    assert rc == 2 and data["exit_code"] == 2 and data["status"] == "failed_gate"
    assert data["success_rate"] == 0.0 and data["collision_rate"] == 0.0 and data["episodes"] == 1
    assert (tmp_path / "evaluation.json").is_file()
    assert main([*argv, "--min-success", "0.0"]) == 0


def test_bad_input_is_one_error_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rc = main(["evaluate", "--matrix", MATRIX, "--planner", "predictive", "--model", "no-such-model",
               "--scenarios", "crossing_low", "--out", str(tmp_path), "--local"])
    err = capsys.readouterr().err
    assert rc == 1 and err.startswith("foresight: error:") and "no-such-model" in err
