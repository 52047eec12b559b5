"""Files of the reference corpus that are not scenario matrices are refused by kind, in one line."""

from __future__ import annotations

from pathlib import Path

import pytest

from foresight.core.errors import ConfigError
from foresight.core.scenarios.loader import load_matrix, matrix_from_data

from .matrices import tiny_map, write

NOT_MATRICES = [
    ("archetype_validation_waivers.yaml", "validation waiver list"),
    ("archetypes/classic_density_tier_index.yaml", "density-tier index"),
    ("contracts/issue_2164_amv_cross_trap_contracts.yaml", "scenario contract set"),
    ("contracts/issue_6054_regulation_source_example.yaml", "regulation record"),
    ("generated/issue_5264_generated_replay_catalog.yaml", "generated-scenario catalog"),
    ("generated/issue_5264_review_manifest.yaml", "generated-scenario review manifest"),
    ("perturbations/issue_3369_occluder_timing_pilot_v1.yaml", "perturbation manifest"),
    ("multi_extractor_default.yaml", "training run config"),
    ("maps/issue_2926_stair_access.yaml", "map definition"),
    ("route_overrides/issue_596/goal_behind_robot.yaml", "route-override payload"),
    ("route_overrides/issue_3977/safe_braking.yaml", "route-override payload"),
    ("collision_sanity.yaml", "parametric scenario-generator spec"),
    ("sets/issue_3279_social_mini_game_families_v0.yaml", "parametric scenario-generator spec"),
    ("results/performance_smoke_test.json", "result index"),
]


@pytest.mark.parametrize(("rel", "kind"), NOT_MATRICES)
def test_non_matrix_file_is_refused_by_kind(corpus_dir: Path, rel: str, kind: str) -> None:
    path = corpus_dir / "configs/scenarios" / rel
    with pytest.raises(ConfigError) as info:
        load_matrix(path)
    assert str(info.value) == f"{path}: not a scenario matrix (it is a {kind})"


def test_schema_version_must_name_a_matrix_schema(tmp_path: Path) -> None:
    with pytest.raises(
        ConfigError, match="schema_version 'robot_sf.scenario_matrix.v9' is not a scenario matrix"
    ):
        matrix_from_data(
            {"schema_version": "robot_sf.scenario_matrix.v9", "scenarios": []}, source=tmp_path / "m.yaml"
        )


def test_defaults_block_is_an_anchor_holder(tmp_path: Path) -> None:

    write(tmp_path / "tiny.yaml", tiny_map())
    text = (
        "schema_version: robot_sf.scenario_matrix.v1\n"
        "defaults:\n  seeds: &seeds [7, 8]\n  plausibility: {status: unverified}\n"
        "scenarios:\n  - {name: a, map_file: tiny.yaml, seeds: *seeds}\n  - {name: b, map_file: tiny.yaml}\n"
    )
    m = load_matrix(write(tmp_path / "m.yaml", text))
    assert [s.scenario.seeds for s in m.scenarios] == [(7, 8), (0,)]  # aliased where used, never applied


def test_map_id_finds_the_registry_above_the_file(corpus_dir: Path) -> None:
    m = load_matrix(corpus_dir / "configs/scenarios/archetypes/classic_cross_trap.yaml")
    assert {s.map.name for s in m.scenarios} == {"classic_cross_trap"}
