"""Predictive planner decisions: determinism, diagnostics, protocol, and a closed-loop crossing episode."""

from __future__ import annotations

import numpy as np
import pytest

from foresight.core.errors import ConfigError
from foresight.core.maps.model import SinglePedestrian
from foresight.core.planners.predictive.config import PredictivePlannerConfig
from foresight.core.planners.predictive.planner import PredictivePlanner
from foresight.core.predict.forecaster import ConstantVelocityForecaster
from foresight.core.predict.timebase import PLANNER_TIMEBASE, TimeBase
from foresight.core.scenarios.model import ResolvedScenario, Scenario, SimulationConfig
from foresight.core.sim.planner import EpisodeInfo, Planner
from foresight.core.sim.simulator import Simulator
from tests.unit.planners.scenes import corridor_map, info_for, observation


def _run_decisions(peds_over_time) -> list:
    m = corridor_map()
    p = PredictivePlanner(None, ConstantVelocityForecaster(PLANNER_TIMEBASE))
    p.reset(info_for(m))
    out = []
    for step, peds in enumerate(peds_over_time):
        obs = observation(m, pose=(5.0 + 0.1 * step, 10.0, 0.0), peds=peds, step=step)
        out.append((p.plan(obs), p.diagnostics["cost"], p.diagnostics["sequence"]))
    return out


def test_decisions_are_deterministic():
    peds = [[(10.0 - 0.065 * k, 10.3), (12.0, 7.0 + 0.065 * k)] for k in range(6)]
    assert _run_decisions(peds) == _run_decisions(peds)


def test_planner_satisfies_protocol_and_reports_diagnostics():
    m = corridor_map()
    p = PredictivePlanner(None, ConstantVelocityForecaster(PLANNER_TIMEBASE))
    assert isinstance(p, Planner)
    with pytest.raises(RuntimeError):
        p.plan(observation(m))
    p.reset(info_for(m))
    v, w = p.plan(observation(m, peds=[(8.0, 10.0)]))
    d = p.diagnostics
    assert 0.0 <= v <= 2.0 and -1.0 <= w <= 1.0
    assert d["command"] == (v, w) and d["forecast_source"] == "constant_velocity"
    assert set(d["terms"]) >= {
        "progress",
        "collision",
        "near_miss",
        "ttc",
        "static",
        "static_collision",
        "smoothness",
    }
    assert d["predictions"]["positions"].shape == (1, PLANNER_TIMEBASE.horizon, 2)
    assert d["near_field"] and d["candidates_evaluated"] > 60


class _FixedGrid(ConstantVelocityForecaster):
    fit = None  # a learned model's grid is what it was trained on


def test_forecast_grid_must_be_whole_simulator_steps():
    p = PredictivePlanner(None, _FixedGrid(TimeBase(dt=0.15, history=3, horizon=8)))
    with pytest.raises(ConfigError):
        p.reset(info_for(corridor_map()))


def test_constant_velocity_fits_its_grid_to_the_simulator_step():
    cv = ConstantVelocityForecaster(TimeBase(dt=0.15, history=3, horizon=8))
    PredictivePlanner(None, cv).reset(
        info_for(corridor_map())
    )  # 0.1 s steps: the nearest multiple, over 1.2 s
    assert (cv.timebase.dt, cv.timebase.history, cv.timebase.horizon) == (pytest.approx(0.1), 3, 12)


def test_drives_at_full_speed_on_a_free_route():
    m = corridor_map()
    p = PredictivePlanner(None, ConstantVelocityForecaster(PLANNER_TIMEBASE))
    p.reset(info_for(m))
    v, w = p.plan(observation(m, velocity=(2.0, 0.0)))
    assert v == pytest.approx(2.0) and w == pytest.approx(0.0)


def _approach(arrival_credit: bool) -> list[float]:
    """Commanded speeds [m/s] on a free route from 11 m before the goal at full speed until within its tolerance."""
    from foresight.core.sim.robot import RobotLimits, unicycle_step

    m = corridor_map()
    p = PredictivePlanner(
        PredictivePlannerConfig.from_dict({"search": {"arrival_credit": arrival_credit}}),
        ConstantVelocityForecaster(PLANNER_TIMEBASE),
    )
    p.reset(info_for(m))
    state, speeds = np.array([16.0, 10.0, 0.0, 2.0, 0.0]), []
    for k in range(80):
        if np.hypot(state[0] - 27.0, state[1] - 10.0) <= 2.0:  # the observation's goal tolerance
            break
        v, w = p.plan(observation(m, pose=state[:3], velocity=state[3:], step=k))
        speeds.append(v)
        state = unicycle_step(state, np.array([v, w]), RobotLimits(), 0.1)
    return speeds


def test_keeps_full_speed_up_to_the_goal():
    """Every rollout that reaches the goal within the horizon once scored the same progress, so the robot slowed down
    in sight of the goal; an earlier arrival now counts as more progress (``search.arrival_credit``)."""
    fast = _approach(True)
    assert (
        len(fast) <= 46
    )  # 9 m at 2 m/s (45 steps, 46 with rounding): as early as full speed throughout gets there
    # full speed until the last half second, where commands reaching the goal in the same 0.2 s forecast step tie (a
    # swerve at 1 m/s among them: the robot, slowed to 1.6 m/s, arrives within the same 46 steps)
    assert set(fast[:40]) == {2.0} and min(fast) >= 1.0
    slowed = _approach(False)
    assert min(slowed) <= 1.0 and len(slowed) > 50


def test_solves_a_crossing_episode():
    """Closed loop in the simulator: a pedestrian crosses the robot's straight route; reach the goal without contact."""
    ped = SinglePedestrian(id="c1", start=(15.0, 3.0), goal=(15.0, 18.0), speed_m_s=0.5)
    m = corridor_map().model_copy(update={"single_pedestrians": (ped,)})
    scen = ResolvedScenario(
        scenario=Scenario(
            name="crossing_test",
            map_id="test",
            simulation_config=SimulationConfig(ped_density=0.0, max_episode_steps=400),
        ),
        map=m,
    )
    sim = Simulator()
    obs = sim.reset(scen, seed=1)
    p = PredictivePlanner(PredictivePlannerConfig(), ConstantVelocityForecaster(PLANNER_TIMEBASE))
    p.reset(
        EpisodeInfo(
            scenario=scen, seed=1, dt=obs.dt, robot_radius=obs.robot_radius, ped_radius=obs.ped_radius
        )
    )
    min_gap = np.inf
    while True:
        obs, ev = sim.step(p.plan(obs))
        if len(obs.ped_positions):
            min_gap = min(
                min_gap, float(np.linalg.norm(obs.ped_positions - obs.robot_pose[:2], axis=1).min())
            )
        if ev.done:
            break
    assert ev.outcome == "success", ev.outcome
    assert min_gap < 8.0  # the pedestrian really was on the way


def _dead_end_decision(
    allow_backwards: bool, reverse: tuple[float, ...] = (0.25, 0.5)
) -> tuple[float, float]:
    """A robot standing in a 3 m corridor (no room to let anyone by, none to turn round in time), a walker coming
    straight at it at 1.2 m/s: the speed a robot that may or may not drive backwards commands, and its plan's
    collision term."""
    from foresight.core.scenarios.model import RobotConfig

    walls = (((0, 0), (30, 0), (30, 8.5), (0, 8.5)), ((0, 11.5), (30, 11.5), (30, 20), (0, 20)))
    m = corridor_map(obstacles=walls)
    scen = ResolvedScenario(
        scenario=Scenario(
            name="test", map_id="test", robot_config=RobotConfig(allow_backwards=allow_backwards)
        ),
        map=m,
    )
    p = PredictivePlanner(
        PredictivePlannerConfig.from_dict({"sampling": {"reverse_speed_ratios": reverse}}),
        ConstantVelocityForecaster(PLANNER_TIMEBASE),
    )
    p.reset(EpisodeInfo(scenario=scen, seed=0, dt=0.1, robot_radius=1.0, ped_radius=0.4))
    for step in range(12):  # the forecast reads the walker's velocity off its track; it ends 3.5 m away
        v, _ = p.plan(
            observation(
                m,
                pose=(10.0, 10.0, 0.0),
                velocity=(0.0, 0.0),
                peds=[(14.82 - 0.12 * step, 10.0)],
                ped_vels=[(-1.2, 0.0)],
                step=step,
            )
        )
    return v, p.diagnostics["terms"]["collision"]


def test_a_robot_that_may_drive_backwards_backs_off_from_a_walker_it_cannot_let_by():
    v, collision = _dead_end_decision(allow_backwards=True)
    assert v == -1.0  # backs off down the corridor at half its speed
    v_off, collision_off = _dead_end_decision(
        allow_backwards=True, reverse=()
    )  # the switch off: never backwards
    assert v_off >= 0 and collision_off > 10 * collision  # it stands, and expects the walker to walk into it
    assert _dead_end_decision(allow_backwards=False) == (v_off, collision_off)  # the reference robots may not
    default = PredictivePlannerConfig().sampling.reverse_speed_ratios
    assert _dead_end_decision(allow_backwards=True, reverse=default) == (
        v_off,
        collision_off,
    )  # off by default


def test_backing_off_adds_no_candidate_for_a_robot_that_may_not():
    from foresight.core.planners.predictive.config import SamplingConfig
    from foresight.core.planners.predictive.sampling import first_candidates, reverse_speeds
    from foresight.core.sim.robot import RobotLimits

    cfg = SamplingConfig(reverse_speed_ratios=(0.25, 0.5))
    assert reverse_speeds(cfg, RobotLimits(), 1.0).size == 0
    assert reverse_speeds(SamplingConfig(), RobotLimits(v_min=-2.0), 1.0).size == 0  # off by default
    assert reverse_speeds(cfg, RobotLimits(v_min=-2.0), 1.0).tolist() == [-0.5, -1.0]
    assert reverse_speeds(cfg, RobotLimits(v_min=-2.0), 0.3).tolist() == [
        -0.5,
        -0.6,
    ]  # capped like forward speeds
    plain = first_candidates(cfg, RobotLimits(), 1.0, near_field=True)
    assert plain[:, 0].min() == 0.0
    assert first_candidates(SamplingConfig(), RobotLimits(v_min=-2.0), 1.0, True).tolist() == plain.tolist()
