"""The result recorders are keyed by job kind: every key names a kind of the one table (a typo would drop rows)."""

from __future__ import annotations

from foresight.core.jobs.kinds import KINDS
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
    from foresight.core.jobs.results import RESULTS

    assert {name: KINDS[name].result for name in RESULTS} == RESULTS


def test_an_evaluation_row_is_derived_from_the_typed_result(engine) -> None:  # noqa: ANN001
    """The row's metrics, config and per-scenario table are the result model's fields, dumped once."""
    from sqlalchemy import select

    from foresight.core.evaluation.evaluation_result import EvaluationResult
    from foresight.store import queue, records
    from foresight.store.models import Evaluation, FailureTaxonomy, GateResult
    from foresight.store.session import write_tx
    from tests.unit.reports import data

    job, _ = queue.submit(engine, kind="evaluate", spec={})
    result = EvaluationResult.model_validate(data.evaluation())
    with write_tx(engine) as conn:
        records.evaluation(conn, job, result.model_dump(mode="json"), "jobs/x")
    with engine.connect() as conn:
        row = conn.execute(select(Evaluation)).mappings().one()
        labels = dict(conn.execute(select(FailureTaxonomy.category, FailureTaxonomy.count)).all())
        gate = conn.execute(select(GateResult.gate, GateResult.passed)).one()
    assert row["metrics"] == {
        "success_rate": 0.7,
        "collision_rate": 0.1,
        "episodes": 10,
        "status": "failed_gate",
        "overall": result.aggregates.overall.model_dump(mode="json"),
    }
    assert (
        row["config"] == {"stage": result.config, "planner": result.planner.config}
        and row["bundle_id"] == "builtin"
    )
    assert [g["key"] for g in row["per_scenario"]] == ["crossing_low", "head_on_corridor_high"]
    assert row["model_id"] is None  # m-7 is not in this registry: no dangling foreign key
    assert labels == result.taxonomy and tuple(gate) == ("gate", False)


def test_a_result_with_a_renamed_field_stores_no_row_and_names_the_field(engine) -> None:  # noqa: ANN001
    """A renamed result field is a validation error naming it (the job fails), never a NULL in a row."""
    import pytest
    from pydantic import ValidationError
    from sqlalchemy import func, select

    from foresight.store import queue, records
    from foresight.store.models import Evaluation
    from foresight.store.session import write_tx
    from tests.unit.reports import data

    job, _ = queue.submit(engine, kind="evaluate", spec={})
    renamed = data.evaluation()
    renamed["success"] = renamed.pop("success_rate")
    with pytest.raises(ValidationError, match="success_rate"), write_tx(engine) as conn:
        records.evaluation(conn, job, renamed, "jobs/x")
    with engine.connect() as conn:
        assert conn.execute(select(func.count()).select_from(Evaluation)).scalar() == 0
