"""Robot kinds: unicycle kinematics, holonomic commands from every built-in planner, bad input refused up front."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from pydantic import ValidationError

from foresight.core.errors import ConfigError
from foresight.core.evaluation.config import EvaluationConfig
from foresight.core.evaluation.runner import run_evaluation
from foresight.core.planners.external import close_all
from foresight.core.planners.registry import make_planner
from foresight.core.runtime.context import StageContext
from foresight.core.runtime.refs import BUILTIN_BUNDLE, BUILTIN_CONFIG_ROOT
from foresight.core.scenarios.loader import load_matrix
from foresight.core.scenarios.model import RobotConfig
from foresight.core.sim.planner import EpisodeInfo
from foresight.core.sim.robot import RobotLimits, robot_rollout, robot_step, turn_first_step
from foresight.core.sim.simulator import Simulator

REPO = Path(__file__).resolve().parents[3]
CIRCLE = REPO / "configs/scenarios/crowdnav/circle_crossing.yaml"


def test_kinematics_field_takes_three_kinds_and_its_earlier_spelling() -> None:
    assert RobotConfig(kinematics="unicycle").kinematics == "unicycle"
    assert RobotConfig.model_validate({"type": "omni"}).kinematics == "holonomic"
    assert RobotConfig().type == "differential_drive"
    with pytest.raises(ValidationError, match="kinematics"):
        RobotConfig.model_validate({"kinematics": "tank"})
    with pytest.raises(ValidationError, match="preferred_speed"):
        RobotConfig(max_linear_speed=1.0, preferred_speed=1.5)


def test_an_unknown_kinematics_in_a_matrix_names_the_file_scenario_and_field(tmp_path: Path) -> None:
    text = CIRCLE.read_text().replace("kinematics: holonomic", "kinematics: hovercraft")
    bad = tmp_path / "bad.yaml"
    bad.write_text(
        text.replace(
            "../../maps/crowdnav/open_plane.yaml", str(REPO / "configs/maps/crowdnav/open_plane.yaml")
        )
    )
    with pytest.raises(ConfigError) as err:
        load_matrix(bad)
    msg = str(err.value)
    assert "bad.yaml" in msg and "crowdnav_circle_crossing" in msg and "kinematics" in msg


def test_unicycle_turns_first_then_moves_along_its_new_heading() -> None:
    lim = RobotLimits(kind="unicycle", v_max=1.0, w_max=2.0, accel=100.0, decel=100.0, alpha=100.0)
    s = robot_step(np.array([0.0, 0.0, 0.0, 0.0, 0.0]), np.array([1.0, 2.0]), lim, 0.25)
    assert s[2] == pytest.approx(0.5) and s[3] == pytest.approx(1.0)
    assert s[:2] == pytest.approx([0.25 * math.cos(0.5), 0.25 * math.sin(0.5)])
    cmds = np.array([[1.0, 2.0], [0.5, -1.0], [1.0, 0.0]])
    states = robot_rollout(np.zeros(5), cmds, lim, 0.25)
    s = np.zeros(5)
    for i, c in enumerate(cmds):
        s = turn_first_step(s, c, lim, 0.25)
        assert states[i] == pytest.approx(s)


@pytest.mark.parametrize("name, config", [("orca", {}), ("social_force", {}), ("goal", {})])
def test_baselines_send_a_holonomic_robot_velocities(name: str, config: dict) -> None:
    sc = load_matrix(CIRCLE).scenarios[0]
    sim, planner = Simulator(), make_planner(name, config)
    obs = sim.reset(sc, 1000)
    planner.reset(EpisodeInfo(sc, 1000, 0.25, 0.3, 0.3))
    vx, vy = planner.plan(obs)
    assert vy > 0.2 and abs(vx) < vy  # straight up toward the goal at (20, 24), not a (v, omega) pair
    obs, _ = sim.step((vx, vy))
    assert obs.robot_pose[1] > 16.0


def test_predictive_planner_samples_velocities_for_a_holonomic_robot() -> None:
    sc = load_matrix(CIRCLE).scenarios[0]
    sim, planner = Simulator(), make_planner("predictive", None, model="cv")
    obs = sim.reset(sc, 1000)
    planner.reset(EpisodeInfo(sc, 1000, 0.25, 0.3, 0.3))
    speeds, moved = [], []
    for _ in range(12):
        cmd = planner.plan(obs)
        speeds.append(math.hypot(*cmd))
        obs, ev = sim.step(cmd)
        moved.append(obs.robot_pose[:2].copy())
        if ev.done:
            break
    assert max(speeds) <= 1.0 + 1e-9 and max(speeds) > 0.5
    assert moved[-1][1] > 17.0  # under way toward the goal 8 m up
    cands = planner._memory.search.candidates(False)
    assert len(cands) >= 16 * 4 and np.allclose(cands.min(axis=0), [-1.0, -1.0])  # every direction


@pytest.fixture
def commands(monkeypatch: pytest.MonkeyPatch):  # noqa: ANN201
    table = {"reference": [sys.executable, str(REPO / "examples" / "external_planner.py")]}
    monkeypatch.setenv("FORESIGHT_EXTERNAL_PLANNERS", json.dumps(table))
    yield table
    close_all()


@pytest.mark.parametrize(
    "command_type, overrides, kind",
    [
        ("velocity", {}, "differential_drive"),  # a holonomic command to a differential-drive robot
        ("unicycle", {"robot_config": {"kinematics": "holonomic"}}, "holonomic"),
    ],
)
def test_an_external_planner_declaring_the_wrong_command_type_is_refused_before_any_episode(
    commands: dict, tmp_path: Path, command_type: str, overrides: dict, kind: str
) -> None:
    cfg = EvaluationConfig.model_validate(
        {
            "scenarios": ["crossing_low"],
            "seeds_per_scenario": 1,
            "max_steps": 20,
            "scenario_overrides": overrides,
            "planner": {"name": "external", "config": {"command": "reference", "command_type": command_type}},
        }
    )
    ctx = StageContext(workdir=tmp_path, resolve_bundle=lambda b: {BUILTIN_BUNDLE: BUILTIN_CONFIG_ROOT}[b])
    with pytest.raises(ConfigError) as err:
        run_evaluation(cfg, ctx)
    msg = str(err.value)
    assert "crossing_low" in msg and "planner.config.command_type" in msg and repr(kind) in msg
    assert not (tmp_path / "episodes.jsonl").exists()


@pytest.mark.parametrize("observed, expected", [(True, "own"), (False, "nominal")])
def test_orca_planner_takes_each_humans_radius_or_the_nominal_one(observed: bool, expected: str) -> None:
    from foresight.core.planners.orca import OrcaConfig, OrcaPlanner

    sc = load_matrix(REPO / "configs/scenarios/crowdnav/crowdnavpp_rand.yaml").scenarios[0]
    sim = Simulator()
    obs = sim.reset(sc, 1425)
    p = OrcaPlanner(OrcaConfig(observed_radii=observed, ped_radius_margin=0.01))
    p.reset(EpisodeInfo(sc, 1425, 0.25, 0.3, 0.3))
    p.plan(obs)
    got = [p._sim.get_agent_radius(i + 1) for i in range(len(obs.ped_ids))]
    want = obs.ped_radii + 0.01 if expected == "own" else np.full(len(obs.ped_ids), 0.31)
    assert len(got) > 0 and np.allclose(got, want, atol=1e-6)


@pytest.mark.parametrize("kinematics, low", [("holonomic", [-1.0, -1.0]), ("unicycle", [0.0, -1.0])])
def test_gym_action_space_follows_the_robot_kind(tmp_path: Path, kinematics: str, low: list[float]) -> None:
    pytest.importorskip("gymnasium")
    from foresight.core.gym.env import CrowdNavEnv

    text = CIRCLE.read_text().replace("kinematics: holonomic", f"kinematics: {kinematics}")
    m = tmp_path / "suite.yaml"
    m.write_text(
        text.replace(
            "../../maps/crowdnav/open_plane.yaml", str(REPO / "configs/maps/crowdnav/open_plane.yaml")
        )
    )
    env = CrowdNavEnv(matrix=m, max_steps=5)
    env.reset(seed=1000)
    assert np.allclose(env.action_space.low, low) and np.allclose(env.action_space.high, [1.0, 1.0])
    obs, *_ = env.step(np.array([0.0, 1.0], dtype=np.float32))
    assert obs is not None
