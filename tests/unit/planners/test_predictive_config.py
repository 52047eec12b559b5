"""PredictivePlannerConfig: defaults, strictness, hash, and the reference grid mapping."""

from __future__ import annotations

import pytest
import yaml

from foresight.core.errors import ConfigError
from foresight.core.planners.predictive.config import REFERENCE_KEY_MAP, PredictivePlannerConfig


@pytest.fixture(scope="module")
def grid_variants(reference_dir) -> list[dict]:
    path = reference_dir / "configs" / "benchmarks" / "predictive_sweep_planner_grid_v1.yaml"
    return yaml.safe_load(path.read_text())["variants"]


def test_resolved_has_every_key_and_hash_is_stable():
    cfg = PredictivePlannerConfig()
    res = cfg.resolved()
    assert set(res) == {"max_speed_ratio", "sampling", "search", "safety", "weights"}
    assert "collision" in res["weights"] and "near_field_distance" in res["sampling"]
    assert cfg.config_hash() == PredictivePlannerConfig.from_dict(res).config_hash()
    assert len(cfg.config_hash()) == 64
    other = PredictivePlannerConfig.from_dict({"weights": {"goal": 5.0}})
    assert other.config_hash() != cfg.config_hash()


def test_unknown_nested_key_is_a_config_error():
    with pytest.raises(ConfigError) as exc:
        PredictivePlannerConfig.from_dict({"weights": {"goall": 1.0}})
    assert "weights.goall" in str(exc.value)


def test_every_reference_grid_variant_maps(grid_variants):
    assert len(grid_variants) == 4
    base = PredictivePlannerConfig()
    for variant in grid_variants:
        cfg = PredictivePlannerConfig.from_reference_grid(variant["params"], source=variant["name"])
        assert cfg.config_hash() != base.config_hash(), variant["name"]
        # heading deltas become distinct turn rates (the reference collapsed them to three)
        assert len(set(cfg.sampling.turn_rates)) == len(
            variant["params"]["predictive_candidate_heading_deltas"]
        )
        assert cfg.sampling.speed_ratios == tuple(variant["params"]["predictive_candidate_speeds"])


def test_mapping_rules():
    base = PredictivePlannerConfig()
    cfg = PredictivePlannerConfig.from_reference_grid(
        {
            "predictive_goal_weight": 12.0,  # twice the reference's 6.0 -> twice ours
            "predictive_ttc_distance": 1.1,  # reference 0.9 + 0.2 -> ours + 0.2
            "predictive_robot_radius": 0.45,  # 0.2 above the reference's planning radius -> 0.2 m extra margin
            "predictive_horizon_boost_steps": 6,  # reference 0.2 s steps
            "predictive_candidate_heading_deltas": [-0.5, 0.0, 0.5],  # rad over one second
        }
    )
    assert cfg.weights.goal == pytest.approx(2 * base.weights.goal)
    assert cfg.safety.ttc_distance == pytest.approx(base.safety.ttc_distance + 0.2)
    assert cfg.safety.extra_robot_margin == pytest.approx(0.2)
    assert cfg.search.horizon_boost_s == pytest.approx(1.2)
    assert cfg.sampling.turn_rates == (-0.5, 0.0, 0.5)


def test_unmappable_reference_key_is_named():
    with pytest.raises(ConfigError) as exc:
        PredictivePlannerConfig.from_reference_grid(
            {"predictive_goal_weight": 5.0, "predictive_mcts_enabled": True}
        )
    assert exc.value.item == "predictive_mcts_enabled"
    assert len(REFERENCE_KEY_MAP) >= 20


def test_bad_reference_value_is_named():
    with pytest.raises(ConfigError) as exc:
        PredictivePlannerConfig.from_reference_grid({"predictive_collision_weight": "high"})
    assert exc.value.item == "predictive_collision_weight"


def test_our_planner_grid_resolves():
    from pathlib import Path

    path = Path(__file__).resolve().parents[3] / "configs" / "planners" / "predictive_grid_v1.yaml"
    variants = yaml.safe_load(path.read_text())["variants"]
    hashes = set()
    for v in variants:
        cfg = PredictivePlannerConfig.from_dict(v.get("config"), source=v["name"])
        if v.get("params"):
            cfg = PredictivePlannerConfig.from_reference_grid(v["params"], base=cfg, source=v["name"])
        hashes.add(cfg.config_hash())
    assert len(hashes) == len(variants)  # every variant differs from the others
