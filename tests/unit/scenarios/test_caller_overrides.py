"""A caller's overrides (``load_matrix(..., overrides=)``, ``foresight evaluate --override``) apply last."""

from __future__ import annotations

from pathlib import Path

import pytest

from foresight.core.errors import ConfigError
from foresight.core.scenarios.loader import load_matrix

from .matrices import scenario, tiny_map, write


def test_caller_overrides_win_over_the_matrix_own(tmp_path: Path) -> None:
    write(tmp_path / "tiny.yaml", tiny_map())
    path = write(
        tmp_path / "m.yaml",
        {
            "scenario_overrides": {"simulation_config": {"ped_speed_tier": "slow", "ped_density": 0.03}},
            "scenarios": [scenario("a"), scenario("b", simulation_config={"nonreactive_fraction": 0.5})],
        },
    )
    m = load_matrix(path, overrides={"simulation_config": {"ped_speed_tier": "realistic"}})
    for s in m.scenarios:
        cfg = s.scenario.simulation_config
        assert cfg.ped_speed_tier == "realistic" and cfg.ped_density == 0.03  # deep merge keeps the rest
    assert m.get("b").scenario.simulation_config.nonreactive_fraction == 0.5
    assert load_matrix(path).get("a").scenario.simulation_config.ped_speed_tier == "slow"
    with pytest.raises(ConfigError, match="may not rename"):
        load_matrix(path, overrides={"name": "c"})
