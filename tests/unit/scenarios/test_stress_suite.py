"""Realistic conditions: the stress suite (configs/scenarios/stress.yaml) and its training and replication seeds
(complete, realistic, disjoint), and our matrix's crowd defaults."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from foresight.core.scenarios.loader import load_matrix
from foresight.core.scenarios.seeds import load_seed_manifest
from foresight.core.sim.spawn_check import early_contacts
from tests.unit.bench_scripts import load_bench

REPO = Path(__file__).resolve().parents[3]
MATRIX = REPO / "configs" / "scenarios" / "stress.yaml"
TRAIN = REPO / "configs" / "seeds" / "stress_train.yaml"
REPLICATION = REPO / "configs" / "seeds" / "stress_replication.yaml"
ARCHETYPES = {
    "crossing",
    "cross_trap",
    "head_on_corridor",
    "overtaking",
    "bottleneck",
    "doorway",
    "merging",
    "t_intersection",
    "group_crossing",
    "station_platform",
    "urban_crossing",
}


def test_synthetic_part_is_every_archetype_at_realistic_speed_and_both_shares(shared_dir: Path) -> None:
    m = load_matrix(MATRIX)
    synthetic = [s for s in m.scenarios if s.scenario.replay is None]
    cells = {(s.scenario.archetype, s.scenario.simulation_config.nonreactive_fraction) for s in synthetic}
    assert cells == {(a, f) for a in ARCHETYPES for f in (0.3, 1.0)} and len(synthetic) == 22
    for s in synthetic:
        cfg = s.scenario.simulation_config
        assert cfg.ped_speed_tier == "realistic" and cfg.ped_density == 0.05 and cfg.peds_have_robot_repulsion
        assert len(set(s.scenario.seeds)) == 10


def test_no_episode_is_lost_before_a_planner_can_act(shared_dir: Path) -> None:
    """A robot standing still is touched by nobody in the first 1.5 s of any episode, training seeds included.

    Version 1 (the reference's 0.5 m spawn margin) lost 18 evaluation episodes that way, within 0.5-1.5 s: a walker
    placed next to the robot walking at it. Such an episode counts against every planner and measures none."""
    m = load_matrix(MATRIX)
    train = load_seed_manifest(TRAIN, m)
    assert early_contacts(m.scenarios) == []
    assert early_contacts([s for s in m.scenarios if s.name in train.seeds], seeds=train.seeds) == []
    # the check itself: version 1's spawn rule brings those episodes back
    v1 = load_matrix(MATRIX, overrides={"simulation_config": {"robot_spawn_clearance": 0.5}})
    lost = early_contacts(s for s in v1.scenarios if s.scenario.replay is None)
    assert len(lost) >= 10 and all(0 < c.time_s <= 1.5 for c in lost)


def test_training_seeds_cover_the_synthetic_scenarios_and_never_an_evaluation_seed(shared_dir: Path) -> None:
    m = load_matrix(MATRIX)
    train = load_seed_manifest(TRAIN, m)
    synthetic = {s.name for s in m.scenarios if s.scenario.replay is None}
    assert set(train.scenario_names) == synthetic
    for name in synthetic:
        assert len(train.seeds[name]) == 10
        assert not set(train.seeds[name]) & set(m.get(name).scenario.seeds)


def test_replication_seeds_are_new_episodes_of_every_synthetic_scenario(shared_dir: Path) -> None:
    """A second sample of the suite's conditions: no evaluation seed of any scenario, no training seed, and no
    episode lost before a planner can act (the suite's own spawn guarantee)."""
    m = load_matrix(MATRIX)
    rep, train = load_seed_manifest(REPLICATION, m), load_seed_manifest(TRAIN, m)
    synthetic = {s.name for s in m.scenarios if s.scenario.replay is None}
    assert set(rep.scenario_names) == synthetic
    evaluation = {x for s in m.scenarios for x in s.scenario.seeds}
    for name in synthetic:
        assert len(set(rep.seeds[name])) == 10
        assert not set(rep.seeds[name]) & (evaluation | set(train.seeds[name]))
    assert early_contacts([s for s in m.scenarios if s.name in rep.seeds], seeds=rep.seeds) == []


def test_replay_part_covers_the_five_scenes_with_at_least_30_episodes(shared_dir: Path) -> None:
    m = load_matrix(MATRIX)
    replay = [s for s in m.scenarios if s.scenario.replay is not None]
    families = {s.scenario.archetype for s in replay}
    assert len(replay) >= 30 and families == {
        f"replay_{x}" for x in ("eth", "hotel", "univ", "zara1", "zara2")
    }
    for s in replay:
        assert s.scenario.metadata["crossings"] >= 5 and s.scenario.simulation_config.max_episode_steps == 200
        start, goal = (np.asarray(p) for p in s.map.robot_routes[0].waypoints)
        assert np.hypot(*(goal - start)) >= 5.0
    assert {s.scenario.replay.frame_dt for s in replay if s.scenario.replay.scene == "biwi_eth"} == {0.64}


def test_files_are_what_the_generator_writes(tmp_path: Path, shared_dir: Path) -> None:
    load_bench("make_stress_suite").main(
        [
            "--out",
            str(tmp_path / "stress.yaml"),
            "--train-out",
            str(tmp_path / "train.yaml"),
            "--replication-out",
            str(tmp_path / "replication.yaml"),
        ]
    )
    stale = (
        "configs/ differ from what the generator writes: run `.venv/bin/python bench/make_stress_suite.py`"
    )
    assert (tmp_path / "stress.yaml").read_text() == MATRIX.read_text(), stale
    assert (tmp_path / "train.yaml").read_text() == TRAIN.read_text(), stale
    assert (tmp_path / "replication.yaml").read_text() == REPLICATION.read_text(), stale


def test_our_matrix_defaults_to_realistic_crowds_and_the_reference_keeps_its_own(
    reference_matrix_path: Path,
) -> None:
    ours = load_matrix(REPO / "configs" / "scenarios" / "classic_interactions.yaml")
    for s in ours.scenarios:
        cfg = s.scenario.simulation_config
        assert cfg.ped_speed_tier == "realistic" and cfg.nonreactive_fraction == 0.2
    for s in load_matrix(reference_matrix_path).scenarios:
        cfg = s.scenario.simulation_config
        assert (
            cfg.ped_speed_tier == "reference"
            and cfg.nonreactive_fraction == 0.0
            and cfg.peds_have_robot_repulsion
        )
