"""`foresight evaluate` prints JSON with the rates at top level and exits 2 on a failing gate."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from foresight.cli.main import main
from foresight.core.runtime.refs import BUILTIN_CONFIG_ROOT

MATRIX = str(BUILTIN_CONFIG_ROOT / "scenarios" / "classic_interactions.yaml")


def test_evaluate_json_and_gate_exit_code(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    argv = [
        "evaluate",
        "--matrix",
        MATRIX,
        "--planner",
        "goal",
        "--scenarios",
        "crossing_low",
        "--seeds-per-scenario",
        "1",
        "--max-steps",
        "20",
        "--json",
        "--out",
        str(tmp_path),
        "--local",
    ]
    rc = main([*argv, "--min-success", "1.0"])  # 20 steps cannot reach the goal: the gate fails
    job = json.loads(capsys.readouterr().out)  # the job envelope, as a server job's (id None in-process)
    data = job["result"]
    assert job["kind"] == "evaluate" and job["status"] == "succeeded" and job["verdict"] == "failed_gate"
    assert rc == 2 and data["exit_code"] == 2 and data["status"] == "failed_gate"
    assert data["success_rate"] == 0.0 and data["collision_rate"] == 0.0 and data["episodes"] == 1
    assert (tmp_path / "evaluation.json").is_file()
    assert main([*argv, "--min-success", "0.0"]) == 0


def test_a_local_run_writes_its_report_page_and_names_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rc = main(
        [
            "evaluate",
            "--matrix",
            MATRIX,
            "--planner",
            "goal",
            "--scenarios",
            "crossing_low",
            "--seeds-per-scenario",
            "1",
            "--max-steps",
            "20",
            "--out",
            str(tmp_path),
            "--local",
        ]
    )
    out = capsys.readouterr().out
    assert rc in (0, 2) and f"report: {(tmp_path / 'report.html').resolve()}" in out
    assert (tmp_path / "report.html").is_file() and (tmp_path / "report.md").is_file()
    assert len(list((tmp_path / "traces").glob("*.json.gz"))) == 1  # the episode's trace for the player


def test_bad_input_is_one_error_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rc = main(
        [
            "evaluate",
            "--matrix",
            MATRIX,
            "--planner",
            "predictive",
            "--model",
            "no-such-model",
            "--scenarios",
            "crossing_low",
            "--out",
            str(tmp_path),
            "--local",
        ]
    )
    err = capsys.readouterr().err
    assert rc == 1 and err.startswith("foresight: error:") and "no-such-model" in err


def _safety(folder: Path) -> list[tuple]:
    rows = [json.loads(line) for line in (folder / "episodes.jsonl").read_text().splitlines()]
    return [(r["scenario"], r["seed"], r["outcome"], r["steps"], r["safety"]["min_distance"]) for r in rows]


def test_override_runs_the_matrix_under_other_conditions_in_every_worker(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = [
        "evaluate",
        "--matrix",
        MATRIX,
        "--planner",
        "goal",
        "--scenarios",
        "crossing_high",
        "--seeds-per-scenario",
        "2",
        "--max-steps",
        "150",
        "--json",
        "--local",
    ]
    over = ["--override", "ped_speed_tier=brisk", "--override", "nonreactive_fraction=1"]
    assert main([*argv, "--out", str(tmp_path / "plain")]) in (0, 2)
    assert main([*argv, *over, "--out", str(tmp_path / "one")]) in (0, 2)
    assert main([*argv, *over, "--workers", "2", "--out", str(tmp_path / "two")]) in (0, 2)
    summary = json.loads((tmp_path / "two" / "evaluation.json").read_text())
    assert summary["config"]["scenario_overrides"] == {
        "simulation_config": {"ped_speed_tier": "brisk", "nonreactive_fraction": 1}
    }
    assert _safety(tmp_path / "one") == _safety(tmp_path / "two")  # pool workers load the same conditions
    assert _safety(tmp_path / "one") != _safety(tmp_path / "plain")


def test_override_errors_name_the_key(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    base = [
        "evaluate",
        "--matrix",
        MATRIX,
        "--planner",
        "goal",
        "--scenarios",
        "crossing_low",
        "--local",
        "--out",
        str(tmp_path),
    ]
    assert main([*base, "--override", "ped_speed_tier"]) == 1
    assert "--override" in capsys.readouterr().err
    assert main([*base, "--override", "simulation_config.no_such_key=1"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "simulation_config.no_such_key: unsupported key" in err[0]


def test_campaign_takes_overrides_into_both_suites_and_its_fingerprints(tmp_path: Path) -> None:
    from foresight.core.evaluation.campaign import _fingerprint, prepare_campaign
    from foresight.core.evaluation.config import CampaignConfig
    from foresight.core.runtime.context import StageContext

    over = {"simulation_config": {"ped_speed_tier": "realistic", "nonreactive_fraction": 1.0}}
    base = dict(
        seed_manifest="seeds/classic_eval_hard_smoke.yaml",
        variants=[{"name": "default"}],
        scenarios=["crossing_low"],
        seeds_per_scenario=1,
    )
    ctx = StageContext(workdir=tmp_path, resolve_bundle=lambda ident: BUILTIN_CONFIG_ROOT)
    plain_cfg, over_cfg = CampaignConfig(**base), CampaignConfig(**base, scenario_overrides=over)
    plain, plan = prepare_campaign(plain_cfg, ctx), prepare_campaign(over_cfg, ctx)
    assert plan.settings.overrides == over
    for s in plan.matrix.scenarios:
        assert s.scenario.simulation_config.nonreactive_fraction == 1.0
    fp = [_fingerprint(p.cells[0][1], c, p.hard, p.glob) for p, c in ((plain, plain_cfg), (plan, over_cfg))]
    assert fp[0] != fp[1]  # a resumed campaign never reuses a cell run under other conditions
