"""configs/pipelines/crowdnav.yaml: a predictor trained on CrowdNav++ crowds at their 0.25 s steps, on training
episodes only, end to end through the same config at a tiny size."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import yaml

from foresight.core.jobs.pipeline.config import load_pipeline_config, stage_config
from foresight.core.jobs.pipeline.runbook import check_seed_separation
from foresight.core.runtime.context import StageContext
from foresight.core.runtime.refs import BUILTIN_CONFIG_ROOT
from foresight.core.scenarios.loader import load_matrix
from foresight.core.training.collect import episode_list

CONFIG = BUILTIN_CONFIG_ROOT / "pipelines" / "crowdnav.yaml"
SUITES = BUILTIN_CONFIG_ROOT / "scenarios" / "crowdnav"
INPUTS = {"base": "b", "hardcase": "h", "mixed": "m", "model": "cand"}


def _ctx(workdir: Path = Path(".")) -> StageContext:
    return StageContext(workdir=workdir, resolve_bundle=lambda ident: BUILTIN_CONFIG_ROOT)


def test_training_episodes_never_meet_the_test_cases_of_any_crowdnav_suite() -> None:
    config = load_pipeline_config(CONFIG)
    collect = stage_config(config, "collect", INPUTS)
    matrix = load_matrix(BUILTIN_CONFIG_ROOT / config.matrix)
    collected = {int(seed) for _, seed, _ in episode_list(collect, matrix)}
    hard = {
        int(seed) for _, seed, _ in episode_list(collect, matrix, BUILTIN_CONFIG_ROOT / config.training_seeds)
    }
    assert len(collected) == collect.seeds_per_scenario and hard
    suites = sorted(SUITES.glob("*.yaml"))
    assert {p.stem for p in suites} >= {
        "circle_crossing",
        "square_crossing",
        "crowdnavpp_no_rand",
        "crowdnavpp_rand",
    }
    for path in suites:
        test = {int(s) for sc in load_matrix(path).scenarios for s in sc.scenario.seeds}
        assert len(test) == 500, path.name  # the originals' 500 test cases
        assert not (collected | hard) & test, path.name
    assert check_seed_separation(config, _ctx())["training_seeds"] == len(hard)


def test_it_trains_at_the_suites_time_base_with_the_crowdnav_planner_config() -> None:
    config = load_pipeline_config(CONFIG)
    collect = stage_config(config, "collect", INPUTS)
    tb = collect.timebase.build()
    assert tb.stride(0.25) == 1 and tb.dt * tb.horizon >= 2.4  # at least the planner's 2.4 s ahead
    planner = yaml.safe_load((BUILTIN_CONFIG_ROOT / "planners" / "crowdnav" / "predictive.yaml").read_text())
    assert collect.planner == {"name": "predictive", "model": "cv", "config": planner["config"]}
    for stage in ("evaluate", "campaign"):
        spec = stage_config(config, stage, INPUTS).planner
        assert (
            spec.name == "predictive"
            and spec.model_dump(mode="json")["config"]
            == stage_config(config, "evaluate", INPUTS).planner.model_dump(mode="json")["config"]
        )
    assert stage_config(config, "evaluate", INPUTS).planner.model == "cand"


def _tiny(config_path: Path, out: Path) -> Path:
    """The same config at smoke size: a few short episodes, one small epoch, relaxed gates (never promoted)."""
    data: dict[str, Any] = yaml.safe_load(config_path.read_text())
    data["workers"] = 1
    data["collect"].update(seeds_per_scenario=6, max_steps=40)
    data["train"].update(epochs=1, hidden=8, blocks=1, edge_dim=4, batch_size=64, allow_degenerate=True)
    data["train"]["gates"] = {"max_val_ade": 10.0, "max_val_fde": 20.0, "require_beat_cv": False}
    data["evaluate"].update(
        seeds_per_scenario=1, max_steps=20, gate={"min_success_rate": 0.0, "min_mean_clearance": -10.0}
    )
    data["campaign"].update(seeds_per_scenario=1, max_steps=20)
    data["campaign"]["gate"].update(
        min_global_success_delta=-1.0, min_hard_success_delta=-1.0, max_clearance_regression=10.0
    )
    data["conformance"].update(steps=5, crowd=20, decision_budget_s=60.0)
    data["gates"]["relaxed"] = True
    data["gates"]["floors"] = {
        "max_success_below_cv": 1.0,
        "require_ade_below_cv": False,
        "require_fde_below_cv": False,
    }
    path = out / "crowdnav-tiny.yaml"
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def test_the_config_runs_end_to_end_at_smoke_size_and_its_model_drives_the_planner_on_quarter_second_steps(
    tmp_path: Path,
) -> None:
    from foresight.cli.pipeline import run_local
    from foresight.core.planners.predictive.planner import PredictivePlanner
    from foresight.core.planners.registry import make_forecaster
    from foresight.core.predict.nn.checkpoint import load_predictor
    from foresight.core.sim.episode import run_episode

    result, workdir = run_local(str(_tiny(CONFIG, tmp_path)), str(tmp_path / "run"), None, quiet=True)
    stages = {s.name: s.status for s in result.stages}
    for stage in ("collect", "train", "register", "evaluate", "cv_baseline", "campaign", "conformance"):
        assert stages.get(stage) not in (None, "skipped", "failed", "cancelled"), stages
    assert (
        stages.get("hardcase") in (None, "skipped") and result.model_id and not result.promoted
    )  # relaxed: never promoted
    model = load_predictor(workdir / "train" / "model.pt")
    assert model.timebase.dt == 0.25 and model.timebase.horizon == 10
    sc = load_matrix(SUITES / "crowdnavpp_rand.yaml").get("crowdnavpp_rand")
    planner = PredictivePlanner(None, make_forecaster(model))
    res = run_episode(sc, 20000, planner, max_steps=8)  # a training seed
    assert res.steps == 8 and planner.forecaster.source.startswith("learned")
    assert np.allclose(planner.forecaster.timebase.times, 0.25 * np.arange(1, 11))
