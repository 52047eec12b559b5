"""Each report writes its figures, Markdown and a self-contained HTML page with every section and the numbers."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from foresight.core.evaluation.campaign_result import CampaignResult
from foresight.core.evaluation.diagnostics import DiagnosticsResult
from foresight.core.evaluation.evaluation_result import EvaluationResult
from foresight.core.evaluation.stats import rate
from foresight.core.reports.campaign import write_campaign_report
from foresight.core.reports.compare import rate_delta, write_comparison_report
from foresight.core.reports.diagnostics import write_diagnostics_report
from foresight.core.reports.evaluation import write_evaluation_report
from foresight.core.reports.pipeline import write_pipeline_report
from foresight.core.reports.pipeline_summary import (
    PipelineSummary,
    StageEntry,
    best_from_campaign,
    gate_entry,
)
from foresight.core.reports.training import write_training_report
from foresight.core.training.config import TrainingSummary, TrainResult

from . import data
from .scenes import predictions, small_map, trace


def _read(paths: list[Path]) -> tuple[str, str]:
    md = next(p for p in paths if p.name == "report.md").read_text()
    page = next(p for p in paths if p.name == "report.html").read_text()
    data.assert_page(page)
    for p in paths:
        if p.suffix in (".png", ".gif"):
            data.assert_picture(p)
    return md, page


def _sections(md: str, page: str, names: list[str]) -> None:
    for name in names:
        assert f"## {name}" in md, name
        assert f">{name}</h2>" in page, name


def _images_exist(page: str, root: Path) -> list[str]:
    import re

    srcs = re.findall(r'<img src="([^"]+)"', page)
    for s in srcs:
        assert not s.startswith("/") and (root / s).is_file(), s
    return srcs


EVAL_SECTIONS = [
    "Summary",
    "Quality gate",
    "Integrity",
    "Success and collisions per scenario",
    "Per family",
    "Per family and density",
    "Failure taxonomy",
    "Failed episodes",
    "Metrics",
    "Artifacts",
]


def test_evaluation_report(tmp_path: Path) -> None:
    res = data.evaluation(failures=True)
    (tmp_path / "evaluation.json").write_text(json.dumps(res))
    paths = write_evaluation_report(tmp_path / "evaluation.json", tmp_path)
    md, page = _read(paths)
    _sections(md, page, EVAL_SECTIONS)
    srcs = _images_exist(page, tmp_path)
    assert {
        "figures/success_per_scenario.png",
        "figures/success_per_family.png",
        "figures/taxonomy_per_family.png",
    } <= set(srcs)
    assert "success 70.0%" in md and "collision 10.0%" in md and "(7/10)" in md
    assert "| head_on_corridor_high | 5 | 60.0% [" in md and "1200, 1204" in md
    assert "| timeout_freeze | 1 |" in md and "freeze_min_s = 3.0" in md
    assert "`m-7`" in md and "FAILED" in md and "| success_rate | FAIL | 0.700 | 0.800 |" in md
    assert (
        "`foresight scenarios witness --matrix " in md
        and "--episodes episodes.jsonl --players witnesses`" in md
    )


def test_evaluation_without_failures_keeps_its_sections(tmp_path: Path) -> None:
    md, page = _read(write_evaluation_report(data.evaluation(failures=False), tmp_path))
    _sections(md, page, EVAL_SECTIONS)
    assert "No failed episodes" in md and "Every episode succeeded" in md and "scenarios witness" not in md
    assert not (tmp_path / "figures" / "taxonomy_per_family.png").exists()
    assert "success 100.0%" in md and "PASSED" in md


def test_campaign_report(tmp_path: Path) -> None:
    md, page = _read(write_campaign_report(data.campaign(gate_passed=False), tmp_path))
    _sections(
        md, page, ["Summary", "Ranking", "Hard-suite failure taxonomy", "Closed-loop gate", "Artifacts"]
    )
    assert set(_images_exist(page, tmp_path)) == {
        "figures/campaign_ranking.png",
        "figures/campaign_taxonomy.png",
    }
    assert "Best: **careful @ cv**" in md and "hard success 75.0%" in md and "global success 85.0%" in md
    assert "| 1 | careful | cv | 75.0% [" in md and "| 3 | fast | cv | 25.0% [" in md
    assert "**FAILED**" in md and "New failure mechanisms on the hard suite: timeout_freeze." in md
    assert "| timeout_freeze | 1 | 0 | +1 |" in md and "cells/careful__cv.jsonl" in md


def test_campaign_without_gate(tmp_path: Path) -> None:
    res = data.campaign()
    res["gate"], res["status"] = None, "completed"
    md, _ = _read(write_campaign_report(res, tmp_path))
    assert "## Closed-loop gate" in md and "No closed-loop gate configured" in md


def test_training_report(tmp_path: Path) -> None:
    md, page = _read(write_training_report(data.training(proxy=True), tmp_path))
    _sections(md, page, ["Summary", "Training curves", "Training gate", "Dataset", "Epochs"])
    assert _images_exist(page, tmp_path) == ["figures/training_curves.png"]
    assert "Selected epoch **6** of 6 by proxy" in md and "0.267 m" in md and "0.410 m" in md
    assert "| val_ade_below_cv | ok | 0.267 | 0.410 |" in md and "| samples | 4321 |" in md
    assert "proxy success per epoch" in md and "| 6 | 0.0833 |" in md


def test_comparison_report(tmp_path: Path) -> None:
    a, b = data.evaluation(failures=True), data.evaluation(failures=False)
    b["planner"] = dict(b["planner"], variant="fast")
    md, page = _read(write_comparison_report(a, b, tmp_path, labels=("careful", "fast")))
    _sections(md, page, ["Runs", "Metric deltas", "Per-scenario success", "Failure taxonomy", "Verdict"])
    assert _images_exist(page, tmp_path) == ["figures/ab_comparison.png"]
    assert "| success | 70.0% [" in md and "+30.00 pp [" in md
    assert "| crossing_low | 80.0% [" in md and "| timeout_freeze | 1 | 0 | -1 |" in md


def test_newcombe_interval_of_a_rate_delta() -> None:
    a, b = rate(5, 10), rate(9, 10)  # Wilson [0.2366, 0.7634] and [0.5958, 0.9821]
    d = rate_delta(a, b)
    assert d.value == pytest.approx(0.4)
    # Newcombe's hybrid score: d -/+ sqrt of the squared inner/outer Wilson half-widths
    assert d.low == pytest.approx(0.4 - ((0.9 - 0.5958) ** 2 + (0.7634 - 0.5) ** 2) ** 0.5, abs=1e-3)
    assert d.high == pytest.approx(0.4 + ((0.9821 - 0.9) ** 2 + (0.5 - 0.2366) ** 2) ** 0.5, abs=1e-3)
    assert d.low < 0 < d.high  # 5/10 vs 9/10 is not a clear difference
    assert rate_delta(rate(0, 0), rate(1, 2)).value is None


def test_pipeline_summary_with_a_failing_gate(tmp_path: Path) -> None:
    camp = CampaignResult.model_validate(data.campaign(gate_passed=False))
    summary = PipelineSummary(
        name="quickstart",
        status="failed_gate",
        exit_code=2,
        stages=[
            StageEntry(
                name="train",
                status="completed",
                wall_s=40.0,
                headline="val ADE 0.27 m",
                report="train/report.html",
            ),
            StageEntry(
                name="campaign",
                status="failed_gate",
                wall_s=99.0,
                report="campaign/report.html",
                artifacts={"summary": "campaign/campaign_summary.json"},
            ),
            StageEntry(name="promote", status="skipped"),
        ],
        gates=[
            gate_entry("training", TrainingSummary.model_validate(data.training()).gate_result()),
            gate_entry("closed_loop", camp.gate),
            gate_entry("evaluation", None),
        ],
        best=best_from_campaign(camp),
        promoted_model=None,
        promotion="closed-loop gate failed: not promoted",
        artifacts={"pipeline.json": "pipeline.json"},
    )
    md, page = _read(
        write_pipeline_report(summary.model_dump(), tmp_path, campaign=camp, training=data.training())
    )
    _sections(
        md,
        page,
        [
            "Verdict",
            "Stages",
            "Gates",
            "Best campaign variant",
            "Promoted model",
            "Training curves",
            "Artifacts",
        ],
    )
    assert len(_images_exist(page, tmp_path)) == 2
    assert "Status **failed_gate** (exit code 2)" in md and "**FAILED** (closed_loop)" in md
    assert "| hard | 75.0% | 0.45 |" in md and "| global | 85.0% | 0.65 |" in md and "**careful**" in md
    assert "No model was promoted." in md and "not evaluated" in md and "val_ade_below_cv" in md
    assert "[campaign: report](campaign/report.html)" in md


def _diagnostics(tmp_path: Path) -> dict:
    """A diagnostics run of one collided seed (trace JSON with predictions) and one solved seed (no trace)."""
    tr = trace()
    steps = []
    preds = {s: (ids, pos) for s, ids, pos, _ in predictions()}
    for t in range(tr.steps):
        rows = []
        if t in preds:
            ids, pos = preds[t]
            rows = [
                {
                    "ped_id": int(i),
                    "times": [0.4] * 8,
                    "predicted": p.tolist(),
                    "actual": [None] * 7 + [[1.0, 2.0]],
                }
                for i, p in zip(ids, pos, strict=True)
            ]
        steps.append(
            {
                "step": t,
                "robot": tr.robot[t].tolist(),
                "min_distance": 2.0 - t / 60,
                "predicted_vs_actual": rows,
            }
        )
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
        "tags": ["late_reaction"],
        "first_collision_step": 40,
        "min_distance": 1.3,
        "min_clearance": -0.1,
        "mean_command_v": 1.1,
        "max_command_v": 1.5,
        "plan_ms_mean": 3.2,
        "prediction_ade": 0.45,
        "trace": "diagnostics/trace_crossing_high_3.json",
    }
    solved = {
        "scenario": "crossing_low",
        "seed": 7,
        "outcome": "success",
        "steps": 90,
        "label": None,
        "tags": [],
        "first_collision_step": None,
        "min_distance": 2.0,
        "min_clearance": 0.8,
        "mean_command_v": 1.0,
        "max_command_v": 1.2,
        "plan_ms_mean": 3.0,
        "prediction_ade": None,
        "trace": "missing.json",
    }
    return {
        "episodes": 2,
        "solved": 1,
        "outcomes": {"collision_pedestrian": 1, "success": 1},
        "taxonomy": data.taxonomy(collision_pedestrian_robot_fault=1),
        "taxonomy_config": {},
        "seeds": [seed, solved],
        "code_version": "0.1.0+test",
        "artifacts": {"summary": "diagnostics.json"},
        "planner": {
            "name": "predictive",
            "variant": None,
            "config": {},
            "config_hash": "c0ffee",
            "model_id": "m-7",
            "checkpoint_sha256": "deadbeef" * 8,
        },
        "wall_s": 3.0,
        "config": {},
    }


def test_diagnostics_report_with_moment_and_replay(tmp_path: Path) -> None:
    res = _diagnostics(tmp_path)
    paths = write_diagnostics_report(
        res, tmp_path, maps={"crossing_high": small_map()}, traces={("crossing_high", 3): trace()}
    )
    md, page = _read(paths)
    _sections(md, page, ["Summary", "Failure taxonomy", "Hard seeds", "Episodes", "Artifacts"])
    assert "### crossing_high seed 3: collision_pedestrian" in md and "### crossing_low seed 7: success" in md
    srcs = _images_exist(page, tmp_path)
    assert {
        "figures/diagnostics_taxonomy.png",
        "figures/moment_crossing_high_3.png",
        "diagnostics/replay_crossing_high_3.gif",
    } <= set(srcs)
    assert (
        "Solved **1/2**" in md
        and "| crossing_high | 3 | collision_pedestrian | collision_pedestrian_robot_fault |" in md
    )
    assert "min clearance -0.10 m" in md and "No per-step trace stored" in md and "No replay" in md


def test_diagnostics_report_links_an_existing_replay(tmp_path: Path) -> None:
    res = _diagnostics(tmp_path)
    (tmp_path / "diagnostics/crossing_high_3.gif").write_bytes(b"GIF89a")
    md = write_diagnostics_report(res, tmp_path)[-2].read_text()
    assert "![Animated replay (GIF) with predicted pedestrian futures](diagnostics/crossing_high_3.gif)" in md
    assert "moment_crossing_high_3.png" in md  # drawn from the trace JSON alone, without a map


def test_stage_dispatch(tmp_path: Path) -> None:
    from foresight.core.errors import ConfigError
    from foresight.core.reports.stage import write_stage_report

    (tmp_path / "training_summary.json").write_text(json.dumps(data.training()))
    train_result = {
        "checkpoint": "model.pt",
        "summary": "training_summary.json",
        "best_epoch": 6,
        "val_ade": 0.27,
        "val_fde": 0.53,
        "cv_val_ade": 0.41,
        "cv_val_fde": 0.93,
        "selection_mode": "proxy",
        "gates_passed": True,
    }
    paths = write_stage_report("train", train_result, tmp_path)
    assert (tmp_path / "figures/training_curves.png") in paths and "Selected epoch **6**" in paths[
        -2
    ].read_text()
    assert (
        write_stage_report("evaluate", data.evaluation(), tmp_path / "e")[-1]
        == tmp_path / "e" / "report.html"
    )
    with pytest.raises(ConfigError):
        write_stage_report("collect", {}, tmp_path)


def test_stage_headlines() -> None:
    from foresight.core.reports.pipeline import headline

    assert (
        headline("evaluate", EvaluationResult.model_validate(data.evaluation()))
        == "success 70.0%, collision 10.0% over 10 episodes; gate FAILED"
    )
    assert headline("campaign", CampaignResult.model_validate(data.campaign())).startswith(
        "best careful: hard success 75.0%, global 85.0%"
    )
    assert (
        headline("train", TrainingSummary.model_validate(data.training()))
        == "val ADE 0.267 m (CV 0.410), FDE 0.533 m (CV 0.930), epoch 6"
    )
    assert headline(
        "train",
        TrainResult(
            val_ade=0.3,
            val_fde=0.6,
            cv_val_ade=0.4,
            cv_val_fde=0.9,
            best_epoch=3,
            checkpoint="model.pt",
            summary="s.json",
            selection_mode="val_loss",
            gates_passed=True,
        ),
    ).startswith("val ADE 0.300 m (CV 0.400)")
    diagnosed = DiagnosticsResult.model_construct(solved=2, episodes=5)
    assert headline("diagnose", diagnosed) == "solved 2/5 hard seeds" and headline("x", None) == ""


def test_campaign_report_shows_the_paired_tests_against_the_baseline(tmp_path: Path) -> None:
    from foresight.core.evaluation.delta import paired_delta

    res = data.campaign()
    success = paired_delta(
        "success", [False] * 9 + [True] * 15, [True] * 24
    )  # 9 discordant pairs, variant's way
    clearance = paired_delta("min_clearance", [0.2] * 24, [0.3 + 0.01 * i for i in range(24)])
    res["ranked"][0]["vs_baseline"] = {
        "hard": {"success": success.model_dump(), "min_clearance": clearance.model_dump()},
        "global": None,
    }
    md, _ = _read(write_campaign_report(res, tmp_path))
    assert "### Paired against the baseline variant" in md
    assert f"| careful @ cv | hard | +37.5 pp | {2 / 2**9:.3g} (0/9) * | +0.21 m |" in md
    res["ranked"][0]["changed_vs_baseline"] = {
        "hard": [{"scenario": "door_high", "seed": 7, "a": "timeout", "b": "success"}],
        "global": [],
    }
    md, _ = _read(write_campaign_report(res, tmp_path))
    assert "| careful @ cv | hard | door_high | 7 | timeout | success |" in md


def test_a_renamed_result_field_is_an_error_naming_it_not_a_dash(tmp_path: Path) -> None:
    """Reports validate the stage's result model on read: a renamed field fails loudly, naming the field."""
    from pydantic import ValidationError

    renamed = data.evaluation()
    renamed["planner"]["hash"] = renamed["planner"].pop("config_hash")
    with pytest.raises(ValidationError, match="planner.config_hash"):
        write_evaluation_report(renamed, tmp_path)
    assert not (tmp_path / "report.md").exists()


def test_evaluation_report_counts_success_on_the_solvable_episodes(tmp_path: Path) -> None:
    """Two of the three failures no robot could have avoided: the summary says so and scores the other 8 episodes;
    a result recorded before the reachability check (no such rate) shows neither row."""
    res = data.evaluation(failures=True)
    md_old, _ = _read(write_evaluation_report(res, tmp_path / "old"))
    assert "solvable" not in md_old
    res["aggregates"]["overall"]["rates"]["unsolvable"] = data.rate_d(2, 10)
    md, _ = _read(write_evaluation_report(res, tmp_path / "new"))
    assert "| unsolvable: no robot could reach the goal in time | 20.0% [" in md
    assert "| success on the solvable episodes | 7/8 (87.5%) |" in md
