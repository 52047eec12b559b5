"""Nesting and alias-expansion bounds on YAML, JSON-like values and SVG."""

from __future__ import annotations

import time
from pathlib import Path

import pytest
import yaml

from foresight.core.errors import ConfigError
from foresight.core.limits import MAX_NESTING, check_nesting, nesting_depth
from foresight.core.maps.svg import parse_svg_text
from foresight.core.scenarios.loader import load_matrix
from foresight.core.yamlio import load_yaml

REPO = Path(__file__).resolve().parents[3]


def alias_bomb(levels: int) -> str:
    """The probe's bomb: each level a list of nine aliases to the previous one (9**levels strings)."""
    lines = ['a0: &a0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    lines += [f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 9)}]" for i in range(1, levels + 1)]
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("levels", [7, 10])
def test_a_yaml_alias_bomb_is_refused_at_once(levels: int) -> None:
    t0 = time.process_time()
    with pytest.raises(ConfigError, match="aliases expand the document beyond") as err:
        load_yaml(alias_bomb(levels), "bomb.yaml")
    assert time.process_time() - t0 < 1.0  # 52 s of server CPU at 7 levels before
    assert err.value.source == "bomb.yaml" and err.value.item.startswith("line ")


def test_aliases_below_the_bound_still_work() -> None:
    assert load_yaml(alias_bomb(2))["a2"] == [[["lol"] * 9] * 9] * 9


def test_a_yaml_nested_20000_deep_is_refused_naming_the_line() -> None:
    with pytest.raises(ConfigError, match=f"nested deeper than {MAX_NESTING} levels") as err:
        load_yaml("a:\n  b: " + "[" * 20_000 + "]" * 20_000, "deep.yaml")
    assert err.value.item == "line 2"
    with pytest.raises(ConfigError, match="nested deeper"):
        load_yaml("".join(" " * i + f"k{i}:\n" for i in range(MAX_NESTING + 5)) + " " * 80 + "x: 1\n")


def test_a_recursive_alias_is_refused() -> None:
    with pytest.raises(ConfigError, match="recursive alias"):
        load_yaml("a: &a [1, *a]\n")


def test_load_yaml_reads_what_safe_load_reads() -> None:
    files = sorted((REPO / "configs").rglob("*.yaml"))
    assert len(files) > 20
    for f in files:
        assert load_yaml(f.read_text(), f) == yaml.safe_load(f.read_text()), f
    with pytest.raises(yaml.YAMLError):
        load_yaml("a: [\n")


def test_a_matrix_with_an_alias_bomb_is_a_config_error_naming_the_file(tmp_path: Path) -> None:
    path = tmp_path / "m.yaml"
    path.write_text(alias_bomb(8) + "scenarios: []\n")
    with pytest.raises(ConfigError, match="aliases expand") as err:
        load_matrix(path)
    assert err.value.source == str(path)


def test_json_nesting_depth_is_measured_without_recursion() -> None:
    value: object = 1
    for _ in range(100_000):
        value = {"k": [value]}
    assert nesting_depth(value) > MAX_NESTING
    with pytest.raises(ConfigError, match="nested deeper") as err:
        check_nesting(value, source="body", item="spec.planner")
    assert err.value.item == "spec.planner"
    assert nesting_depth({"a": [1, {"b": 2}]}) == 3 and nesting_depth(5) == 0
    check_nesting({"a": {"b": {"c": [1]}}})


def test_an_svg_with_100000_nested_groups_is_refused() -> None:
    text = (
        '<svg xmlns="http://www.w3.org/2000/svg" width="10" height="10">'
        + "<g>" * 100_000
        + "</g>" * 100_000
        + "</svg>"
    )
    with pytest.raises(ConfigError, match="elements nested deeper than") as err:
        parse_svg_text(text, name="deep", source="deep.svg")
    assert err.value.source == "deep.svg" and err.value.item == "<g>"
    for bad in ("", "<svg", "not xml"):
        with pytest.raises(ConfigError, match="malformed XML"):
            parse_svg_text(bad, name="bad", source="bad.svg")


def test_a_flat_yaml_of_a_million_keys_is_refused_at_once_with_little_memory() -> None:
    """The probe's 10.9 MB file took 84 s of CPU and 1.5 GB before its node count was checked."""
    import tracemalloc

    from foresight.core.limits import MAX_YAML_BYTES, MAX_YAML_NODES

    text = "".join(f"k{i}: {i}\n" for i in range(1_000_000))
    dense = text[: MAX_YAML_BYTES - 100]  # under the size bound: the node count stops it
    for doc, words in ((text, "over"), (dense, f"more than {MAX_YAML_NODES} nodes")):
        t0 = time.process_time()
        with pytest.raises(ConfigError, match=words):
            load_yaml(doc, "flat.yaml")
        cpu = time.process_time() - t0
        tracemalloc.start()  # a second pass: tracing slows every allocation
        with pytest.raises(ConfigError, match=words):
            load_yaml(doc, "flat.yaml")
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        assert cpu < 2.0 and peak < 100 << 20, (words, cpu, peak)


def test_one_huge_yaml_string_is_refused_unread() -> None:
    t0 = time.process_time()
    with pytest.raises(ConfigError, match="over"):
        load_yaml('a: "' + "x" * 49_000_000 + '"\n', "string.yaml")
    assert time.process_time() - t0 < 0.5  # 65 s to scan before
