"""A model trained in the pedestrian frame (robot-less data such as ETH/UCY) is refused by the predictive planner
before any episode runs, in one line naming the model id (not the checkpoint file's stem)."""

from __future__ import annotations

from pathlib import Path

import pytest

from foresight.cli.main import main

REPO = Path(__file__).resolve().parents[3]


def test_a_pedestrian_frame_model_is_refused_by_id_before_any_episode(
    tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    from foresight.core.predict.nn.checkpoint import read_checkpoint, save_checkpoint

    payload = read_checkpoint(REPO / "model" / "predictor-sim-default.pt")
    payload["feature_schema"]["frame_convention"] = "pedestrian"
    save_checkpoint(payload, tmp_path / "model.pt")
    code = main(
        [
            "evaluate",
            "--local",
            "--matrix",
            str(REPO / "configs" / "scenarios" / "classic_interactions.yaml"),
            "--scenarios",
            "crossing_low",
            "--seeds-per-scenario",
            "1",
            "--max-steps",
            "20",
            "--model",
            str(tmp_path / "model.pt"),
            "--out",
            str(tmp_path / "run"),
        ]
    )
    err = capsys.readouterr().err
    assert code == 1
    line = err.strip().splitlines()[-1]
    assert (
        line.startswith("foresight: error:")
        and "model 'file:model.pt' was trained in the 'pedestrian' frame" in line
    )
    assert not (tmp_path / "run" / "episodes.jsonl").exists()  # refused before any episode
