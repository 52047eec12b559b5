"""Our YAML map format ``foresight.map/1``: reading, writing, round trip and bad input."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from foresight.core.errors import ConfigError
from foresight.core.maps.model import MapDef, Route, SinglePedestrian, WaitRule, Zone
from foresight.core.maps.native import dump_map, load_native_map, map_from_dict
from foresight.core.maps.svg import load_svg_map

EXAMPLE = """\
format: foresight.map/1
name: crossing
width: 40
height: 30
obstacles:
  - rect: [0, 0, 14, 10]
  - polygon: [[26, 0], [40, 0], [40, 10]]
robot_spawn_zones: [{rect: [2, 13, 3, 4]}]
robot_goal_zones: [{rect: [35, 13, 3, 4]}]
robot_routes: [{spawn: 0, goal: 0, waypoints: [[4, 15], [36, 15]]}]
ped_spawn_zones: [{rect: [18, 1, 4, 2]}]
ped_goal_zones: [{corners: [[18, 27], [22, 27], [22, 29]]}]
ped_routes: [{spawn: 0, goal: 0, waypoints: [[20, 2], [20, 28]]}]
ped_crowded_zones: []
single_pedestrians:
  - {id: s1, start: [10, 20], goal: [30, 20], speed_m_s: 0.5}
pois: {}
"""


def write(tmp_path: Path, text: str, name: str = "m.yaml") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


def test_architecture_example_loads(tmp_path):
    m = load_native_map(write(tmp_path, EXAMPLE))
    assert (m.name, m.width, m.height) == ("crossing", 40.0, 30.0)
    assert m.obstacles[0] == ((0, 0), (14, 0), (14, 10), (0, 10))
    assert m.obstacles[1] == ((26, 0), (40, 0), (40, 10))
    assert m.robot_spawn_zones[0] == Zone.from_rect(2, 13, 3, 4)
    assert m.ped_goal_zones[0].corners == ((18, 27), (22, 27), (22, 29))
    assert m.robot_routes[0].waypoints == ((4, 15), (36, 15))
    assert m.single_pedestrians[0].goal == (30, 20)
    assert m.source == str(tmp_path / "m.yaml")


def rich_map() -> MapDef:
    return MapDef(
        name="rich",
        width=12.5,
        height=7.25,
        obstacles=(
            ((0.5, 0.25), (1.5, 0.25), (1.5, 0.75), (0.5, 0.75)),
            ((5, 5), (6, 5.5), (5.2, 6.1), (4.9, 5.4)),
            ((0.2, 0.2), (0.9, 0.2), (0.9, 0.7), (0.2, 0.7)),  # 0.2 + (0.9 - 0.2) != 0.9 in floating point
        ),
        robot_spawn_zones=(Zone.from_rect(0.3, 0.1, 0.7, 0.9),),
        robot_goal_zones=(Zone(corners=((9, 1), (10, 2), (9, 3))),),
        robot_routes=(Route(spawn_id=0, goal_id=0, waypoints=((0.5, 0.5), (9.5, 2.0))),),
        ped_spawn_zones=(Zone.from_rect(1, 1, 1, 1), Zone.from_rect(3, 3, 1, 1)),
        ped_goal_zones=(Zone.from_rect(8, 6, 1, 1),),
        ped_routes=(Route(spawn_id=1, goal_id=0, waypoints=((3.5, 3.5), (6, 6), (8.5, 6.5))),),
        ped_crowded_zones=(Zone.from_rect(4, 0, 2, 2),),
        single_pedestrians=(
            SinglePedestrian(id="a", start=(1, 6), goal=(11, 6), speed_m_s=0.8, note="cuts across"),
            SinglePedestrian(
                id="b",
                start=(2, 2),
                trajectory=((3, 3), (4, 2)),
                start_delay_s=1.5,
                wait_at=(WaitRule(waypoint_index=1, wait_s=2.0, note="waits"),),
            ),
        ),
        pois={"door": (6.0, 0.0)},
    )


def test_round_trip_of_every_field():
    m = rich_map()
    back = map_from_dict(yaml.safe_load(dump_map(m)), source="x.yaml")
    assert back.model_copy(update={"source": None}) == m


def test_dump_uses_rect_shorthand_only_when_exact():
    doc = yaml.safe_load(dump_map(rich_map()))
    assert doc["obstacles"][0] == {"rect": [0.5, 0.25, 1.0, 0.5]}
    assert "polygon" in doc["obstacles"][1] and "polygon" in doc["obstacles"][2]
    assert "corners" in doc["robot_goal_zones"][0]
    assert doc["ped_spawn_zones"][0] == {"rect": [1.0, 1.0, 1.0, 1.0]}


def test_round_trip_of_imported_reference_maps(reference_dir, tmp_path):
    for svg in sorted((reference_dir / "maps" / "svg_maps").glob("*.svg")):
        m = load_svg_map(svg)
        back = load_native_map(write(tmp_path, dump_map(m), f"{svg.stem}.yaml"))
        assert back.model_copy(update={"source": m.source}) == m, svg.name


def test_name_defaults_to_file_stem(tmp_path):
    text = EXAMPLE.replace("name: crossing\n", "")
    assert load_native_map(write(tmp_path, text, "plaza.yaml")).name == "plaza"


@pytest.mark.parametrize(
    ("old", "new", "item", "pattern"),
    [
        ("format: foresight.map/1", "format: other/2", "format", "expected format"),
        ("height: 30", "height: 30\ncolour: red", "document", r"unknown key\(s\) \['colour'\]"),
        ("height: 30", "height: -1", "height", "positive"),
        ("width: 40\n", "", "width", "missing"),
        ("{rect: [2, 13, 3, 4]}", "{rect: [2, 13, 3]}", "robot_spawn_zones[0].rect", r"\[x, y, w, h\]"),
        (
            "{rect: [2, 13, 3, 4]}",
            "{rect: [2, 13, 3, 4], corners: []}",
            "robot_spawn_zones[0]",
            "exactly one",
        ),
        ("{rect: [2, 13, 3, 4]}", "{circle: 3}", "robot_spawn_zones[0]", "unknown key"),
        ("[[26, 0], [40, 0], [40, 10]]", "[[26, 0], [40, 0]]", "obstacles[1].polygon", "at least 3"),
        ("[[26, 0], [40, 0], [40, 10]]", "[[26, 0], [40, 0], [26, 0]]", "obstacles[1].polygon", "distinct"),
        (
            "[[26, 0], [40, 0], [40, 10]]",
            "[[26, 0], [40, yes], [40, 10]]",
            "obstacles[1].polygon[1]",
            "number",
        ),
        (
            "ped_routes: [{spawn: 0, goal: 0,",
            "ped_routes: [{spawn: 0, goal: 3,",
            "ped_routes[0].goal",
            "out of range",
        ),
        (
            "ped_routes: [{spawn: 0, goal: 0,",
            "ped_routes: [{spawn: 0, goal: 0, speed: 1,",
            "ped_routes[0]",
            "unknown key",
        ),
        ("waypoints: [[20, 2], [20, 28]]", "waypoints: [[20, 2]]", "ped_routes[0].waypoints", "at least 2"),
        ("speed_m_s: 0.5}", "speed_m_s: -1}", "single_pedestrians[0].speed_m_s", "greater than or equal"),
        ("speed_m_s: 0.5}", "speed_m_s: 0.5, mood: happy}", "single_pedestrians[0]", "unknown key"),
        ("pois: {}", "pois: {door: [1]}", "pois.door", r"point \[x, y\]"),
        ("robot_routes: [", "robot_routes: 7\nx: [", "document", "unknown key"),
    ],
)
def test_bad_input_names_file_and_item(tmp_path, old, new, item, pattern):
    assert old in EXAMPLE
    p = write(tmp_path, EXAMPLE.replace(old, new, 1))
    with pytest.raises(ConfigError, match=pattern) as info:
        load_native_map(p)
    assert info.value.source == str(p)
    assert info.value.item == item


def test_duplicate_single_pedestrian_ids(tmp_path):
    text = EXAMPLE + "  - {id: s1, start: [1, 1]}\n"
    text = text.replace("pois: {}\n", "") + "pois: {}\n"
    with pytest.raises(ConfigError, match="duplicate single pedestrian ids"):
        load_native_map(write(tmp_path, text))


def test_missing_file_and_malformed_yaml(tmp_path):
    with pytest.raises(ConfigError, match="gone.yaml.*not found"):
        load_native_map(tmp_path / "gone.yaml")
    with pytest.raises(ConfigError, match="malformed YAML") as info:
        load_native_map(write(tmp_path, "format: [unclosed"))
    assert info.value.item == "yaml"
