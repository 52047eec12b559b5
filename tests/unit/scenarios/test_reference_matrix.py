"""The reference (robot_sf) classic matrix loads unchanged, with the values of reference-simulation.md section 6.3."""

from __future__ import annotations

from pathlib import Path

import pytest

from foresight.core.errors import ConfigError
from foresight.core.scenarios.loader import load_matrix, matrix_from_data
from foresight.core.scenarios.model import ScenarioMatrix
from foresight.core.scenarios.seeds import load_seed_manifest

# name, map (file stem or map id), ped_density, max_episode_steps, first seed (3 consecutive seeds)
EXPECTED = [
    ("classic_bottleneck_low", "classic_bottleneck", 0.0, 500, 131),
    ("classic_bottleneck_medium", "classic_bottleneck_medium", 0.0, 500, 131),
    ("classic_bottleneck_high", "classic_bottleneck_high", 0.0, 500, 131),
    ("classic_realworld_double_bottleneck_high", "classic_realworld_bottleneck", 0.0, 700, 201),
    ("classic_station_platform_medium", "classic_station_platform", 0.05, 650, 301),
    ("classic_cross_trap_low", "classic_cross_trap", 0.02, 600, 101),
    ("classic_cross_trap_medium", "classic_cross_trap", 0.05, 600, 101),
    ("classic_cross_trap_high", "classic_cross_trap", 0.08, 600, 101),
    ("classic_doorway_low", "classic_doorway", 0.02, 500, 141),
    ("classic_doorway_medium", "classic_doorway", 0.05, 500, 141),
    ("classic_doorway_high", "classic_doorway", 0.08, 500, 141),
    ("classic_group_crossing_low", "classic_group_crossing", 0.04, 500, 171),
    ("classic_group_crossing_medium", "classic_group_crossing", 0.08, 500, 171),
    ("classic_group_crossing_high", "classic_group_crossing", 0.12, 500, 171),
    ("classic_head_on_corridor_low", "classic_head_on_corridor", 0.02, 500, 111),
    ("classic_head_on_corridor_medium", "classic_head_on_corridor", 0.05, 500, 111),
    ("classic_merging_low", "classic_merging", 0.02, 600, 151),
    ("classic_merging_medium", "classic_merging", 0.05, 600, 151),
    ("classic_overtaking_low", "classic_overtaking", 0.02, 600, 121),
    ("classic_overtaking_medium", "classic_overtaking", 0.05, 600, 121),
    ("classic_t_intersection_low", "classic_t_intersection", 0.02, 500, 161),
    ("classic_t_intersection_medium", "classic_t_intersection", 0.05, 500, 161),
    ("classic_urban_crossing_medium", "classic_urban_crossing", 0.05, 600, 101),
]


@pytest.fixture(scope="module")
def matrix(reference_matrix_path: Path) -> ScenarioMatrix:
    return load_matrix(reference_matrix_path)


def test_twenty_three_scenarios_in_file_order(matrix: ScenarioMatrix) -> None:
    assert matrix.names == [e[0] for e in EXPECTED]


@pytest.mark.parametrize("name, map_name, density, steps, seed0", EXPECTED, ids=[e[0] for e in EXPECTED])
def test_scenario_values(
    matrix: ScenarioMatrix, name: str, map_name: str, density: float, steps: int, seed0: int
) -> None:
    s = matrix.get(name)
    sim = s.scenario.simulation_config
    assert s.map.name == map_name
    assert sim.ped_density == density
    assert sim.max_episode_steps == steps
    assert s.scenario.seeds == (seed0, seed0 + 1, seed0 + 2)
    assert s.scenario.robot_config.type == "differential_drive"
    assert s.map_sha256 is not None and len(s.map_sha256) == 64


def test_cross_trap_map_id_resolves_to_classic_crossing_svg(matrix: ScenarioMatrix) -> None:
    s = matrix.get("classic_cross_trap_high")
    assert s.scenario.map_id == "classic_cross_trap"
    assert Path(s.map.source or "").name == "classic_crossing.svg"


def test_reference_specific_settings(matrix: ScenarioMatrix) -> None:
    doorway = matrix.get("classic_doorway_low").scenario.simulation_config
    assert (
        doorway.route_spawn_distribution,
        doorway.route_spawn_jitter_frac,
        doorway.max_peds_per_group,
    ) == ("spread", 0.2, 1)
    assert matrix.get("classic_group_crossing_low").scenario.simulation_config.groups == 0.5
    assert matrix.get("classic_cross_trap_low").scenario.archetype == "cross_trap"
    assert matrix.get("classic_cross_trap_low").scenario.density_label == "low"


def test_single_pedestrian_overrides_are_applied_by_id(matrix: ScenarioMatrix) -> None:
    realworld = matrix.get("classic_realworld_double_bottleneck_high").map
    assert sorted(p.id for p in realworld.single_pedestrians) == [
        "l1",
        "l2",
        "l3",
        "l4",
        "r1",
        "r2",
        "r3",
        "r4",
    ]
    assert all(p.speed_m_s == 0.7 for p in realworld.single_pedestrians)
    assert realworld.single_pedestrian("l1").start == (10.0, 9.0)
    assert realworld.single_pedestrian("r4").goal == (10.0, 10.5)
    platform = matrix.get("classic_station_platform_medium").map
    p1 = platform.single_pedestrian("p1")
    assert p1.goal is None  # goal: null in the YAML clears the marker's goal
    assert p1.trajectory == ((24.0, 22.0), (24.0, 18.5), (38.0, 22.0), (76.0, 22.0))
    assert [(w.waypoint_index, w.wait_s) for w in p1.wait_at] == [(1, 6.0)]
    assert platform.single_pedestrian("p3").wait_at[0].wait_s == 5.0


def test_bottleneck_markers_come_from_the_map(matrix: ScenarioMatrix) -> None:
    counts = [
        len(matrix.get(f"classic_bottleneck_{d}").map.single_pedestrians) for d in ("low", "medium", "high")
    ]
    assert counts == [0, 1, 3]


def test_hard_seed_manifest_against_reference_matrix(reference_dir: Path, matrix: ScenarioMatrix) -> None:
    manifest = load_seed_manifest(reference_dir / "configs/benchmarks/predictive_hard_seeds_v1.yaml", matrix)
    assert len(manifest) == 7
    assert list(manifest.pairs())[:4] == [
        ("classic_cross_trap_high", 101),
        ("classic_cross_trap_high", 102),
        ("classic_cross_trap_high", 103),
        ("classic_cross_trap_medium", 102),
    ]
    assert manifest.seeds["classic_group_crossing_high"] == (171,)


def test_excluded_alias_file_loads_with_its_evaluation_notes(reference_dir: Path) -> None:
    m = load_matrix(reference_dir / "configs/scenarios/archetypes/classic_crossing.yaml")
    assert m.names == ["classic_crossing_low", "classic_crossing_medium", "classic_crossing_high"]
    (notes,) = m.metadata["file_notes"].values()
    assert notes["evaluation"] == "excluded"


def test_density_index_is_not_a_matrix(reference_dir: Path) -> None:
    with pytest.raises(ConfigError) as info:
        load_matrix(reference_dir / "configs/scenarios/archetypes/classic_density_tier_index.yaml")
    assert Path(info.value.source).name == "classic_density_tier_index.yaml"
    assert info.value.detail == "not a scenario matrix (it is a density-tier index)"
    assert str(info.value) == f"{info.value.source}: not a scenario matrix (it is a density-tier index)"


def test_apply_transforms_reaches_the_svg_importer(reference_matrix_path: Path) -> None:
    inline = {
        "includes": ["archetypes/classic_bottleneck.yaml"],
        "map_search_paths": ["../../maps/svg_maps"],
        "select_scenarios": ["classic_bottleneck_low"],
    }
    raw = matrix_from_data(inline, source=reference_matrix_path)
    drawn = matrix_from_data(inline, source=reference_matrix_path, apply_transforms=True)
    assert raw.names == drawn.names == ["classic_bottleneck_low"]
    a, b = raw.scenarios[0].map.ped_routes[0].array, drawn.scenarios[0].map.ped_routes[0].array
    assert a.shape == b.shape and not (a == b).all()  # the pedestrian group's translate is applied


def test_required_map_profile_is_checked(reference_matrix_path: Path) -> None:
    inline = {
        "map_search_paths": ["../../maps/svg_maps"],
        "scenarios": [
            {"name": "x", "map_id": "classic_cross_trap", "required_map_profile": "no_such_capability"}
        ],
    }
    with pytest.raises(ConfigError) as info:
        matrix_from_data(inline, source=reference_matrix_path)
    assert info.value.item == "classic_cross_trap" and "capability" in info.value.detail
