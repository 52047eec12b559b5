"""External planners over the JSON-lines protocol: the reference client, and planners that crash, hang or
answer malformed JSON (each a planner_error episode with its reason, the run goes on)."""

from __future__ import annotations

import json
import re
import sys
import time
from pathlib import Path

import pytest
from pydantic import ValidationError

from foresight.core.evaluation.config import EvaluationConfig
from foresight.core.evaluation.runner import run_evaluation
from foresight.core.planners import external
from foresight.core.planners.external import close_all, operator_commands
from foresight.core.runtime.context import StageContext
from foresight.core.runtime.refs import BUILTIN_BUNDLE, BUILTIN_CONFIG_ROOT

REPO = Path(__file__).resolve().parents[3]
BAD = Path(__file__).with_name("bad_external_planner.py")


@pytest.fixture
def commands(monkeypatch: pytest.MonkeyPatch):  # noqa: ANN201
    table = {
        "reference": [sys.executable, str(REPO / "examples" / "external_planner.py")],
        **{mode: [sys.executable, str(BAD), mode] for mode in ("crash", "hang", "malformed")},
    }
    monkeypatch.setenv("FORESIGHT_EXTERNAL_PLANNERS", json.dumps(table))
    yield table
    close_all()


def _run(tmp_path: Path, config: dict, seeds: int = 2, max_steps: int = 60):  # noqa: ANN202
    cfg = EvaluationConfig.model_validate(
        {
            "scenarios": ["crossing_low"],
            "seeds_per_scenario": seeds,
            "max_steps": max_steps,
            "planner": {"name": "external", "config": config},
        }
    )
    ctx = StageContext(workdir=tmp_path, resolve_bundle=lambda b: {BUILTIN_BUNDLE: BUILTIN_CONFIG_ROOT}[b])
    return run_evaluation(cfg, ctx)


def test_operator_commands_parse_strings_and_lists() -> None:
    assert operator_commands('{"a": "python x.py --k 1", "b": ["/bin/p", "q r"]}') == {
        "a": ["python", "x.py", "--k", "1"],
        "b": ["/bin/p", "q r"],
    }


def test_unconfigured_command_is_refused_naming_the_configured_ones(commands: dict) -> None:
    with pytest.raises(
        ValidationError,
        match=r"planner\.external\.config\.command[\s\S]*'rm -rf /' is not configured"
        r"[\s\S]*configured: reference, crash",
    ):
        EvaluationConfig.model_validate({"planner": {"name": "external", "config": {"command": "rm -rf /"}}})


def test_reference_client_drives_the_robot(commands: dict, tmp_path: Path) -> None:
    result = _run(tmp_path, {"command": "reference", "params": {"speed": 1.2}}, max_steps=400)
    records = [json.loads(line) for line in (tmp_path / "episodes.jsonl").read_text().splitlines()]
    assert result.episodes == 2 and result.taxonomy.get("planner_error", 0) == 0
    assert all(r["outcome"] != "error" for r in records)
    assert result.success_rate is not None and result.success_rate > 0  # it reaches the goal
    assert external._PROCESSES == {}  # the run ended its planner process


@pytest.mark.parametrize(
    "mode, reason",
    [
        ("crash", r"exited \(code 3\) at step 2.*crashed on purpose"),
        ("hang", r"no answer within 0.5 s at step 2 \(killed\)"),
        ("malformed", r"malformed JSON at step 2"),
    ],
)
def test_misbehaving_process_is_a_planner_error_and_the_run_goes_on(
    commands: dict, tmp_path: Path, mode: str, reason: str
) -> None:
    t0 = time.perf_counter()
    result = _run(tmp_path, {"command": mode, "step_timeout_s": 0.5})
    assert time.perf_counter() - t0 < 30
    records = [json.loads(line) for line in (tmp_path / "episodes.jsonl").read_text().splitlines()]
    assert (
        result.episodes == 2 and result.taxonomy["planner_error"] == 2
    )  # both episodes: a fresh process each
    for r in records:
        assert r["outcome"] == "error" and r["steps"] == 2
        assert r["taxonomy"]["label"] == "planner_error"
        assert re.search(reason, r["error"]), r["error"]


def _shape(value: object) -> object:
    """Keys at every depth (lists by their first element): what a client written from the docs relies on."""
    if isinstance(value, dict):
        return {k: _shape(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_shape(value[0])] if value else []
    return type(value).__name__ if isinstance(value, str) else "number"


def test_the_documented_messages_are_the_ones_sent_and_understood() -> None:
    """docs/planner_protocol.md against the code: the same keys at every depth."""
    from foresight.core.planners.external import observation_message, start_message
    from foresight.core.scenarios.loader import load_matrix
    from foresight.core.sim.planner import EpisodeInfo
    from foresight.core.sim.simulator import Simulator

    text = (REPO / "docs" / "planner_protocol.md").read_text()
    docs = {m["type"]: m for m in (json.loads(b) for b in re.findall(r"```json\n(.*?)```", text, flags=re.S))}
    scenario = load_matrix(BUILTIN_CONFIG_ROOT / "scenarios" / "classic_interactions.yaml").get(
        "crossing_low"
    )
    sim = Simulator()
    obs = sim.reset(scenario, 1000)
    sent = observation_message(obs)
    assert _shape(docs["observation"]) == _shape(sent)
    info = EpisodeInfo(scenario=scenario, seed=1000, dt=sim.dt, robot_radius=1.0, ped_radius=0.4)
    assert _shape(docs["start"]) == _shape(start_message(info, {"speed": 1.2}))
    later, _ = sim.step((0.5, 0.0))
    assert set(observation_message(later)) == set(sent) - {
        "robot_limits",
        "static",
    }  # constants on step 0 only
    reference = __import__("runpy").run_path(str(REPO / "examples" / "external_planner.py"))
    answer = reference["command"](json.loads(json.dumps(sent)), {})
    assert set(answer) <= set(docs["command"]) and {"type", "v", "omega"} <= set(answer)
