"""The oracle forecaster (``core.predict.oracle``): where nobody reacts to the robot its forecast is where everyone
then is, checked against the episode itself, with the predictive planner driving."""

from __future__ import annotations

import numpy as np

from foresight.core.planners.predictive.planner import PredictivePlanner
from foresight.core.predict.oracle import ORACLE_SIGMA, OracleForecaster
from foresight.core.predict.timebase import PLANNER_TIMEBASE
from foresight.core.sim.episode import run_episode
from tests.unit.sim.scenes import scenario, street_map


def test_the_forecast_is_where_everyone_then_is():
    sc = scenario(street_map(), ped_density=0.3, peds_have_robot_repulsion=False, max_episode_steps=150)
    oracle = OracleForecaster.for_episode(sc, 3)
    forecasts: dict[int, object] = {}
    seen: dict[int, dict[int, np.ndarray]] = {}

    def note(obs, cmd, events, diag):
        forecasts[int(round(obs.time / 0.1))] = oracle.update(obs)
        seen[int(round(obs.time / 0.1))] = dict(
            zip(obs.ped_ids.tolist(), obs.ped_positions.copy(), strict=True)
        )

    res = run_episode(sc, 3, PredictivePlanner(None, oracle), on_step=note)
    assert res.steps > 40 and len(seen[1]) >= 5  # a crowd, and the robot on its way
    checked = 0
    for step, fc in forecasts.items():
        assert fc.source == "oracle" and np.all(fc.sigma == ORACLE_SIGMA)
        for k, t in enumerate(fc.times):
            later = seen.get(step + int(round(t / 0.1)))
            if later is None:
                continue
            for i, pid in enumerate(fc.ped_ids.tolist()):
                if (
                    pid in later and np.hypot(*(later[pid] - seen[step][pid])) < 3.0
                ):  # not respawned in between
                    assert np.allclose(fc.positions[i, k], later[pid], atol=1e-9), (step, pid, t)
                    checked += 1
    assert checked > 1000


def test_someone_the_recording_does_not_hold_gets_constant_velocity():
    oracle = OracleForecaster([np.zeros((0, 2))] * 30, [np.zeros(0, dtype=np.int64)] * 30, dt=0.1)
    from tests.unit.planners.scenes import corridor_map, observation

    obs = observation(corridor_map(), peds=[(10.0, 10.0)], ped_vels=[(1.0, -0.5)])
    fc = oracle.update(obs)
    expected = np.array([10.0, 10.0]) + PLANNER_TIMEBASE.times[:, None] * np.array([1.0, -0.5])
    assert np.allclose(fc.positions[0], expected)


def test_the_oracle_gap_bench_runs_paired_and_refuses_an_unknown_scenario(shared_dir):
    import json
    import os
    import subprocess
    import sys
    from pathlib import Path

    bench = Path(__file__).resolve().parents[3] / "bench" / "oracle_gap.py"
    env = {**os.environ, "FORESIGHT_SHARED": str(shared_dir)}
    run = subprocess.run(
        [
            sys.executable,
            str(bench),
            "--scenarios",
            "classic_cross_trap_low",
            "--seeds-per-scenario",
            "2",
            "--max-steps",
            "60",
            "--forecasters",
            "oracle,cv",
            "--workers",
            "1",
            "--json",
        ],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    assert run.returncode == 0, run.stderr
    out = json.loads(run.stdout)
    assert out["episodes"] == 2 and not out["approximate"] and set(out["forecasters"]) == {"oracle", "cv"}
    for r in out["forecasters"].values():
        assert r["success"] + r["collisions"] + r["timeouts"] == 2
    assert set(out["paired"]["oracle_vs_cv"]) == {"oracle_only", "cv_only", "mcnemar_p"}
    bad = subprocess.run(
        [sys.executable, str(bench), "--scenarios", "no_such_scenario", "--json"],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
    )
    assert bad.returncode == 1 and "no scenario named 'no_such_scenario'" in bad.stderr
    assert len(bad.stderr.strip().splitlines()) == 1


def test_the_oracle_gap_bench_as_is_refuses_a_scenario_where_people_react():
    import subprocess
    import sys
    from pathlib import Path

    repo = Path(__file__).resolve().parents[3]
    run = subprocess.run(
        [
            sys.executable,
            str(repo / "bench" / "oracle_gap.py"),
            "--matrix",
            str(repo / "configs" / "scenarios" / "stress.yaml"),
            "--as-is",
            "--scenarios",
            "crossing_nr100,crossing_nr30",
            "--json",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode == 1 and "'crossing_nr30' has pedestrians who react" in run.stderr
    assert len(run.stderr.strip().splitlines()) == 1
