"""The rest of robot_sf's scenario language, each key seen doing what it says (corpus files and hand-built ones)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from foresight.core.errors import ConfigError
from foresight.core.maps.model import MapDef
from foresight.core.scenarios.loader import load_matrix, matrix_from_data
from foresight.core.scenarios.model import ObservationVisibility, SimulationConfig
from foresight.core.sim import heterogeneity
from foresight.core.sim.simulator import Simulator
from foresight.core.sim.visibility import visible

from .matrices import tiny_map, write


def _scen(corpus_dir: Path, rel: str, name: str):
    return load_matrix(corpus_dir / "configs/scenarios" / rel).get(name)


def test_route_overrides_file_replaces_the_robot_route(corpus_dir: Path) -> None:
    s = _scen(corpus_dir, "sets/safety_barrier_static_slice_v1.yaml", "goal_behind_robot")
    (route,) = s.map.robot_routes
    assert (route.spawn_id, route.goal_id, route.waypoints) == (0, 4, ((12.5, 10.0), (7.0, 10.0)))
    sim = Simulator()
    sim.reset(s, 0)
    corners = np.array(s.map.robot_goal_zones[4].corners)
    assert (corners.min(axis=0) <= sim.route.goal).all() and (sim.route.goal <= corners.max(axis=0)).all()


def test_route_payload_file_with_provenance_keys_sets_ped_and_robot_routes(corpus_dir: Path) -> None:
    s = _scen(
        corpus_dir,
        "sets/issue_1878_head_on_replay.yaml",
        "issue_1878_classic_head_on_corridor_low_guided_1502",
    )
    import yaml

    payload = yaml.safe_load(
        (
            corpus_dir / "configs/scenarios/route_overrides/issue_1878/"
            "classic_head_on_corridor_low_guided_1502.yaml"
        ).read_text()
    )["route_payload"]
    assert [list(map(list, r.waypoints)) for r in s.map.ped_routes] == [
        r["waypoints"] for r in payload["ped_routes"]
    ]


def test_inline_route_overrides_and_unknown_route_keys(tmp_path: Path) -> None:
    write(tmp_path / "tiny.yaml", tiny_map())
    inline = {"robot_routes": [{"spawn_id": 0, "goal_id": 9, "waypoints": [[2, 5], [10, 6], [16, 7]]}]}
    m = matrix_from_data(
        {"scenarios": [{"name": "a", "map_file": "tiny.yaml", "route_overrides": inline}]},
        source=tmp_path / "m.yaml",
    )
    mapdef = m.scenarios[0].map
    (route,) = mapdef.robot_routes
    assert route.waypoints[1] == (10.0, 6.0)
    # goal zone 9 does not exist: a 0.1 m zone at the route's end, as robot_sf makes
    assert route.goal_id == 1 and mapdef.robot_goal_zones[1].corners == ((16, 7), (16.1, 7), (16.1, 7.1))
    with pytest.raises(ConfigError, match="route_overrides.robot_routes.0.via: unsupported key"):
        matrix_from_data(
            {
                "scenarios": [
                    {
                        "name": "a",
                        "map_file": "tiny.yaml",
                        "route_overrides": {
                            "robot_routes": [
                                {"spawn_id": 0, "goal_id": 0, "waypoints": [[2, 5], [18, 5]], "via": 1}
                            ]
                        },
                    }
                ]
            },
            source=tmp_path / "m.yaml",
        )


def test_generated_replay_pedestrians_walk_their_recorded_paths(corpus_dir: Path) -> None:
    s = _scen(corpus_dir, "generated/generated-c64c6ffba1e4a51f.yaml", "generated-c64c6ffba1e4a51f")
    replay = s.scenario.generated_replay
    peds = {p.id: p for p in s.map.single_pedestrians}
    assert len(replay.pedestrians) == 12 and all(
        peds[p.id].trajectory == p.trajectory for p in replay.pedestrians
    )
    sim = Simulator()
    sim.reset(s, s.scenario.seeds[0])
    assert (
        np.linalg.norm(sim.route.start - replay.robot.start) < 0.15
    )  # the robot starts where it was recorded
    assert np.linalg.norm(sim.route.goal - replay.robot.goal) < 0.15


def test_archetype_and_response_law_compositions_are_exact_and_seeded() -> None:
    cfg = SimulationConfig(
        archetype_composition={"cautious": 0.34, "standard": 0.33, "hurried": 0.33},
        archetype_speed_factors={"cautious": 0.7, "standard": 1.0, "hurried": 1.4},
        archetype_seed=3206,
        response_law_composition={"reactive": 0.6, "hesitating": 0.4},
        hesitating_response_multiplier=1.8,
    )
    rng = np.random.default_rng(0)
    f = heterogeneity.speed_factors(10, cfg, rng)
    assert (
        sorted(f.tolist()) == [0.7] * 4 + [1.0] * 3 + [1.4] * 3
    )  # largest remainder: 3.4 -> 4, 3.3, 3.3 -> 3
    assert np.array_equal(f, heterogeneity.speed_factors(10, cfg, np.random.default_rng(99)))  # its own seed
    r = heterogeneity.robot_responses(10, cfg, rng)
    assert sorted(r.tolist()) == [1.0] * 6 + [1.8] * 4
    with pytest.raises(ValueError, match="shares must sum to 1"):
        SimulationConfig(response_law_composition={"reactive": 0.5})
    with pytest.raises(ValueError, match="archetype_speed_factors lacks standard"):
        SimulationConfig(archetype_composition={"standard": 1.0}, archetype_speed_factors={"fast": 1.2})


def test_compositions_reach_the_crowd(corpus_dir: Path) -> None:
    mixed = _scen(
        corpus_dir, "sets/issue_3206_heterogeneous_pedestrian_smoke.yaml", "issue_3206_classic_crossing_mixed"
    )
    sim = Simulator()
    sim.reset(mixed, 101)
    assert len(set(np.round(sim.crowd.vmax, 6))) > 1  # 0.65 m/s x 0.7 / 1.0 / 1.4
    blocks = _scen(
        corpus_dir, "archetypes/issue_4974_field_observed_ped_robot.yaml", "issue_4974_pedestrian_hesitation"
    )
    sim.reset(blocks, blocks.scenario.seeds[0])
    assert (
        set(np.round(sim.crowd.robot_response, 6)) <= {1.0, 1.8} and (sim.crowd.robot_response == 1.8).any()
    )
    assert sim.dynamics.p.robot_factor == 10.0 and sim.dynamics.robot_radius == 1.0


def test_prf_config_sets_the_robot_repulsion(corpus_dir: Path) -> None:
    s = _scen(
        corpus_dir,
        "archetypes/issue_4974_field_observed_ped_robot.yaml",
        "issue_4974_robot_blocks_narrow_path",
    )
    sim = Simulator()
    sim.reset(s, s.scenario.seeds[0])
    assert (sim.dynamics.p.robot_factor, sim.dynamics.p.robot_activation, sim.dynamics.robot_radius) == (
        15.0,
        2.5,
        1.2,
    )
    reach = sim.dynamics.robot_reach
    assert reach is None or np.allclose(
        reach[reach > 0], 2.5 + 0.35 + 1.2
    )  # the cutoff follows the calibration


def test_peds_reset_follow_route_at_start_places_groups_in_the_spawn_zone(corpus_dir: Path) -> None:
    s = _scen(
        corpus_dir,
        "sets/issue_3813_sustained_flow_scaffold_v0.yaml",
        "issue_3813_sustained_flow_t_intersection_heavy",
    )
    sim = Simulator()
    sim.reset(s, s.scenario.seeds[0])
    spawn = s.map.ped_spawn_zones[s.map.ped_routes[0].spawn_id]
    lo, hi = np.min(spawn.corners, axis=0) - 1e-6, np.max(spawn.corners, axis=0) + 1e-6
    assert len(sim.crowd.pos) > 0 and all(((lo <= p) & (p <= hi)).all() for p in sim.crowd.pos)


def test_observation_visibility_filters_what_the_planner_sees() -> None:
    robot = np.array([0.0, 0.0, 0.0])
    pts = np.array([[5.0, 0.0], [-5.0, 0.0], [20.0, 0.0], [5.0, 4.0], [8.0, 0.2]])
    wall = np.array([[7.0, -1.0, 7.0, 1.0]])
    vis = ObservationVisibility(fov_degrees=160, max_range_m=9.0, static_occlusion=True)
    assert visible(robot, pts, vis, wall).tolist() == [True, False, False, True, False]
    assert ObservationVisibility(enabled=False, fov_degrees=90).active is False


def test_visibility_scenario_hides_pedestrians_only_from_the_observation(corpus_dir: Path) -> None:
    m = load_matrix(
        corpus_dir / "configs/scenarios/sets/vulnerable_user_proxy_pack_v0_deferred_issue3654.yaml"
    )
    s = next(s for s in m.scenarios if s.scenario.observation_visibility is not None)
    sim = Simulator()
    obs = sim.reset(s, s.scenario.seeds[0])
    seen = visible(sim.robot, sim.crowd.pos, s.scenario.observation_visibility, s.map.obstacle_segments)
    assert len(obs.ped_ids) == seen.sum() and sim.trace.ped_ids.shape[1] == len(sim.crowd.pos)


@pytest.mark.parametrize(
    ("sim_cfg", "message"),
    [
        ({"route_spawn_distribution": "uniform"}, None),
        ({"robot_config": {}}, None),
        ({"robot_config": {"radius": 0.3}}, "robot_config belongs at scenario level"),
    ],
)
def test_reference_spellings_of_simulation_config(sim_cfg: dict, message: str | None) -> None:
    if message is None:
        cfg = SimulationConfig(**sim_cfg)
        assert cfg.route_spawn_distribution == "cluster"
    else:
        with pytest.raises(ValueError, match=message):
            SimulationConfig(**sim_cfg)


def test_platform_semantics_needing_a_consumer_is_refused(tmp_path: Path) -> None:
    write(tmp_path / "tiny.yaml", tiny_map())
    regions = [{"id": "r", "kind": "hazard", "shape": "bbox", "bounds": [1, 1, 2, 2]}]
    ok = {
        "name": "a",
        "map_file": "tiny.yaml",
        "platform_semantics": {"status": "metadata_only", "regions": regions},
    }
    assert (
        matrix_from_data({"scenarios": [ok]}, source=tmp_path / "m.yaml")
        .scenarios[0]
        .scenario.platform_semantics
    )
    bad = {**ok, "platform_semantics": {"status": "require_consumers", "regions": regions}}
    with pytest.raises(ConfigError, match="platform_semantics.status"):
        matrix_from_data({"scenarios": [bad]}, source=tmp_path / "m.yaml")
    flat = {**ok, "platform_semantics": {"regions": [{**regions[0], "bounds": [1, 1, 1, 2]}]}}
    with pytest.raises(ConfigError, match="region 'r': a bbox needs bounds"):
        matrix_from_data({"scenarios": [flat]}, source=tmp_path / "m.yaml")


def test_robot_sf_map_format_is_read_with_its_margins(tmp_path: Path) -> None:
    from foresight.core.maps.io import load_map

    doc = {
        "x_margin": [10, 22],
        "y_margin": [5, 13],
        "obstacles": [[[14, 7], [15, 7], [15, 8]]],
        "robot_spawn_zones": [[[11, 6], [12, 6], [12, 7]]],
        "robot_goal_zones": [[[20, 6], [21, 6], [21, 7]]],
        "ped_spawn_zones": [],
        "ped_goal_zones": [],
        "ped_crowded_zones": [],
        "robot_routes": [{"spawn_id": 0, "goal_id": 0, "waypoints": [[11.5, 6.5], [20.5, 6.5]]}],
        "ped_routes": [],
    }
    m: MapDef = load_map(write(tmp_path / "rsf.yaml", doc))
    assert (m.width, m.height) == (12, 8) and m.obstacles[0][0] == (4.0, 2.0)
    zone = {
        "id": "stairs",
        "zone_type": "stairs",
        "vertices": [[16, 5], [18, 5], [18, 13], [16, 13]],
        "allowed_actor_types": ["pedestrian"],
    }
    with pytest.raises(ConfigError, match="robot route 0 enters infrastructure zone 'stairs'"):
        load_map(write(tmp_path / "rsf2.yaml", {**doc, "infrastructure_zones": [zone]}))
