"""PredictivePlannerConfig: defaults, strictness, hash, and the reference grid mapping."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml
from pydantic import BaseModel

from foresight.core.errors import ConfigError
from foresight.core.planners.predictive.config import REFERENCE_KEY_MAP, PredictivePlannerConfig
from foresight.core.planners.predictive.config_keys import OLD_KEYS


@pytest.fixture(scope="module")
def grid_variants(reference_dir) -> list[dict]:
    path = reference_dir / "configs" / "benchmarks" / "predictive_sweep_planner_grid_v1.yaml"
    return yaml.safe_load(path.read_text())["variants"]


def test_resolved_has_every_key_and_hash_is_stable():
    cfg = PredictivePlannerConfig()
    res = cfg.resolved()
    assert set(res) == {"max_speed_ratio", "sampling", "search", "safety", "weights"}
    assert "collision" in res["weights"]["pedestrians"] and "distance" in res["sampling"]["near_field"]
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
    assert cfg.safety.pedestrians.ttc_distance == pytest.approx(base.safety.pedestrians.ttc_distance + 0.2)
    assert cfg.safety.pedestrians.extra_robot_margin == pytest.approx(0.2)
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
    path = Path(__file__).resolve().parents[3] / "configs" / "planners" / "predictive_grid_v1.yaml"
    variants = yaml.safe_load(path.read_text())["variants"]
    hashes = set()
    for v in variants:
        cfg = PredictivePlannerConfig.from_dict(v.get("config"), source=v["name"])
        if v.get("params"):
            cfg = PredictivePlannerConfig.from_reference_grid(v["params"], base=cfg, source=v["name"])
        hashes.add(cfg.config_hash())
    assert len(hashes) == len(variants)  # every variant differs from the others


def _sections(model=PredictivePlannerConfig, path="config"):
    yield path, model
    for name, field in model.model_fields.items():
        if isinstance(field.annotation, type) and issubclass(field.annotation, BaseModel):
            yield from _sections(field.annotation, f"{path}.{name}")


def test_no_section_holds_more_than_twelve_settings_and_each_says_what_it_is():
    for path, model in _sections():
        assert len(model.model_fields) <= 12, (path, list(model.model_fields))
        assert model.__doc__ and model.__doc__.strip(), path


def test_a_config_recorded_with_the_flat_keys_reads_as_the_same_config():
    """Every resolved config recorded before the settings were nested (runs, stored job specs) still validates,
    each flat key moved to its place: the recorded defaults are today's defaults."""
    flat = json.loads((Path(__file__).parent / "predictive_config_flat.json").read_text())
    assert PredictivePlannerConfig.from_dict(flat) == PredictivePlannerConfig()
    recorded = {(section, key) for section in OLD_KEYS for key in flat[section]}
    assert {(section, key) for section, keys in OLD_KEYS.items() for key in keys} <= recorded


def test_old_keys_move_to_their_place_and_unknown_ones_are_still_named():
    cfg = PredictivePlannerConfig.from_dict(
        {
            "safety": {"confidence": 0.5, "yield_speed": 0.0, "stall_after_s": 3.0},
            "sampling": {"turn_then_go": [], "veer_speeds": [0.5], "near_field_distance": 2.0},
            "weights": {"lane": 0.0, "static": 2.0, "static_collision": 500.0, "near_miss": 3.0},
        }
    )
    assert cfg.safety.pedestrians.confidence == 0.5 and cfg.safety.crowd.yielding.speed == 0.0
    assert cfg.safety.stall.after_s == 3.0 and cfg.sampling.point_turns.angles == ()
    assert cfg.sampling.veers.speed_ratios == (0.5,) and cfg.sampling.near_field.distance == 2.0
    assert cfg.weights.static.clearance == 2.0 and cfg.weights.static.collision == 500.0
    assert cfg.weights.lane == 0.0 and cfg.weights.pedestrians.near_miss == 3.0
    # an old key beside keys of its new group: both kept
    both = PredictivePlannerConfig.from_dict(
        {"safety": {"receding_room": 0.0, "crowd": {"lingering_s": 0.0}}}
    )
    assert both.safety.crowd.receding.room == 0.0 and both.safety.crowd.lingering_s == 0.0
    with pytest.raises(ConfigError) as exc:  # one setting given both ways
        PredictivePlannerConfig.from_dict({"safety": {"confidence": 0.5, "pedestrians": {"confidence": 2.0}}})
    assert exc.value.item == "safety" and "pedestrians.confidence" in str(exc.value)
    with pytest.raises(ConfigError) as exc:
        PredictivePlannerConfig.from_dict({"safety": {"confidance": 0.5}})
    assert exc.value.item == "safety.confidance"
    with pytest.raises(ConfigError) as exc:  # an old key's bad value is named at its new place
        PredictivePlannerConfig.from_dict({"sampling": {"veer_speeds": [-0.5]}})
    assert exc.value.item == "sampling.veers.speed_ratios"
