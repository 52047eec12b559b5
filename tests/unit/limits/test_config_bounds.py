"""Every stage config obeys the size and range limits of core.bounds, nested and free-form values included."""

from __future__ import annotations

import pytest
from pydantic import ValidationError

from foresight.core.bounds import MAX_ITEMS, BoundedConfig
from foresight.core.evaluation.config import EvaluationConfig
from foresight.core.evaluation.plannerspec import PlannerSpecBase
from foresight.core.jobs.kinds import KINDS


def test_every_job_kind_and_planner_spec_is_bounded() -> None:
    assert [k.name for k in KINDS.values() if not issubclass(k.config, BoundedConfig)] == []
    assert issubclass(PlannerSpecBase, BoundedConfig)


@pytest.mark.parametrize(
    ("data", "says"),
    [
        (
            {
                "planner": {
                    "name": "predictive",
                    "config": {"sampling": {"turn_rates": [0.1] * (MAX_ITEMS + 1)}},
                }
            },
            "sampling.turn_rates: 257 entries",
        ),
        ({"planner": {"name": "orca", "config": {"time_horizon": 1e12}}}, r"time_horizon: 1e\+12 is beyond"),
        ({"planner": {"name": "goal", "config": {"speed": float("nan")}}}, "finite number"),
        ({"scenario_overrides": {"metadata": {"a": [[[[[[[[[[[[[[1]]]]]]]]]]]]]]}}}, "nested more than"),
        ({"scenario_overrides": {"metadata": {"k": "x" * 5000}}}, "5000 characters"),
        ({"planner": {"name": "orca", "config": {"max_neighbors": 10_000}}}, "less than or equal to 256"),
    ],
)
def test_oversized_settings_are_refused_by_name(data: dict, says: str) -> None:
    with pytest.raises(ValidationError, match=says):
        EvaluationConfig.model_validate(data)


def test_a_field_that_declares_its_own_length_keeps_it() -> None:
    from foresight.core.evaluation.config import EvaluationConfig

    config = EvaluationConfig.model_validate({"scenarios": [f"s{i}" for i in range(600)]})  # its own max 1000
    assert len(config.scenarios or []) == 600
    with pytest.raises(ValidationError, match="at most 1000"):
        EvaluationConfig.model_validate({"scenarios": [f"s{i}" for i in range(1001)]})
