"""``foresight.evaluate`` / ``foresight.simulate`` on a user's planner: the same records as
``foresight evaluate --local`` with the same planner, and a failing planner is a planner_error record."""

from __future__ import annotations

import json
from pathlib import Path

import foresight
from foresight.cli.main import main
from foresight.core.evaluation.evaluation_result import EvaluationResult
from tests.results import without
from tests.unit.planners.user_planner import Cautious, broken_factory

NOISE = {"wall_s", "code_version", "plan_ms_mean", "plan_ms_p95", "plan_ms_max", "timing", "artifacts"}
SCENARIOS = ["crossing_low", "head_on_corridor_high"]


def _records(folder: Path) -> list[dict]:
    return [without(json.loads(line), NOISE) for line in (folder / "episodes.jsonl").read_text().splitlines()]


def test_evaluate_matches_cli_local_record_for_record(tmp_path: Path, capsys) -> None:  # noqa: ANN001
    result = foresight.evaluate(
        Cautious, scenarios=SCENARIOS, seeds=2, max_steps=120, config={"speed": 0.8}, out=tmp_path / "api"
    )
    assert isinstance(result, EvaluationResult) and result.episodes == 4
    assert result.planner.name == "tests.unit.planners.user_planner:Cautious"
    assert result.planner.config == {"speed": 0.8} and result.planner.origin == "module"
    code = main(
        [
            "evaluate",
            "--local",
            "--matrix",
            "configs/scenarios/classic_interactions.yaml",
            "--planner",
            "tests.unit.planners.user_planner:Cautious",
            "--planner-config",
            '{"speed": 0.8}',
            "--scenarios",
            ",".join(SCENARIOS),
            "--seeds-per-scenario",
            "2",
            "--max-steps",
            "120",
            "--out",
            str(tmp_path / "cli"),
            "--json",
        ]
    )
    assert code in (0, 2)  # 2 = the gate failed: a result
    cli = json.loads(capsys.readouterr().out)["result"]
    assert _records(tmp_path / "api") == _records(tmp_path / "cli")
    assert without(result.model_dump(mode="json"), NOISE) == without(cli, NOISE)
    assert {r["outcome"] for r in _records(tmp_path / "api")} - {"error"}  # it really drove


def test_evaluate_with_workers_rebuilds_the_planner_by_name(tmp_path: Path) -> None:
    one = foresight.evaluate(Cautious, scenarios=SCENARIOS[:1], seeds=2, max_steps=60, out=tmp_path / "one")
    two = foresight.evaluate(
        Cautious, scenarios=SCENARIOS[:1], seeds=2, max_steps=60, workers=2, out=tmp_path / "two"
    )
    assert _records(tmp_path / "one") == _records(tmp_path / "two")
    assert one.success_rate == two.success_rate


def test_a_failing_planner_instance_is_a_planner_error_record() -> None:
    run = foresight.simulate(broken_factory(), scenario="crossing_low", seed=3, max_steps=50)
    assert run.record.outcome == "error" and run.record.steps == 2
    assert "boom at step 2" in run.record.error and run.record.taxonomy.label == "planner_error"


def test_simulate_returns_the_record_and_the_trace() -> None:
    run = foresight.simulate("toy", scenario="crossing_low", seed=1, max_steps=40, config={"speed": 0.6})
    assert run.record.planner == "toy" and run.record.steps == run.trace.steps
    assert run.trace.command[:, 0].max() <= 0.6 + 1e-9
