"""The per-user data folder: where it is, how the client finds a running `foresight up`, where --local runs go."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from foresight.cli.main import main
from foresight.store.settings import DEFAULT_API_URL, Settings


def test_the_data_folder_is_per_user(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.delenv("FORESIGHT_DATA_DIR")
    monkeypatch.delenv("XDG_DATA_HOME", raising=False)
    monkeypatch.setenv("HOME", str(tmp_path))
    monkeypatch.chdir(tmp_path.parent)
    assert (
        Settings().data_dir == tmp_path / ".local" / "share" / "foresight"
    )  # not relative to the current folder
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "xdg"))
    assert Settings().data_dir == tmp_path / "xdg" / "foresight"
    monkeypatch.setenv("FORESIGHT_DATA_DIR", "~/elsewhere")
    assert Settings().data_dir == tmp_path / "elsewhere"


def test_the_client_uses_the_running_server_of_the_data_folder(tmp_path: Path) -> None:
    settings = Settings(data_dir=tmp_path)
    assert settings.client_url == DEFAULT_API_URL  # no server.json
    alive = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    try:
        settings.server_file().write_text(json.dumps({"url": "http://127.0.0.1:8123", "pid": alive.pid}))
        assert settings.client_url == "http://127.0.0.1:8123"
        assert (
            Settings(data_dir=tmp_path, api_url="http://h:1/").client_url == "http://h:1"
        )  # the explicit URL wins
    finally:
        alive.kill()
        alive.wait()
    assert settings.client_url == DEFAULT_API_URL  # a server that died without removing its file is not used
    settings.server_file().write_text("{not json")
    assert settings.client_url == DEFAULT_API_URL


def test_local_runs_without_out_keep_their_folder_in_the_data_folder(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    monkeypatch.setenv("FORESIGHT_DATA_DIR", str(tmp_path))
    code = main(
        [
            "evaluate",
            "--local",
            "--matrix",
            "configs/scenarios/classic_interactions.yaml",
            "--scenarios",
            "crossing_low",
            "--seeds-per-scenario",
            "1",
            "--max-steps",
            "20",
            "--planner",
            "goal",
        ]
    )
    assert code in (0, 2)
    runs = list((tmp_path / "runs").iterdir())
    assert len(runs) == 1 and runs[0].name.startswith("evaluate-") and (runs[0] / "report.html").is_file()
    assert f"artifacts in {runs[0]}" in capsys.readouterr().out
