"""bench/forecast_near_robot.py: forecast errors by the walker's gap to the robot, from an episode trace."""

from __future__ import annotations

import gzip
import json
import subprocess
import sys
from pathlib import Path

import pytest

from tests.unit.bench_scripts import BENCH as BENCH_DIR
from tests.unit.bench_scripts import load_bench

BENCH = BENCH_DIR / "forecast_near_robot.py"


def _trace(scenario: str = "doorway_nr100") -> dict:
    """Robot standing at the origin (radius 1); walker 1 at 1 m/s along y = 2.4 (gap 1.0 m: near), walker 2 along
    y = 9.4 (gap 8 m: far), 0.1 s steps. One forecast at step 2: walker 1 exact, walker 2 0.5 m off in y throughout;
    walker 3 appears at step 2 (no step before it: not scored)."""
    steps, times = 30, [0.2, 0.4, 0.6]
    peds = [
        [[1, 0.1 * t, 2.4], [2, 0.1 * t, 9.4]] + ([[3, 5.0, 5.0]] if t >= 2 else []) for t in range(steps + 1)
    ]
    forecast = {
        "step": 2,
        "ids": [1, 2, 3],
        "times": times,
        "positions": [[[0.2 + t, 2.4] for t in times], [[0.2 + t, 9.9] for t in times], [[5.0, 5.0]] * 3],
    }
    return {
        "scenario": scenario,
        "dt": 0.1,
        "stride": 1,
        "robot_radius": 1.0,
        "ped_radius": 0.4,
        "robot": [[0.0, 0.0, 0.0, 0.0, 0.0]] * (steps + 1),
        "peds": peds,
        "forecasts": [forecast],
    }


def test_errors_per_walker_and_band() -> None:
    nav = load_bench("forecast_near_robot")
    out = sorted(nav.trace_errors(_trace()))
    assert [o[0] for o in out] == ["far", "near"]
    (_, far_ade, far_fde), (_, near_ade, near_fde) = out
    assert far_ade == pytest.approx(0.5) and far_fde == pytest.approx(0.5)
    assert near_ade == pytest.approx(0.0, abs=1e-9) and near_fde == pytest.approx(0.0, abs=1e-9)
    assert nav.condition_of("doorway_nr100") == "nonreactive_1" and nav.condition_of("replay_x_0") == "all"


def test_the_command_reads_evaluation_folders_and_refuses_what_is_not_one(tmp_path: Path) -> None:
    (tmp_path / "run" / "traces").mkdir(parents=True)
    (tmp_path / "run" / "traces" / "doorway_nr100__0.json.gz").write_bytes(
        gzip.compress(json.dumps(_trace()).encode())
    )
    ok = subprocess.run(
        [sys.executable, str(BENCH), f"learned={tmp_path / 'run'}", "--json"], capture_output=True, text=True
    )
    rows = json.loads(ok.stdout)["runs"]["learned"]["rows"]
    assert ok.returncode == 0 and {(r["band"], r["samples"]) for r in rows} == {("near", 1), ("far", 1)}
    empty = subprocess.run([sys.executable, str(BENCH), f"x={tmp_path}"], capture_output=True, text=True)
    assert empty.returncode == 1 and "no episode traces" in empty.stderr
    unlabelled = subprocess.run([sys.executable, str(BENCH), str(tmp_path)], capture_output=True, text=True)
    assert unlabelled.returncode == 2 and "expected LABEL=DIR" in unlabelled.stderr
