"""Keep the plan: the last decision's sequence, one step on, competes with the fixed candidates, so a plan begun (a
point turn beside a door) is carried out instead of flipping to whichever fixed candidate is cheapest this step."""

from __future__ import annotations

import numpy as np

from foresight.core.planners.predictive.config import PredictivePlannerConfig
from foresight.core.planners.predictive.planner import PredictivePlanner
from foresight.core.planners.predictive.rollout import rollout
from foresight.core.planners.predictive.search import kept_plan
from foresight.core.predict.forecaster import ConstantVelocityForecaster
from foresight.core.predict.timebase import PLANNER_TIMEBASE
from foresight.core.sim.robot import RobotLimits, unicycle_step
from tests.unit.planners.scenes import corridor_map, info_for, observation
from tests.unit.planners.test_point_turns import WALL

GOAL = ((22.0, 16.0),)  #: through the door, from beside it


def _drive(keep_plan: bool, decisions: int) -> tuple[PredictivePlanner, list[dict], np.ndarray]:
    """Closed loop in the door-corner scene, the robot moved by the simulator's kinematics; the diagnostics of each
    decision and the robot's last state."""
    m = corridor_map(obstacles=WALL)
    planner = PredictivePlanner(
        PredictivePlannerConfig.from_dict({"search": {"keep_plan": keep_plan}}),
        ConstantVelocityForecaster(PLANNER_TIMEBASE),
    )
    planner.reset(info_for(m))
    state, out = np.array([12.8, 18.0, 0.2, 0.0, 0.0]), []
    for k in range(decisions):
        cmd = planner.plan(observation(m, pose=state[:3], velocity=state[3:], route=GOAL, step=k))
        out.append(planner.diagnostics)
        state = unicycle_step(state, np.array(cmd), RobotLimits(), 0.1)
    return planner, out, state


def _one_step_on(sequence: list[tuple[int, float, float]]) -> list[tuple[int, float, float]]:
    (n, v, w), *rest = sequence
    rest = rest[:-1] + [(rest[-1][0] + 1, *rest[-1][1:])]  # its last command held one step longer
    return ([(n - 1, v, w)] if n > 1 else []) + rest


def test_the_next_decision_carries_the_point_turn_on():
    _, d, _ = _drive(keep_plan=True, decisions=2)
    first_steps, v, w = d[0]["sequence"][0]
    assert v == 0.0 and abs(w) == 1.0 and first_steps > 4  # a point turn of more than the 0.4 rad fixed ones
    assert not d[0]["kept_plan"]  # nothing to keep at the first decision
    assert d[1]["kept_plan"] and d[1]["sequence"] == _one_step_on(d[0]["sequence"])


def test_without_it_no_decision_is_a_kept_plan():
    _, d, _ = _drive(keep_plan=False, decisions=4)
    assert not any(x["kept_plan"] for x in d)


def test_the_kept_rollout_is_the_rollout_of_the_kept_commands_from_where_the_robot_is():
    planner, _, state = _drive(keep_plan=True, decisions=3)
    S = len(planner._memory.plan[0])
    cmds, states = kept_plan(planner._memory.plan, state, S, 0.1, planner._limits)
    expected = rollout(state[None], cmds[None], RobotLimits(), 0.1)[0]
    assert np.allclose(states[:, :2], expected[:, :2], atol=1e-9) and np.allclose(
        states[:, 3:], expected[:, 3:]
    )
    assert np.allclose(np.cos(states[:, 2]), np.cos(expected[:, 2])) and np.allclose(
        np.sin(states[:, 2]), np.sin(expected[:, 2])
    )
    moved = state + np.array(
        [0.3, 0.0, 0.0, 0.0, 0.0]
    )  # the robot is not where the plan put it: nothing to keep
    assert kept_plan(planner._memory.plan, moved, S, 0.1, planner._limits) is None
    assert kept_plan(planner._memory.plan, state, S + 1, 0.1, planner._limits) is None  # another horizon
