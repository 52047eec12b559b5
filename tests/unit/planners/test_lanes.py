"""Lanes: a robot that has to wait does not wait where people have lately been walking through."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from foresight.core.errors import ConfigError
from foresight.core.planners.predictive.config import PredictivePlannerConfig
from foresight.core.planners.predictive.planner import PredictivePlanner
from foresight.core.planners.predictive.traffic import TrafficMap
from foresight.core.planners.registry import make_forecaster
from foresight.core.predict.forecaster import ConstantVelocityForecaster
from foresight.core.predict.nn.checkpoint import load_predictor
from foresight.core.predict.timebase import PLANNER_TIMEBASE
from foresight.core.scenarios.loader import load_matrix
from foresight.core.sim.episode import run_episode
from tests.unit.planners.scenes import corridor_map, info_for, observation

CHECKPOINT = Path(__file__).resolve().parents[3] / "model" / "predictor-sim-default.pt"


def _walk_past(traffic: TrafficMap, start: float = 0.0, x: float = 15.0, speed: float = 1.2) -> float:
    """One walker along x = ``x`` from y = 2 to y = 18 at ``speed``, observed every 0.1 s; the time it ends."""
    t = start
    for y in np.arange(2.0, 18.0, speed * 0.1):
        traffic.observe(t, np.array([[x, y]]), np.array([[0.0, speed]]))
        t += 0.1
    return t


def test_a_pass_counts_one_walker_along_its_lane_and_nothing_beside_it():
    traffic = TrafficMap(30.0, 20.0, radius=1.4, memory_s=1e9)  # no decay: the count itself
    _walk_past(traffic)
    on, edge, beside = traffic(np.array([[15.0, 10.0], [16.2, 10.0], [17.0, 10.0]]))
    assert on == pytest.approx(1.0, abs=0.2)  # one walker passed through here (stamped every 0.5 s)
    # 1.2 m beside the lane, inside contact distance: the part of the pass within it (chord / diameter, 0.51)
    assert edge == pytest.approx(math.sqrt(1.4**2 - 1.2**2) / 1.4, abs=0.2) and edge < on
    assert beside == 0.0  # beyond contact distance: a walker there would not touch a robot standing here
    _walk_past(traffic, start=20.0, speed=0.6)  # a slower second walker counts once, not twice
    assert traffic(np.array([15.0, 10.0])) == pytest.approx(2.0, abs=0.3)
    assert traffic(np.array([[-5.0, 10.0], [15.0, 40.0]])).tolist() == [0.0, 0.0]  # off the map


def test_standing_people_make_no_lane_and_passes_fade_with_the_memory():
    traffic = TrafficMap(30.0, 20.0, radius=1.4, memory_s=10.0)
    for k in range(100):
        traffic.observe(0.1 * k, np.array([[5.0, 5.0]]), np.array([[0.1, 0.0]]))  # shuffling on the spot
    assert traffic(np.array([5.0, 5.0])) == 0.0
    end = _walk_past(traffic, start=10.0)
    fresh = float(traffic(np.array([15.0, 10.0])))
    traffic.observe(end + 10.0, np.zeros((0, 2)), np.zeros((0, 2)))  # one memory later, nobody about
    assert float(traffic(np.array([15.0, 10.0]))) == pytest.approx(fresh / math.e, rel=0.1)


def test_waiting_in_a_lane_costs_and_driving_out_of_it_does_not():
    m = corridor_map()
    cfg = PredictivePlannerConfig()
    planner = PredictivePlanner(cfg, ConstantVelocityForecaster(PLANNER_TIMEBASE))
    planner.reset(info_for(m))
    here = np.array([15.0, 10.0])
    for k in range(400):  # walkers lately through the robot's spot, one every 5 s (none in view now)
        t = 0.1 * k
        y = 7.0 + 1.2 * (t % 5.0)
        obs = observation(
            m, pose=(*here, math.pi / 2), velocity=(0.0, 0.0), peds=[[15.0, y]], ped_vels=[[0.0, 1.2]], step=k
        )
        planner._lanes(obs, 1.4)
    obs = observation(m, pose=(*here, math.pi / 2), velocity=(0.0, 0.0), step=400)
    _, terms = planner.score_commands(obs, np.array([[0.0, 0.0], [2.0, 0.0]]))
    assert terms["lane"][0] > 2.0  # standing in the lane: several walkers lately
    assert terms["lane"][1] == 0.0  # driving on at full speed: nobody waits there
    off = PredictivePlanner(
        PredictivePlannerConfig.from_dict({"weights": {"lane": 0}}),
        ConstantVelocityForecaster(PLANNER_TIMEBASE),
    )
    off.reset(info_for(m))
    assert off.score_commands(obs, np.array([[0.0, 0.0]]))[1]["lane"][0] == 0.0  # weight 0: no map kept


def test_negative_lane_settings_are_refused_by_name():
    with pytest.raises(ConfigError, match="lane"):
        PredictivePlannerConfig.from_dict({"weights": {"lane": -1}})
    with pytest.raises(ConfigError, match="lane_memory_s"):
        PredictivePlannerConfig.from_dict({"safety": {"crowd": {"lane_memory_s": 0}}})


def test_a_robot_waiting_at_a_doorway_no_longer_stands_in_the_stream_of_people_who_do_not_see_it(
    reference_matrix_path,
):
    """The reference's medium doorway at walking speed, nobody yielding (seed 144): without lanes the robot waits at
    the door's mouth and a walker coming through walks into it; with them it waits beside the stream and gets through."""
    blind = {"simulation_config": {"ped_speed_tier": "typical", "peds_have_robot_repulsion": False}}
    scenario = load_matrix(reference_matrix_path, overrides=blind).get("classic_doorway_medium")
    predictor = load_predictor(CHECKPOINT)

    def outcome(lane: float) -> str:
        cfg = PredictivePlannerConfig.from_dict({"weights": {"lane": lane}})
        return run_episode(scenario, 144, PredictivePlanner(cfg, make_forecaster(predictor))).outcome

    assert outcome(2.0) == "success"
    assert outcome(0.0) == "collision_pedestrian"
