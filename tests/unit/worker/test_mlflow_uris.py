"""MLflow tracking URIs a newcomer tries: a file store (read-only under MLflow 3) refused at start in one line, a
SQLite store whose artifacts land under the data folder, not in ./mlruns of the folder the run started in."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from foresight.core.errors import ConfigError
from foresight.worker import mlflow_export

REPO = Path(__file__).resolve().parents[3]
RUN = [
    "evaluate",
    "--local",
    "--matrix",
    "configs/scenarios/classic_interactions.yaml",
    "--planner",
    "social_force",
    "--scenarios",
    "crossing_low",
    "--seeds-per-scenario",
    "1",
    "--max-steps",
    "20",
]


def _cli(cwd: Path, uri: str, *args: str) -> subprocess.CompletedProcess:
    env = {
        **os.environ,
        "FORESIGHT_DATA_DIR": str(cwd / "data"),
        "FORESIGHT_MLFLOW_TRACKING_URI": uri,
        "PYTHONPATH": str(REPO),
    }
    return subprocess.run(
        [sys.executable, "-m", "foresight.cli.main", *args],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )


@pytest.mark.parametrize("uri", ["file:///tmp/mlruns", "./mlruns", "/tmp/mlruns"])
def test_a_file_store_is_refused_naming_the_setting(uri: str) -> None:
    with pytest.raises(ConfigError, match="FORESIGHT_MLFLOW_TRACKING_URI.*sqlite:///"):
        mlflow_export.target(uri)
    assert (
        mlflow_export.target("sqlite:///x.db").database and not mlflow_export.target("http://h:5000").database
    )


def test_file_store_refused_before_a_local_run_and_before_up(tmp_path: Path) -> None:
    done = _cli(tmp_path, "file:///tmp/mlruns", *RUN, "--out", str(tmp_path / "run"))
    assert done.returncode == 1 and done.stderr.count("\n") == 1 and "sqlite:///" in done.stderr
    assert not (tmp_path / "run" / "episodes.jsonl").exists()
    done = _cli(tmp_path, "file:///tmp/mlruns", "up", "--port", "0")
    assert done.returncode == 1 and done.stderr.count("\n") == 1 and "dashboard" not in done.stderr


def test_sqlite_artifacts_go_under_the_data_folder(tmp_path: Path) -> None:
    pytest.importorskip("mlflow")
    work = tmp_path / "work"
    work.mkdir()
    done = _cli(work, f"sqlite:///{tmp_path / 'mlflow.db'}", *RUN, "--out", str(tmp_path / "run"))
    assert done.returncode in (0, 2), done.stderr
    assert "MLflow: run" in done.stderr, done.stderr
    assert not (work / "mlruns").exists()
    assert any((work / "data" / "mlflow-artifacts" / "foresight").rglob("report.html"))
