"""Matrix loader rules: includes, map lookup, registry, selection, overrides, and one clear error per bad input."""

from __future__ import annotations

from pathlib import Path

import pytest

from foresight.core.errors import ConfigError
from foresight.core.scenarios.loader import load_matrix, matrix_from_data

from .matrices import registry, scenario, tiny_map, write


@pytest.fixture
def root(tmp_path: Path) -> Path:
    write(tmp_path / "tiny.yaml", tiny_map())
    return tmp_path


def _raises(path: Path, **kw) -> ConfigError:
    with pytest.raises(ConfigError) as info:
        load_matrix(path, **kw)
    return info.value


def test_includes_come_first_recursively_with_all_aliases(root: Path) -> None:
    write(root / "a.yaml", [scenario("a1"), scenario("a2")])  # a bare list
    write(root / "sub" / "b.yaml", {"include": ["c.yaml"], "scenarios": [scenario("b1")]})
    write(root / "sub" / "c.yaml", {"scenarios": [scenario("c1")]})
    write(root / "sub" / "d.yaml", {"scenario_files": [], "scenarios": [scenario("d1")]})
    path = write(
        root / "m.yaml", {"includes": ["a.yaml", "sub/b.yaml", "sub/d.yaml"], "scenarios": [scenario("r1")]}
    )
    m = load_matrix(path)
    assert m.names == ["a1", "a2", "c1", "b1", "d1", "r1"]
    assert m.source == str(path.resolve())
    assert m.get("c1").map.name == "tiny"


def test_map_file_lookup_order_root_then_declaring_file_then_search_paths(root: Path) -> None:
    write(root / "sub" / "tiny.yaml", tiny_map("sub_tiny"))
    write(root / "sub" / "only_sub.yaml", tiny_map("only_sub"))
    write(root / "maps" / "searched.yaml", tiny_map("searched"))
    write(
        root / "sub" / "s.yaml",
        [
            scenario("from_root"),
            scenario("from_declaring", map_file="only_sub.yaml"),
            scenario("from_search_path", map_file="searched.yaml"),
        ],
    )
    path = write(root / "m.yaml", {"includes": ["sub/s.yaml"], "map_search_paths": ["maps"]})
    m = load_matrix(path)
    assert [m.get(n).map.name for n in m.names] == ["tiny", "only_sub", "searched"]


def test_map_search_paths_of_an_included_file_are_relative_to_it(root: Path) -> None:
    write(root / "sub" / "maps" / "deep.yaml", tiny_map("deep"))
    write(
        root / "sub" / "s.yaml",
        {"map_search_paths": ["maps"], "scenarios": [scenario("x", map_file="deep.yaml")]},
    )
    m = load_matrix(write(root / "m.yaml", {"includes": ["sub/s.yaml"]}))
    assert m.get("x").map.name == "deep"


def test_map_id_through_registry_argument_key_or_discovery(root: Path) -> None:
    maps = root / "maps" / "files"
    write(maps / "t.yaml", tiny_map("file_name"))
    reg = registry(root / "maps" / "registry.yaml", {"my_map": maps / "t.yaml"})
    sc = [scenario("x", map_id="my_map", map_file="does_not_exist.yaml")]  # map_id wins
    by_arg = load_matrix(write(root / "a.yaml", {"scenarios": sc}), map_registry=reg)
    by_key = load_matrix(write(root / "b.yaml", {"map_registry": "maps/registry.yaml", "scenarios": sc}))
    found = load_matrix(write(root / "c.yaml", {"map_search_paths": ["maps/files"], "scenarios": sc}))
    for m in (by_arg, by_key, found):
        s = m.get("x")
        assert s.map.name == "my_map"  # a map loaded by id is named by its id, as in the reference
        assert Path(s.map.source or "").name == "t.yaml"


def test_select_and_overrides(root: Path) -> None:
    path = write(
        root / "m.yaml",
        {
            "select_scenarios": ["C", "a"],
            "scenario_overrides": {
                "simulation_config": {"max_episode_steps": 123},
                "metadata": {"suite": "t"},
            },
            "scenario_overrides_by_name": {"A": {"seeds": [7, 8], "simulation_config": {"ped_density": 0.1}}},
            "seeds": [5],
            "metadata": {"owner": "tests"},
            "scenarios": [
                scenario("a", metadata={"archetype": "x"}),
                scenario("b"),
                scenario("c", seeds=[1, 2, 3]),
            ],
        },
    )
    m = load_matrix(path)
    assert m.names == ["c", "a"]
    a, c = m.get("a").scenario, m.get("c").scenario
    assert a.seeds == (7, 8) and c.seeds == (1, 2, 3)
    assert a.simulation_config.ped_density == 0.1 and c.simulation_config.ped_density == 0.02
    assert a.simulation_config.max_episode_steps == c.simulation_config.max_episode_steps == 123
    assert a.metadata == {"archetype": "x", "suite": "t"}  # deep-merged, not replaced
    assert m.metadata == {"owner": "tests"}
    defaulted = load_matrix(write(root / "n.yaml", {"seeds": [5, 6], "scenarios": [scenario("b")]}))
    assert defaulted.get("b").scenario.seeds == (5, 6)


def test_single_pedestrian_overrides_by_id(root: Path) -> None:
    sp = [
        {
            "id": "s1",
            "goal": None,
            "trajectory": [[6, 2], [12, 2]],
            "wait_at": [{"waypoint_index": 1, "wait_s": 2.0}],
        }
    ]
    m = load_matrix(write(root / "m.yaml", [scenario("x", single_pedestrians=sp)]))
    p = m.get("x").map.single_pedestrian("s1")
    assert p.goal is None and p.trajectory == ((6.0, 2.0), (12.0, 2.0)) and p.wait_at[0].wait_s == 2.0
    assert p.start == (5.0, 2.0) and p.speed_m_s == 0.5  # untouched fields keep the map's values


def test_inline_manifest_resolves_against_its_notional_path(root: Path) -> None:
    m = matrix_from_data({"scenarios": [scenario("x")]}, source=root / "inline.yaml")
    assert m.names == ["x"]


def test_file_notes_are_kept(root: Path) -> None:
    m = load_matrix(write(root / "m.yaml", {"evaluation": "excluded", "scenarios": [scenario("x")]}))
    assert list(m.metadata["file_notes"].values()) == [{"evaluation": "excluded"}]


# ---- bad input: one ConfigError naming the file and the item -----------------------------------


def test_missing_map_file(root: Path) -> None:
    err = _raises(write(root / "m.yaml", [scenario("x", map_file="nope.yaml")]))
    assert (Path(err.source).name, err.item) == ("m.yaml", "x")
    assert "nope.yaml" in str(err)


def test_unknown_route_zone_index_in_a_map(root: Path) -> None:
    write(root / "bad_map.yaml", tiny_map(route_spawn=3))
    err = _raises(write(root / "m.yaml", [scenario("x", map_file="bad_map.yaml")]))
    assert Path(err.source).name == "bad_map.yaml"
    assert err.item == "ped_routes[0].spawn"


def test_unknown_single_pedestrian_id(root: Path) -> None:
    err = _raises(
        write(root / "m.yaml", [scenario("x", single_pedestrians=[{"id": "ghost", "speed_m_s": 1.0}])])
    )
    assert (Path(err.source).name, err.item) == ("m.yaml", "x.single_pedestrians[ghost]")
    assert "s1" in str(err)  # lists the ids the map has


def test_malformed_yaml_in_an_included_file(root: Path) -> None:
    write(root / "broken.yaml", "scenarios: [\n  - name: x\n    map_file: [unclosed\n")
    err = _raises(write(root / "m.yaml", {"includes": ["broken.yaml"]}))
    assert Path(err.source).name == "broken.yaml"
    assert err.item == "broken.yaml" and "malformed YAML at line" in str(err)


def test_missing_included_file(root: Path) -> None:
    err = _raises(write(root / "m.yaml", {"includes": ["gone.yaml"]}))
    assert (Path(err.source).name, err.item) == ("m.yaml", "gone.yaml")


def test_include_cycle_is_named(root: Path) -> None:
    write(root / "a.yaml", {"includes": ["b.yaml"]})
    write(root / "b.yaml", {"includes": ["a.yaml"], "scenarios": [scenario("b1")]})
    err = _raises(write(root / "m.yaml", {"includes": ["a.yaml"]}))
    assert (Path(err.source).name, err.item) == ("b.yaml", "a.yaml")
    assert "include cycle: a.yaml -> b.yaml -> a.yaml" in str(err)


def test_negative_density(root: Path) -> None:
    err = _raises(write(root / "m.yaml", [scenario("x", simulation_config={"ped_density": -0.1})]))
    assert (Path(err.source).name, err.item) == ("m.yaml", "x")
    assert "simulation_config.ped_density" in err.detail


def test_checksum_mismatch_in_the_registry(root: Path) -> None:
    reg = registry(root / "registry.yaml", {"tiny_id": root / "tiny.yaml"}, sha={"tiny_id": "0" * 64})
    err = _raises(write(root / "m.yaml", [{"name": "x", "map_id": "tiny_id"}]), map_registry=reg)
    assert (Path(err.source).name, err.item) == ("registry.yaml", "tiny_id")
    assert "checksum" in str(err)


def test_unknown_map_id(root: Path) -> None:
    reg = registry(root / "registry.yaml", {"tiny_id": root / "tiny.yaml"})
    err = _raises(write(root / "m.yaml", [{"name": "x", "map_id": "other"}]), map_registry=reg)
    assert (Path(err.source).name, err.item) == ("m.yaml", "x")


def test_map_id_without_any_registry(root: Path) -> None:
    err = _raises(write(root / "m.yaml", [{"name": "x", "map_id": "tiny_id"}]))
    assert (Path(err.source).name, err.item) == ("m.yaml", "x") and "registry" in str(err)


@pytest.mark.parametrize(
    "entry, key",
    [
        ({"groupz": 1}, "groupz"),
        ({"simulation_config": {"ped_density": 0.02, "walkers": 3}}, "simulation_config.walkers"),
        ({"robot_config": {"wheels": 4}}, "robot_config.wheels"),
    ],
)
def test_unknown_scenario_key(root: Path, entry: dict, key: str) -> None:
    err = _raises(write(root / "m.yaml", [{**scenario("x"), **entry}]))
    assert (Path(err.source).name, err.item) == ("m.yaml", "x")
    assert f"{key}: unsupported key" in err.detail


def test_unknown_manifest_key(root: Path) -> None:
    err = _raises(write(root / "m.yaml", {"scenarios": [scenario("x")], "scenario_override": {}}))
    assert (Path(err.source).name, err.item) == ("m.yaml", "scenario_override")


def test_root_only_key_in_an_included_file(root: Path) -> None:
    write(root / "a.yaml", {"select_scenarios": ["x"], "scenarios": [scenario("x")]})
    err = _raises(write(root / "m.yaml", {"includes": ["a.yaml"]}))
    assert (Path(err.source).name, err.item) == ("a.yaml", "select_scenarios")


def test_duplicate_scenario_names(root: Path) -> None:
    write(root / "a.yaml", [scenario("Same")])
    err = _raises(write(root / "m.yaml", {"includes": ["a.yaml"], "scenarios": [scenario("same")]}))
    assert (Path(err.source).name, err.item) == ("m.yaml", "same")
    assert "a.yaml" in str(err)


def test_select_unknown_scenario(root: Path) -> None:
    err = _raises(write(root / "m.yaml", {"select_scenarios": ["nope"], "scenarios": [scenario("x")]}))
    assert (Path(err.source).name, err.item) == ("m.yaml", "nope")


def test_scenario_without_map(root: Path) -> None:
    err = _raises(write(root / "m.yaml", [{"name": "x"}]))
    assert err.item == "x" and "map_file or map_id" in err.detail


def test_empty_file(root: Path) -> None:
    err = _raises(write(root / "m.yaml", ""))
    assert Path(err.source).name == "m.yaml"
