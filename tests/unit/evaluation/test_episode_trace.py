"""Every evaluated episode stores a compact, bounded trace (what the browser's episode player draws)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from foresight.core.evaluation.config import EvaluationConfig
from foresight.core.evaluation.runner import read_records, run_evaluation
from foresight.core.render import episode_trace
from foresight.core.render.episode_trace import read_compact, trace_name
from foresight.core.runtime.refs import BUILTIN_CONFIG_ROOT
from foresight.local import local_context


def _evaluate(tmp_path: Path, planner: dict, scenarios: list[str], max_steps: int) -> Path:
    ctx = local_context(tmp_path, {"builtin": BUILTIN_CONFIG_ROOT}, quiet=True)
    config = EvaluationConfig.model_validate(
        {
            "matrix": "scenarios/classic_interactions.yaml",
            "planner": planner,
            "scenarios": scenarios,
            "seeds_per_scenario": 1,
            "max_steps": max_steps,
        }
    )
    run_evaluation(config, ctx)
    return tmp_path


def test_every_episode_has_a_trace_matching_its_record(tmp_path: Path) -> None:
    wd = _evaluate(tmp_path, {"name": "goal"}, ["crossing_high", "head_on_corridor_high"], 200)
    records = read_records(wd / "episodes.jsonl")
    assert len(records) == 2
    for rec in records:
        tr = read_compact(wd / trace_name(rec.scenario, rec.seed))
        assert tr["outcome"] == rec.outcome and tr["steps"] == rec.steps and tr["frames"][-1] == rec.steps
        assert len(tr["robot"]) == len(tr["peds"]) == len(tr["command"]) == len(tr["frames"])
        assert tr["goal_tolerance"] > 0 and tr["robot_radius"] == 1.0 and tr["map"]["obstacles"]
        if rec.collision:  # the collision is the last frame, and the struck pedestrian is there
            assert tr["collision"]["step"] == rec.steps
            assert tr["collision"]["ped_id"] in [p[0] for p in tr["peds"][-1]]
            x, y = tr["robot"][-1][:2]
            px, py = next(p[1:] for p in tr["peds"][-1] if p[0] == tr["collision"]["ped_id"])
            assert (
                np.hypot(px - x, py - y) <= tr["robot_radius"] + tr["ped_radius"] + 0.05
            )  # touching, not "at a distance"
        else:
            assert tr["collision"] is None


def test_forecasts_are_kept_and_long_episodes_are_thinned(tmp_path: Path, monkeypatch) -> None:  # noqa: ANN001
    monkeypatch.setattr(episode_trace, "MAX_FRAMES", 25)
    wd = _evaluate(tmp_path, {"name": "predictive", "model": "cv"}, ["crossing_low"], 120)
    rec = read_records(wd / "episodes.jsonl")[0]
    path = wd / trace_name(rec.scenario, rec.seed)
    tr = read_compact(path)
    assert (
        len(tr["frames"]) <= 26
        and tr["frames"][0] == 0
        and tr["frames"][-1] == rec.steps
        and tr["stride"] > 1
    )
    assert tr["forecasts"], "the predictive planner's logged forecasts are in the trace"
    f = tr["forecasts"][0]
    assert len(f["ids"]) == len(f["positions"]) and all(len(p) == len(f["times"]) for p in f["positions"])
    assert f["sigma"] is not None and len(f["sigma"]) == len(f["ids"])  # the forecast's spread, per point
    assert all(len(s) == len(f["times"]) and min(s) >= 0 for s in f["sigma"])
    assert path.stat().st_size < 200_000
