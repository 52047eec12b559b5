"""The one planner registry: built-ins, the installed toy plugin, module:attr planners, the typed spec union."""

from __future__ import annotations

import json

import pytest
from pydantic import ValidationError

from foresight.core.errors import ConfigError, NotFoundError
from foresight.core.evaluation.config import CampaignConfig, EvaluationConfig
from foresight.core.evaluation.plannerspec import planner_spec
from foresight.core.planners.registry import entry, installed, make_planner, register


def test_installed_lists_builtins_and_the_toy_plugin_with_its_origin() -> None:
    found = installed()
    assert {"predictive", "orca", "social_force", "goal", "external", "toy"} <= set(found)
    assert found["toy"].origin == "plugin foresight-toy-planner 0.1.0"
    assert found["toy"].config_model.__name__ == "ToyConfig"
    assert found["predictive"].takes_model and not found["toy"].takes_model


def test_plugin_config_is_validated_by_its_model_naming_the_field() -> None:
    planner = make_planner("toy", {"speed": 0.7})
    assert planner.config.speed == 0.7
    with pytest.raises(ConfigError, match="toy.sped"):
        make_planner("toy", {"sped": 0.7})
    with pytest.raises(ValidationError, match=r"planner\.toy\.config\.speed"):
        EvaluationConfig.model_validate({"planner": {"name": "toy", "config": {"speed": -1}}})


def test_builtin_config_typo_names_the_field() -> None:
    with pytest.raises(ValidationError, match=r"planner\.predictive\.config\.safety\.colision_margin"):
        EvaluationConfig.model_validate({"planner": {"config": {"safety": {"colision_margin": 0.2}}}})


def test_unknown_planner_lists_the_installed_ones() -> None:
    with pytest.raises(ValidationError) as exc:
        EvaluationConfig.model_validate({"planner": {"name": "dwa"}})
    assert "unknown planner 'dwa'" in str(exc.value)
    assert "predictive, orca, social_force, goal, scripted, sb3, external" in str(exc.value) and "toy" in str(
        exc.value
    )
    with pytest.raises(NotFoundError, match="installed: .*toy"):
        entry("dwa")


def test_module_attr_planners_only_once_registered_in_this_process() -> None:
    name = "tests.unit.planners.user_planner:Cautious"
    with pytest.raises(ConfigError, match="run in-process only"):
        planner_spec(name="tests.unit.planners.user_planner:NotRegistered")
    assert register(name) == name
    spec = planner_spec(name=name, config={"speed": 0.5})
    assert spec.config == {"speed": 0.5}
    with pytest.raises(ConfigError, match="speeed"):
        planner_spec(name=name, config={"speeed": 0.5})
    assert make_planner(name, {"speed": 0.4}).speed == 0.4


def test_typed_spec_keeps_the_config_model_and_round_trips() -> None:
    spec = planner_spec(name="toy", config={"speed": 0.5})
    assert type(spec.config).__name__ == "ToyConfig"
    again = planner_spec(spec.model_dump(mode="json"))
    assert again == spec


def test_campaign_variants_of_a_plugin_are_checked_at_validation() -> None:
    base = {"seed_manifest": "seeds/x.yaml", "planner": {"name": "toy", "config": {"caution_distance": 3.0}}}
    ok = CampaignConfig.model_validate({**base, "variants": [{"name": "slow", "config": {"speed": 0.5}}]})
    assert ok.planner.name == "toy"
    with pytest.raises(ValidationError, match=r"grid variant bad.*planner\.toy\.config\.spede"):
        CampaignConfig.model_validate({**base, "variants": [{"name": "bad", "config": {"spede": 0.5}}]})


def test_cli_lists_this_installations_planners(capsys, monkeypatch: pytest.MonkeyPatch) -> None:  # noqa: ANN001
    from foresight.cli.main import main

    monkeypatch.setenv("FORESIGHT_EXTERNAL_PLANNERS", '{"ref": "python ref.py"}')
    assert main(["planners", "--local", "--json"]) == 0
    listing = json.loads(capsys.readouterr().out)
    toy = next(p for p in listing["data"] if p["name"] == "toy")
    assert toy["config_schema"]["properties"]["speed"]["default"] == 1.0
    assert listing["external_commands"] == ["ref"] and "python" not in json.dumps(listing)
    assert main(["planners", "--local"]) == 0
    assert "toy" in capsys.readouterr().out


def test_a_broken_or_foreign_plugin_is_skipped_with_a_warning(monkeypatch: pytest.MonkeyPatch) -> None:
    import importlib.metadata

    from foresight.core.planners import registry

    eps = [
        importlib.metadata.EntryPoint("broken", "no_such_module_xyz:Planner", registry.PLUGIN_GROUP),
        importlib.metadata.EntryPoint(
            "future", "tests.unit.planners.test_registry:FuturePlanner", registry.PLUGIN_GROUP
        ),
        importlib.metadata.EntryPoint(
            "goal", "tests.unit.planners.user_planner:Cautious", registry.PLUGIN_GROUP
        ),
        importlib.metadata.EntryPoint(
            "fine", "tests.unit.planners.user_planner:Cautious", registry.PLUGIN_GROUP
        ),
    ]
    monkeypatch.setattr(importlib.metadata, "entry_points", lambda group: eps)
    with pytest.warns(UserWarning) as caught:
        found = registry._plugins({"goal"})
    assert [e.name for e in found] == ["fine"]
    messages = " | ".join(str(w.message) for w in caught)
    assert "'broken'" in messages and "no_such_module_xyz" in messages
    assert "'future'" in messages and "interface version 2" in messages
    assert "'goal'" in messages and "taken" in messages


class FuturePlanner:
    """A plugin written for a planner interface this Foresight does not know."""

    planner_api = 2


def test_cli_refuses_a_module_attr_planner_for_the_server(capsys) -> None:  # noqa: ANN001
    from foresight.cli.main import main

    code = main(
        [
            "evaluate",
            "--matrix",
            "configs/scenarios/classic_interactions.yaml",
            "--planner",
            "tests.unit.planners.user_planner:Cautious",
            "--url",
            "http://127.0.0.1:9",
        ]
    )
    err = capsys.readouterr().err
    assert code == 1 and "module:attr planners run in-process only (--local)" in err
    assert len(err.strip().splitlines()) == 1
