"""Hard-seed diagnostics: per-step trace with the planner's decision, summary with taxonomy, a PNG and a GIF per seed."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from foresight.core.evaluation.config import DiagnosticsConfig
from foresight.core.evaluation.diagnostics import run_diagnostics
from foresight.core.runtime.context import StageContext
from foresight.core.runtime.refs import BUILTIN_CONFIG_ROOT


def test_diagnostics_of_a_manifest(tmp_path: Path) -> None:
    root = tmp_path / "bundle"
    shutil.copytree(BUILTIN_CONFIG_ROOT, root)
    (root / "hard.yaml").write_text("crossing_high: [3]\n")
    work = tmp_path / "run"
    work.mkdir()
    ctx = StageContext(workdir=work, resolve_bundle=lambda _b: root)
    res = run_diagnostics(
        DiagnosticsConfig(
            bundle="t", seed_manifest="hard.yaml", max_steps=20, planner={"name": "predictive", "model": "cv"}
        ),
        ctx,
    )
    assert res.episodes == 1 and [(s.scenario, s.seed) for s in res.seeds] == [("crossing_high", 3)]
    s = res.seeds[0]
    assert s.outcome == "timeout" and s.label == "timeout_slow_progress" and s.steps == 20
    assert (work / s.render).stat().st_size > 1000
    gif = (work / s.replay).read_bytes()
    assert gif[:6] in (b"GIF87a", b"GIF89a") and len(gif) > 1000
    trace = json.loads((work / s.trace).read_text())
    assert len(trace["steps"]) == 20
    step = trace["steps"][5]
    assert len(step["robot"]) == 5 and len(step["command"]) == 2 and step["min_distance"] > 0
    assert {"cost", "terms", "command"} <= set(step["chosen"])
    pva = step["predicted_vs_actual"]
    assert pva and len(pva[0]["predicted"]) == len(pva[0]["times"]) == len(pva[0]["actual"])
    # the seed behaves exactly as in an evaluation of the same manifest
    from foresight.core.evaluation.config import EvaluationConfig
    from foresight.core.evaluation.record import EpisodeRecord
    from foresight.core.evaluation.runner import read_records, run_evaluation

    ev = tmp_path / "ev"
    ev.mkdir()
    run_evaluation(
        EvaluationConfig(
            bundle="t", seed_manifest="hard.yaml", max_steps=20, planner={"name": "predictive", "model": "cv"}
        ),
        StageContext(workdir=ev, resolve_bundle=lambda _b: root, workers=2),
    )
    (evaluated,) = read_records(ev / "episodes.jsonl")
    assert EpisodeRecord.model_validate(trace["record"]).comparable() == evaluated.comparable()
    summary = json.loads((work / "diagnostics.json").read_text())
    assert summary["taxonomy"]["timeout_slow_progress"] == 1 and summary["planner"]["config_hash"]
    assert "| crossing_high | 3 | timeout |" in (work / "diagnostics_report.md").read_text()
