"""The result recorders are keyed by job kind: every key names a kind of the one table (a typo would drop rows)."""

from __future__ import annotations

from foresight.core.stages.kinds import KINDS
from foresight.store.records import RECORDERS


def test_every_recorder_is_for_a_known_kind() -> None:
    assert set(RECORDERS) <= set(KINDS)
    assert {"collect", "mix", "import_dataset", "evaluate", "campaign", "pipeline"} <= set(RECORDERS)


def test_every_kind_has_a_spec_with_its_name_and_a_run_function() -> None:
    for name, kind in KINDS.items():
        assert kind.name == name and callable(kind.run)
        assert kind.spec.model_fields["kind"].default == name
        assert set(kind.config.model_fields) | {"kind"} == set(kind.spec.model_fields)


def test_the_kinds_result_models_are_the_stage_results() -> None:
    from foresight.core.stages.results import RESULTS

    assert {name: KINDS[name].result for name in RESULTS} == RESULTS
