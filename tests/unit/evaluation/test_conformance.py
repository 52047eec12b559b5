"""Planner conformance: every built-in, the example plug-in and the external reference client pass; a broken toy
planner fails, naming each failed check (one fault per check, so each check has a test that fails without it)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

from foresight.core.evaluation.conformance import ConformanceConfig, run_conformance
from foresight.core.planners.registry import register
from foresight.core.runtime.context import StageContext
from foresight.core.runtime.refs import BUILTIN_CONFIG_ROOT
from tests.conftest import REPO

BROKEN = "tests.plugins.broken_toy:BrokenToy"
EXTERNAL = {
    "reference": [sys.executable, str(REPO / "examples" / "external_planner.py")],
    "lingers": [sys.executable, str(REPO / "tests" / "plugins" / "external_broken.py"), "lingers"],
    "no_second_episode": [
        sys.executable,
        str(REPO / "tests" / "plugins" / "external_broken.py"),
        "no_second_episode",
    ],
}


@pytest.fixture
def ctx(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> StageContext:
    from foresight.local import ModelArgs

    monkeypatch.setenv("FORESIGHT_EXTERNAL_PLANNERS", json.dumps(EXTERNAL))
    return StageContext(
        workdir=tmp_path, resolve_bundle=lambda i: BUILTIN_CONFIG_ROOT, resolve_model=ModelArgs().resolve
    )


def _check(ctx: StageContext, planner: dict, **kw) -> object:
    return run_conformance(ConformanceConfig(planner=planner, **kw), ctx)


@pytest.mark.parametrize(
    "planner",
    [
        {"name": "goal"},
        {"name": "orca"},
        {"name": "social_force"},
        {"name": "predictive", "model": "cv"},
        {"name": "predictive"},  # the default model
        {"name": "toy"},  # the example plug-in (tests/plugins/toy_planner)
        {"name": "external", "config": {"command": "reference"}},  # examples/external_planner.py
    ],
    ids=lambda p: p.get("config", {}).get("command") or p.get("model") or p["name"],
)
def test_every_builtin_the_plugin_and_the_reference_client_conform(ctx: StageContext, planner: dict) -> None:
    result = _check(ctx, planner, steps=20)
    assert result.passed, [(c.name, c.detail) for c in result.checks if not c.passed]
    names = {c.name for c in result.checks}
    assert {
        "finite",
        "within_limits",
        "deterministic",
        "decision_budget",
        "no_pedestrians",
        "crowd_200",
        "reset_leaves_no_state",
    } <= names
    assert ("protocol_error_paths" in names) == (planner["name"] == "external")


def test_the_scripted_witness_conforms(ctx: StageContext) -> None:
    result = _check(ctx, {"name": "scripted", "config": {}}, steps=20)  # the route as is
    assert result.passed, result.failed


@pytest.mark.parametrize(
    "fault,failed",
    [
        ({}, []),
        ({"nan": True}, ["finite"]),
        ({"too_fast": True}, ["within_limits"]),
        ({"noisy": True}, ["deterministic"]),  # (reset_leaves_no_state needs determinism: left out)
        ({"slow_s": 0.15}, ["decision_budget"]),
        ({"no_crowd": True}, ["no_pedestrians"]),
        ({"big_crowd": True}, ["crowd_200"]),
        ({"leaky": True}, ["reset_leaves_no_state"]),
        (
            {"too_fast": True, "no_crowd": True, "big_crowd": True},
            ["within_limits", "no_pedestrians", "crowd_200"],
        ),
    ],
    ids=lambda v: ",".join(v) if isinstance(v, dict) else None,
)
def test_a_broken_toy_fails_naming_each_failed_check(
    ctx: StageContext, fault: dict, failed: list[str]
) -> None:
    name = register(BROKEN)
    result = _check(ctx, {"name": name, "config": fault}, steps=20, decision_budget_s=0.1)
    assert result.failed == failed and result.passed == (not failed)
    for check in result.checks:
        assert check.passed == (check.name not in failed)
        if not check.passed:
            assert check.detail  # says what it saw


@pytest.mark.parametrize(
    "command,why", [("lingers", "after its input was closed"), ("no_second_episode", "no answer within")]
)
def test_an_external_planner_that_breaks_the_error_paths_fails(
    ctx: StageContext, command: str, why: str
) -> None:
    planner = {"name": "external", "config": {"command": command, "start_timeout_s": 1.0}}
    result = _check(ctx, planner, steps=10)
    assert result.failed == ["protocol_error_paths"]
    assert why in {c.name: c for c in result.checks}["protocol_error_paths"].detail


def test_the_cli_check_exits_2_naming_the_failed_checks() -> None:
    import subprocess

    def check(*argv: str) -> subprocess.CompletedProcess:
        return subprocess.run(
            [
                sys.executable,
                "-m",
                "foresight.cli.main",
                "planners",
                "check",
                *argv,
                "--local",
                "--steps",
                "10",
            ],
            cwd=REPO,
            capture_output=True,
            text=True,
            timeout=300,
        )

    ok = check("toy")
    assert ok.returncode == 0 and "planner toy: CONFORMS" in ok.stdout, ok.stderr
    bad = check(BROKEN, "--config", '{"too_fast": true, "big_crowd": true}')
    assert bad.returncode == 2, bad.stderr
    assert "FAILED within_limits, crowd_200" in bad.stdout
    assert "FAIL within_limits" in bad.stdout and "threshold 0" in bad.stdout
    typo = check("toy", "--config", '{"speeed": 1}')
    assert typo.returncode == 1 and "speeed" in typo.stderr and len(typo.stderr.strip().splitlines()) == 1
