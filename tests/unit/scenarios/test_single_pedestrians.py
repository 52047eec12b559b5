"""Scenario single-pedestrian entries: POIs from the SVG, roles, holds, new peds, and errors before any episode."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from foresight.core.errors import ConfigError
from foresight.core.scenarios.loader import load_matrix
from foresight.core.sim.simulator import Simulator

from .matrices import write

SVG = """<svg xmlns="http://www.w3.org/2000/svg" xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape"
     width="30" height="20">
  <rect inkscape:label="robot_spawn_zone" x="1" y="1" width="2" height="2"/>
  <rect inkscape:label="robot_goal_zone" x="26" y="1" width="2" height="2"/>
  <path inkscape:label="robot_route_0_0" d="M 2 2 L 27 2"/>
  <circle inkscape:label="single_ped_p1_start" cx="5" cy="15" r="0.3"/>
  <circle inkscape:label="single_ped_p1_goal" cx="6" cy="15" r="0.3"/>
  <circle class="poi" id="poi_exit" inkscape:label="exit_checkpoint" cx="24" cy="12" r="0.4"/>
  <circle class="poi" id="poi_mid" cx="15" cy="10" r="0.4"/>
</svg>
"""


def _matrix(tmp_path: Path, peds: list[dict], **scenario) -> Path:
    write(tmp_path / "poi_map.svg", SVG)
    doc = {
        "scenarios": [
            {
                "name": "s",
                "map_file": "poi_map.svg",
                "single_pedestrians": peds,
                "simulation_config": {"ped_density": 0.0, "max_episode_steps": 400},
                **scenario,
            }
        ]
    }
    return write(tmp_path / "m.yaml", doc)


def test_goal_poi_resolves_to_the_svg_point_by_label_or_id(tmp_path: Path) -> None:
    m = load_matrix(
        _matrix(
            tmp_path,
            [
                {"id": "p1", "goal_poi": "exit_checkpoint"},
                {"id": "p2", "start": [8, 15], "goal_poi": "poi_mid", "speed_m_s": 1.0},
            ],
        )
    )
    peds = {p.id: p for p in m.scenarios[0].map.single_pedestrians}
    assert peds["p1"].goal == (24.0, 12.0)  # the circle's centre, found by its inkscape:label
    assert peds["p2"].goal == (15.0, 10.0)  # by its id; p2 is a new pedestrian (the map has no p2 marker)
    assert m.scenarios[0].map.poi("exit_checkpoint") == m.scenarios[0].map.pois["poi_exit"]
    sim = Simulator()
    sim.reset(m.scenarios[0], 0)
    for _ in range(250):
        sim.step((0.0, 0.0))
    assert np.linalg.norm(sim.crowd.pos[1] - (15.0, 10.0)) < 0.5  # p2 walked to the POI


def test_trajectory_poi_lists_points_of_interest(tmp_path: Path) -> None:
    m = load_matrix(
        _matrix(tmp_path, [{"id": "p1", "goal": None, "trajectory_poi": ["poi_mid", "exit_checkpoint"]}])
    )
    assert m.scenarios[0].map.single_pedestrians[0].trajectory == ((15.0, 10.0), (24.0, 12.0))


def test_unknown_poi_is_one_error_naming_file_scenario_and_item(tmp_path: Path) -> None:
    path = _matrix(tmp_path, [{"id": "p1", "goal_poi": "nowhere"}])
    with pytest.raises(ConfigError) as info:
        load_matrix(path)
    assert info.value.source == str(path.resolve())
    assert info.value.item == "s.single_pedestrians[p1]"
    assert (
        "goal_poi: the map has no point of interest 'nowhere' (has: exit_checkpoint, poi_exit, poi_mid)"
        in str(info.value)
    )


@pytest.mark.parametrize(
    ("ped", "message"),
    [
        (
            {"id": "p1", "role": "join", "role_target_id": "ghost"},
            "role_target_id 'ghost': no other single pedestrian",
        ),
        (
            {"id": "p1", "role": "lead", "role_target_id": "robot:1"},
            "role_target_id 'robot:1': the only robot is",
        ),
        (
            {"id": "p1", "role": "wait", "role_target_id": "robot"},
            "role_target_id 'robot' is not used by role 'wait'",
        ),
        ({"id": "p1", "role": "dance"}, "role: Input should be"),
        (
            {"id": "ghost", "goal": [3, 3]},
            "the map has no single pedestrian 'ghost' (has: p1); a new one needs a start",
        ),
        (
            {
                "id": "p1",
                "goal": None,
                "trajectory": [[5, 10], [9, 10]],
                "hold_until_robot_within_m": 2.0,
                "hold_ref_point": [7, 7],
            },
            "hold_ref_point [7.0, 7.0] is not a waypoint of the trajectory",
        ),
        ({"id": "p1", "hold_until_robot_within_m": 2.0}, "hold_until_robot_within_m needs hold_ref_point"),
    ],
)
def test_bad_single_pedestrian_entries_fail_at_load(tmp_path: Path, ped: dict, message: str) -> None:
    path = _matrix(tmp_path, [ped])
    with pytest.raises(ConfigError) as info:
        load_matrix(path)
    assert info.value.item.startswith("s")
    assert message in str(info.value)
    assert str(path.resolve()) in str(info.value)


def test_hold_ref_point_defaults_to_the_event_contract_conflict_point(tmp_path: Path) -> None:
    meta = {"public_requirement": {"event_contract": {"conflict_point": [9, 10]}}}
    ped = {"id": "p1", "goal": None, "trajectory": [[5, 10], [9, 10]], "hold_until_robot_within_m": 2.0}
    m = load_matrix(_matrix(tmp_path, [ped], metadata=meta))
    assert m.scenarios[0].map.single_pedestrians[0].hold_ref_point == (9.0, 10.0)


def test_metadata_merges_and_roles_round_trip_the_native_format(tmp_path: Path) -> None:
    import yaml

    from foresight.core.maps.native import dump_map, map_from_dict

    m = load_matrix(
        _matrix(
            tmp_path,
            [
                {
                    "id": "p1",
                    "role": "accompany",
                    "role_offset": [0, 2],
                    "metadata": {"intent_label": "escort"},
                }
            ],
        )
    )
    mapdef = m.scenarios[0].map
    assert mapdef.single_pedestrians[0].metadata == {"intent_label": "escort"}
    again = map_from_dict(yaml.safe_load(dump_map(mapdef)), source="x")
    assert again.single_pedestrians == mapdef.single_pedestrians
    assert again.poi_labels == {"poi_exit": "exit_checkpoint"}
