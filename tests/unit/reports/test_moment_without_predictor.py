"""The critical-moment figure of a planner without a predictor (no forecasts recorded) still shows the scene:
the pedestrians at that step with ids and velocities, the robot's heading and its plan (its command rolled out)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from PIL import Image

from foresight.core.render.moment import rollout
from foresight.core.reports.diagnostics import write_diagnostics_report
from tests.unit.reports import data
from tests.unit.reports.scenes import trace

PLAN_RGB = (148, 103, 189)  #: the plan's purple (#9467bd)
PED_RGB = (140, 86, 75)  #: tab:brown


def _pixels(path: Path, rgb: tuple[int, int, int], tol: int = 30) -> int:
    with Image.open(path) as im:
        px = np.asarray(im.convert("RGB"), dtype=int)
    return int((np.abs(px - np.array(rgb)).max(axis=2) < tol).sum())


def _run_without_forecasts(tmp_path: Path) -> dict:
    tr = trace()
    steps = [
        {
            "step": t,
            "robot": tr.robot[t].tolist(),
            "command": [0.9, 0.2],
            "min_distance": 2.0 - t / 60,
            "predicted_vs_actual": [],
        }
        for t in range(tr.steps)
    ]
    record = data.record(tr, "crossing_high", 3, collision_step=40, collision_point=(14.0, 10.0))
    (tmp_path / "diagnostics").mkdir(parents=True)
    (tmp_path / "diagnostics/trace_crossing_high_3.json").write_text(
        json.dumps(
            {
                "scenario": "crossing_high",
                "seed": 3,
                "horizon": tr.steps,
                "dt": 0.1,
                "record": record.model_dump(mode="json"),
                "steps": steps,
            }
        )
    )
    seed = {
        "scenario": "crossing_high",
        "seed": 3,
        "outcome": "collision_pedestrian",
        "steps": 40,
        "label": "collision_pedestrian_robot_fault",
        "tags": [],
        "first_collision_step": 40,
        "min_distance": 1.3,
        "min_clearance": -0.1,
        "mean_command_v": 0.9,
        "max_command_v": 0.9,
        "plan_ms_mean": 0.1,
        "prediction_ade": None,
        "trace": "diagnostics/trace_crossing_high_3.json",
    }
    return {
        "episodes": 1,
        "solved": 0,
        "outcomes": {"collision_pedestrian": 1},
        "taxonomy": data.taxonomy(collision_pedestrian_robot_fault=1),
        "taxonomy_config": {},
        "seeds": [seed],
        "code_version": "0.1.0+test",
        "artifacts": {},
        "wall_s": 1.0,
        "config": {},
        "planner": {
            "name": "orca",
            "variant": None,
            "config": {},
            "config_hash": "c0ffee",
            "model_id": "none",
            "checkpoint_sha256": "",
        },
    }


def test_moment_of_a_planner_without_predictor_shows_scene_heading_and_plan(tmp_path: Path) -> None:
    result = _run_without_forecasts(tmp_path)
    write_diagnostics_report(result, tmp_path, traces={("crossing_high", 3): trace()})
    picture = tmp_path / "figures/moment_crossing_high_3.png"
    assert _pixels(picture, PLAN_RGB) > 40  # the plan drawn
    assert _pixels(picture, PED_RGB) > 80  # pedestrians drawn at that step
    bare = tmp_path / "bare"
    write_diagnostics_report(
        _run_without_forecasts(bare), bare
    )  # no full trace: heading and plan still drawn
    assert _pixels(bare / "figures/moment_crossing_high_3.png", PLAN_RGB) > 40
    assert _pixels(bare / "figures/moment_crossing_high_3.png", PED_RGB) < _pixels(picture, PED_RGB)


def test_rollout_holds_the_command() -> None:
    path = rollout([0.0, 0.0, 0.0], [1.0, 0.0], dt=0.1, seconds=2.0)
    assert path.shape == (21, 2) and np.allclose(path[-1], [2.0, 0.0])
    turning = rollout([0.0, 0.0, np.pi / 2], [1.0, 0.5], dt=0.1, seconds=1.0)
    assert turning[-1, 1] > 0.9 and turning[-1, 0] < 0  # heading up, turning left
