"""The predictive planner's CrowdNav config (configs/planners/crowdnav/predictive.yaml) is a valid planner file and
gets the 0.3 m robot across the circle crossing sooner than the defaults, without contact."""

from __future__ import annotations

from pathlib import Path

import yaml

from foresight.core.evaluation.plannerspec import planner_config, planner_spec
from foresight.core.planners.predictive.config import PredictivePlannerConfig
from foresight.core.planners.predictive.planner import PredictivePlanner
from foresight.core.predict.forecaster import ConstantVelocityForecaster
from foresight.core.predict.timebase import PLANNER_TIMEBASE
from foresight.core.scenarios.loader import load_matrix
from foresight.core.sim.episode import run_episode

REPO = Path(__file__).resolve().parents[3]
CONFIG = REPO / "configs/planners/crowdnav/predictive.yaml"
CIRCLE = REPO / "configs/scenarios/crowdnav/circle_crossing.yaml"


def _episode(cfg: PredictivePlannerConfig, seed: int) -> tuple[str, int]:
    scenario = load_matrix(CIRCLE).get("crowdnav_circle_crossing")
    result = run_episode(scenario, seed, PredictivePlanner(cfg, ConstantVelocityForecaster(PLANNER_TIMEBASE)))
    return result.outcome, result.steps


def test_the_crowdnav_config_is_a_predictive_planner_file_with_constant_velocity() -> None:
    spec = planner_spec(yaml.safe_load(CONFIG.read_text()))
    assert spec.name == "predictive" and spec.model == "cv"
    cfg = planner_config(spec)
    assert isinstance(cfg, PredictivePlannerConfig)
    default = PredictivePlannerConfig()
    assert (
        cfg.safety.pedestrians.near_distance < default.safety.pedestrians.near_distance
    )  # bands for a 0.3 m robot
    assert cfg.safety.pedestrians.collision_margin == default.safety.pedestrians.collision_margin
    assert (
        cfg.safety.crowd.receding.room == 0.0 and cfg.safety.crowd.yielding.speed == 0.0
    )  # humans never see the robot


def test_the_crowdnav_config_reaches_the_goal_sooner_than_the_defaults() -> None:
    cfg = planner_config(planner_spec(yaml.safe_load(CONFIG.read_text())))
    for seed in (1000, 1001):  # CrowdNav's test cases 0 and 1: 13.5 s and 14 s at the defaults
        tuned, default = _episode(cfg, seed), _episode(PredictivePlannerConfig(), seed)
        assert tuned[0] == default[0] == "success"
        assert tuned[1] < default[1], (seed, tuned, default)
