"""core.evaluation.witness_cost: the predictive planner rides along a witness's run and prices its course, on the
reference's doorway at typical walking speed (``doorway_medium`` 147: the planner times out, a witness that waits
back and keeps 0.3 m from every walker arrives)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from foresight.core.errors import ConfigError
from foresight.core.evaluation.plannerspec import resolve_planner
from foresight.core.evaluation.witness import WitnessSettings, search, witness_run
from foresight.core.evaluation.witness_cost import WitnessCost, price_witness
from foresight.core.planners.scripted import ScriptedConfig
from foresight.core.runtime.context import StageContext
from foresight.core.scenarios.loader import load_matrix

REPO = Path(__file__).resolve().parents[3]
TYPICAL = {"simulation_config": {"ped_speed_tier": "typical"}}


def _planner(name: str = "predictive"):
    spec = {"name": name, "model": "default"} if name == "predictive" else {"name": name}
    ctx = StageContext(
        workdir=Path("."), resolve_model=lambda ident: REPO / "model" / "predictor-sim-default.pt"
    )
    return resolve_planner(spec, ctx)


def test_the_planner_rides_along_and_says_where_it_would_have_left_the_course(
    reference_matrix_path: Path,
) -> None:
    scenario = load_matrix(reference_matrix_path, overrides=TYPICAL).get("classic_doorway_medium")
    witness = search(scenario, 147, WitnessSettings(max_plans=50, min_clearance=0.3))
    assert witness.found and witness.plan.release_s > 0
    priced = price_witness(scenario, 147, witness.plan, _planner())
    run = witness_run(scenario, 147, witness.plan)
    # one decision every 0.5 s, where the witness itself was then (replayed command for command, independently run)
    assert len(priced.decisions) == math.ceil(run.trace.steps / 5)
    for i, d in enumerate(priced.decisions):
        assert d.time_s == pytest.approx(0.5 * i)
        assert d.position == pytest.approx(tuple(run.trace.robot[5 * i, :2]), abs=0.006)
    waits = [d for d in priced.decisions if d.waiting]
    assert waits and all(d.speed == 0 and d.time_s < witness.plan.release_s for d in waits)
    # the planner would rather creep on than wait back, and rather not drive the witness's line through the door
    assert any(d.rejected and "progress" in d.dearer for d in waits)
    drives = [d for d in priced.decisions if not d.waiting and d.rejected]
    assert drives and all(v > 0 for d in drives for v in d.dearer.values())
    assert {"collision", "static_collision"} & set(priced.dearer(waiting=False))
    line = priced.summary()
    assert line.startswith("the planner's own cost would have left the witness's course while it waits, at ")
    assert "; while it drives, at " in line
    assert WitnessCost.model_validate(priced.model_dump(mode="json")) == priced  # typed end to end (--json)


def test_only_a_planner_that_prices_a_course_can_ride_along(reference_matrix_path: Path) -> None:
    scenario = load_matrix(reference_matrix_path).get("classic_doorway_low")
    with pytest.raises(ConfigError, match="the predictive planner"):
        price_witness(scenario, 141, ScriptedConfig(), _planner("goal"))
