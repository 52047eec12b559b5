"""Reports from real stage output: a tiny evaluation (goal-seeking planner, 2 scenarios x 2 seeds, short
horizon), so a change of the evaluation's result models that the reports cannot read shows up here."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from foresight.core.evaluation.config import EvaluationConfig
from foresight.core.evaluation.evaluation_result import EvaluationResult
from foresight.core.evaluation.runner import run_evaluation
from foresight.core.reports.campaign import write_campaign_report
from foresight.core.reports.compare import write_comparison_report
from foresight.core.reports.evaluation import write_evaluation_report
from foresight.core.runtime.context import StageContext
from foresight.core.runtime.refs import BUILTIN_CONFIG_ROOT

from .data import assert_page, assert_picture, campaign


@pytest.fixture(scope="module")
def evaluated(tmp_path_factory: pytest.TempPathFactory) -> tuple[EvaluationResult, Path]:
    work = tmp_path_factory.mktemp("eval")
    cfg = EvaluationConfig.model_validate(
        dict(
            scenarios=["crossing_low", "head_on_corridor_high"],
            seeds_per_scenario=2,
            max_steps=40,
            planner={"name": "goal"},
        )
    )
    ctx = StageContext(workdir=work, resolve_bundle=lambda _b: BUILTIN_CONFIG_ROOT)
    return run_evaluation(cfg, ctx), work


def test_report_of_a_real_evaluation(evaluated: tuple[EvaluationResult, Path]) -> None:
    res, work = evaluated
    paths = write_evaluation_report(res, work)
    md = (work / "report.md").read_text()
    assert_page((work / "report.html").read_text())
    for p in paths:
        if p.suffix == ".png":
            assert_picture(p)
    assert (work / "figures/success_per_scenario.png") in paths
    assert f"{res.episodes} episodes" in md and f"{100 * (res.success_rate or 0):.1f}%" in md
    for scenario in ("crossing_low", "head_on_corridor_high"):
        assert f"| {scenario} | 2 |" in md
    if sum(res.taxonomy.values()):
        assert (work / "figures/taxonomy_per_family.png") in paths
    assert (
        res.planner.config_hash[:12] in md and "[evaluation.json](evaluation.json)" not in md
    )  # labelled links
    assert "(evaluation.json)" in md and "(episodes.jsonl)" in md


def test_report_from_the_json_file_matches_the_model(
    evaluated: tuple[EvaluationResult, Path], tmp_path: Path
) -> None:
    res, work = evaluated
    write_evaluation_report(work / "evaluation.json", tmp_path)
    write_evaluation_report(res, tmp_path / "model")
    assert (tmp_path / "report.md").read_text() == (tmp_path / "model" / "report.md").read_text()


def test_ab_of_a_run_against_itself_has_zero_deltas(
    evaluated: tuple[EvaluationResult, Path], tmp_path: Path
) -> None:
    res, _ = evaluated
    write_comparison_report(res, json.loads(res.model_dump_json()), tmp_path, labels=("run", "same run"))
    md = (tmp_path / "report.md").read_text()
    assert "delta +0.00 pp" in md and "interval includes 0" in md and "Warning" not in md


def test_campaign_ab_from_cell_episode_files(
    evaluated: tuple[EvaluationResult, Path], tmp_path: Path
) -> None:
    _, work = evaluated
    camp = campaign(gate_passed=True)
    (tmp_path / "cells").mkdir()
    for c in camp["ranked"]:
        shutil.copy(work / "episodes.jsonl", tmp_path / c["episodes_file"])
    md = next(p for p in write_campaign_report(camp, tmp_path) if p.name == "report.md").read_text()
    assert "## A/B: careful @ cv vs base @ cv" in md and "### Per-scenario success" in md
    assert "![" in md and "figures/campaign_ab.png" in md and (tmp_path / "figures/campaign_ab.png").is_file()
    assert "| crossing_low |" in md and "delta +0.00 pp" in md
    # the same episodes in both cells: the verdict is the paired test (no discordant pair: p = 1)
    assert "0 succeed only with careful @ cv, 0 only with base @ cv; McNemar exact p = 1.000" in md
    assert "| success | " in md and "mcnemar_exact" in md and "wilcoxon_signed_rank" in md


def test_campaign_ab_without_episode_files_says_so(tmp_path: Path) -> None:
    md = next(p for p in write_campaign_report(campaign(), tmp_path) if p.name == "report.md").read_text()
    assert "## A/B: careful @ cv vs base @ cv" in md and "episode files are not in this folder" in md
