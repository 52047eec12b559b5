"""Command latency: the robot carries out a command ``command_latency_s`` after it was issued, the predictive planner
plans for that moment, and a latency no planner can plan for is refused before any episode."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from pydantic import ValidationError

from foresight.core.errors import ConfigError
from foresight.core.evaluation.config import EvaluationConfig
from foresight.core.evaluation.runner import run_evaluation
from foresight.core.planners.external import observation_message
from foresight.core.planners.registry import make_planner
from foresight.core.runtime.context import StageContext
from foresight.core.runtime.refs import BUILTIN_BUNDLE, BUILTIN_CONFIG_ROOT
from foresight.core.scenarios.loader import load_matrix
from foresight.core.scenarios.model import RobotConfig
from foresight.core.sim.latency import CommandDelay, split
from foresight.core.sim.planner import EpisodeInfo
from foresight.core.sim.robot import RobotLimits, robot_step
from foresight.core.sim.simulator import Simulator
from tests.unit.sim.scenes import open_map, scenario

REPO = Path(__file__).resolve().parents[3]
CIRCLE = REPO / "configs/scenarios/crowdnav/circle_crossing.yaml"


def _robot(latency: float, **kw) -> RobotConfig:
    return RobotConfig(command_latency_s=latency, max_linear_accel=2.0, max_angular_accel=2.0, **kw)


def _drive(latency: float, commands: list[tuple[float, float]], **robot) -> tuple[np.ndarray, list]:
    sim = Simulator()
    obs = sim.reset(scenario(open_map(), robot=_robot(latency, **robot)), 3)
    states, seen = [sim.robot.copy()], [obs]
    for cmd in commands:
        obs, _ = sim.step(cmd)
        states.append(sim.robot.copy())
        seen.append(obs)
    return np.array(states), seen


def test_a_robot_with_latency_keeps_executing_the_old_command_for_that_long() -> None:
    go, turn = (1.5, 0.0), (0.5, 0.8)
    commands = [go] * 12 + [turn] * 12
    lag = 5  # 0.5 s at dt 0.1
    late, _ = _drive(0.5, commands)
    shifted, _ = _drive(0.0, [(0.0, 0.0)] * lag + commands[:-lag])
    assert np.array_equal(late, shifted)  # bit for bit: the same commands, 0.5 s later
    assert np.all(late[1 : lag + 1] == late[0])  # standing still until the first command arrives
    assert late[12 + lag, 4] == 0.0 and late[13 + lag, 4] > 0.0  # the turn begins 0.5 s after it was sent


def test_a_latency_between_steps_splits_the_step_between_the_old_and_the_new_command() -> None:
    assert split(0.1, 0.25) == (0, pytest.approx(0.1)) and split(0.3, 0.1) == (3, 0.0)
    commands = [(1.0, 0.0), (1.0, 0.5), (0.2, -0.5)]
    got, seen = _drive(0.07, commands)  # at dt 0.1: the previous command for 0.07 s, then the new one
    lim = RobotLimits.from_config(_robot(0.07))
    s, prev = got[0], np.zeros(2)
    for i, cmd in enumerate(commands):
        s = robot_step(robot_step(s, prev, lim, 0.07), np.array(cmd), lim, 0.1 - 0.07)
        prev = np.array(cmd)
        assert np.allclose(got[i + 1], s, rtol=0, atol=1e-12)
        assert np.allclose(seen[i + 1].pending_commands, [cmd]) and np.allclose(
            seen[i + 1].pending_durations, [0.07]
        )


def test_no_latency_leaves_the_observation_without_pending_commands() -> None:
    _, seen = _drive(0.0, [(1.0, 0.0)])
    assert seen[-1].pending_commands is None and seen[-1].pending_durations is None
    assert "pending_commands" not in observation_message(seen[-1])
    delay = CommandDelay(0.3, 0.1)
    delay.push(np.array([1.0, 2.0]))
    cmds, durations = delay.pending()
    assert np.allclose(cmds, [[0, 0], [0, 0], [1, 2]]) and np.allclose(durations, 0.1)


def test_the_external_protocol_and_the_gym_env_see_the_same_delay(tmp_path: Path) -> None:
    _, seen = _drive(0.2, [(1.0, 0.0)])
    msg = observation_message(seen[-1])["pending_commands"]
    assert msg == {"commands": [[0.0, 0.0], [1.0, 0.0]], "durations": [0.1, 0.1]}
    pytest.importorskip("gymnasium")
    from foresight.core.gym.env import CrowdNavEnv

    m = tmp_path / "suite.yaml"
    text = CIRCLE.read_text().replace(
        "kinematics: holonomic,", "kinematics: holonomic, command_latency_s: 0.5,"
    )
    assert "command_latency_s: 0.5" in text
    m.write_text(text.replace("../../maps/", str(REPO / "configs/maps") + "/"))
    env = CrowdNavEnv(matrix=m, max_steps=5)
    env.reset(seed=1000)
    start = env.sim.robot.copy()
    for _ in range(2):  # two steps of 0.25 s: the first command is still on its way
        env.step(np.array([0.0, 1.0], dtype=np.float32))
        assert np.array_equal(env.sim.robot[:2], start[:2])
    env.step(np.array([0.0, 1.0], dtype=np.float32))
    assert env.sim.robot[1] > start[1]  # 0.5 s after it was sent, the robot moves


def test_a_negative_or_absurd_latency_is_refused_naming_the_field(tmp_path: Path) -> None:
    with pytest.raises(ValidationError, match="command_latency_s"):
        RobotConfig(command_latency_s=-0.1)
    with pytest.raises(ValidationError, match="command_latency_s"):
        RobotConfig(command_latency_s=60.0)
    text = CIRCLE.read_text().replace(
        "kinematics: holonomic,", "kinematics: holonomic, command_latency_s: -1,"
    )
    bad = tmp_path / "bad.yaml"
    bad.write_text(text.replace("../../maps/", str(REPO / "configs/maps") + "/"))
    with pytest.raises(ConfigError) as err:
        load_matrix(bad)
    msg = str(err.value)
    assert "bad.yaml" in msg and "crowdnav_circle_crossing" in msg and "command_latency_s" in msg


def test_a_latency_beyond_the_planners_horizon_is_refused_before_any_episode(tmp_path: Path) -> None:
    cfg = EvaluationConfig.model_validate(
        {
            "scenarios": ["crossing_low"],
            "seeds_per_scenario": 1,
            "max_steps": 20,
            "scenario_overrides": {"robot_config": {"command_latency_s": 4.5}},
            "planner": {"name": "predictive", "model": "cv"},
        }
    )
    ctx = StageContext(workdir=tmp_path, resolve_bundle=lambda b: {BUILTIN_BUNDLE: BUILTIN_CONFIG_ROOT}[b])
    with pytest.raises(ConfigError) as err:
        run_evaluation(cfg, ctx)
    msg = str(err.value)
    assert "crossing_low" in msg and "robot_config.command_latency_s" in msg and "horizon" in msg
    assert not (tmp_path / "episodes.jsonl").exists()


@pytest.mark.parametrize(
    "kinematics, latency", [("holonomic", 0.5), ("holonomic", 0.1), ("differential_drive", 0.3)]
)
def test_the_predictive_planner_rolls_out_from_where_the_pending_commands_take_the_robot(
    kinematics: str, latency: float
) -> None:
    sc = load_matrix(CIRCLE).scenarios[0]
    robot = sc.scenario.robot_config.model_copy(
        update={"command_latency_s": latency, "kinematics": kinematics}
    )
    sc = sc.model_copy(update={"scenario": sc.scenario.model_copy(update={"robot_config": robot})})
    sim, planner = Simulator(), make_planner("predictive", None, model="cv")
    obs = sim.reset(sc, 1000)
    planner.reset(EpisodeInfo(sc, 1000, 0.25, 0.3, 0.3))
    lim = RobotLimits.from_config(robot)
    for _ in range(8):
        cmd = planner.plan(obs)
        state = np.concatenate([obs.robot_pose, obs.robot_velocity])
        for c, d in zip(obs.pending_commands, obs.pending_durations, strict=True):
            state = robot_step(state, c, lim, d)
        assert np.allclose(planner.diagnostics["rollout_start"], state, rtol=0, atol=1e-12)
        obs, ev = sim.step(cmd)
        assert not ev.done
    assert obs.robot_pose[1] > 16.0  # under way toward the goal


def test_with_latency_the_planner_brakes_for_a_wall_a_latency_blind_one_meets() -> None:
    """At full speed toward a wall with 1 s of full-speed commands in flight: the planner that rolls them forward
    sees that only braking at once stops in time; the same planner shown the present state alone does not."""
    walls = (((6.4, -5.0), (7.0, -5.0), (7.0, 10.0), (6.4, 10.0)),)
    outcomes = {}
    for blind in (False, True):
        m = open_map(
            width=20.0, height=10.0, obstacles=walls, robot_start=(1.0, 1.0, 0.5, 0.5), robot_goal=(3.5, 8.0)
        )
        robot = RobotConfig(
            kinematics="holonomic",
            radius=0.3,
            max_linear_speed=1.5,
            max_linear_accel=1.0,
            command_latency_s=1.0,
        )
        sc = scenario(m, robot=robot)
        sim, planner = Simulator(), make_planner("predictive", None, model="cv")
        obs = sim.reset(sc, 0)
        planner.reset(EpisodeInfo(sc, 0, obs.dt, 0.3, obs.ped_radius))
        for _ in range(30):  # 3 s of full speed toward the wall: the last second of them is still in flight
            obs, _ = sim.step((1.5, 0.0))
        events = None
        for _ in range(200):
            seen = dataclasses.replace(obs, pending_commands=None, pending_durations=None) if blind else obs
            obs, events = sim.step(planner.plan(seen))
            if events.done:
                break
        outcomes[blind] = events.outcome
    assert outcomes == {False: "success", True: "collision_static"}
