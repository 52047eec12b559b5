"""Seed manifests: file and inline forms, validation against a matrix, episode pairs."""

from __future__ import annotations

from pathlib import Path

import pytest

from foresight.core.errors import ConfigError
from foresight.core.scenarios.loader import load_matrix
from foresight.core.scenarios.model import ScenarioMatrix
from foresight.core.scenarios.seeds import SeedManifest, load_seed_manifest

from .matrices import scenario, tiny_map, write


@pytest.fixture
def matrix(tmp_path: Path) -> ScenarioMatrix:
    write(tmp_path / "tiny.yaml", tiny_map())
    return load_matrix(write(tmp_path / "m.yaml", [scenario("Alpha"), scenario("beta")]))


def test_file_manifest_pairs_in_order(tmp_path: Path, matrix: ScenarioMatrix) -> None:
    path = write(tmp_path / "seeds.yaml", "beta: [3, 1]\nalpha: [7]\n")
    m = load_seed_manifest(path, matrix)
    assert list(m.pairs()) == [("beta", 3), ("beta", 1), ("Alpha", 7)]  # names take the matrix's spelling
    assert len(m) == 3 and m.scenario_names == ["beta", "Alpha"]
    assert m.source == str(path)


def test_wrapped_form_and_inline_dict() -> None:
    wrapped = SeedManifest.from_data({"description": "hard cases", "seeds": {"a": [1, 2]}})
    assert wrapped.description == "hard cases" and list(wrapped.pairs()) == [("a", 1), ("a", 2)]
    inline = SeedManifest.model_validate({"a": [1, 2]})  # what an API body holds
    assert inline.seeds == wrapped.seeds


def test_unknown_scenario_names_file_and_scenario(tmp_path: Path, matrix: ScenarioMatrix) -> None:
    path = write(tmp_path / "seeds.yaml", {"beta": [1], "gamma": [2]})
    with pytest.raises(ConfigError) as info:
        load_seed_manifest(path, matrix)
    assert (Path(info.value.source).name, info.value.item) == ("seeds.yaml", "gamma")


@pytest.mark.parametrize(
    "data, item",
    [
        ({"a": []}, "a"),
        ({"a": [1, 1]}, "a"),
        ({"a": [-1]}, "a"),
        ({"a": [1.5]}, "a"),
        ({"a": [True]}, "a"),
    ],
)
def test_bad_seed_lists(tmp_path: Path, data: dict, item: str) -> None:
    with pytest.raises(ConfigError) as info:
        load_seed_manifest(write(tmp_path / "s.yaml", data))
    assert Path(info.value.source).name == "s.yaml"
    assert info.value.item == item


def test_not_a_mapping(tmp_path: Path) -> None:
    with pytest.raises(ConfigError):
        load_seed_manifest(write(tmp_path / "s.yaml", "[1, 2]\n"))
