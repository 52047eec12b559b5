"""core.evaluation.witness: the plan family built from an episode's route, and the search, on the reference's
doorways at typical walking speed (the crowd reacting to the robot, where no reachability analysis can answer)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from foresight.core.evaluation.witness import Witness, WitnessSettings, route_plans, search, witness_run
from foresight.core.scenarios.loader import load_matrix
from foresight.core.sim.geometry import points_in_polygons
from foresight.core.sim.simulator import Simulator

TYPICAL = {"simulation_config": {"ped_speed_tier": "typical"}}


@pytest.fixture(scope="module")
def matrix(reference_matrix_path: Path):
    return load_matrix(reference_matrix_path, overrides=TYPICAL)


def test_the_family_drives_the_route_then_waits_along_it_coarse_to_fine(matrix) -> None:
    scenario = matrix.get("classic_doorway_medium")
    plans = route_plans(scenario, 147)
    obs = Simulator().reset(scenario, 147)
    route = [tuple(map(float, p)) for p in obs.route[:-1]]
    assert plans[0].hold is None and list(plans[0].via) == route  # first the route as it is
    holds = plans[1:]
    assert len(holds) > 500
    # every plan keeps the route's order: the waypoints before its waiting point, then the ones after it
    assert all(list(p.via) + list(p.after) == route for p in holds)
    # release times coarse to fine: every multiple of 8 s before any multiple of 4, of 2, then the odd seconds
    levels = [
        next(i for i, every in enumerate((8, 4, 2, 1)) if round(p.release_s) % every == 0) for p in holds
    ]
    assert levels == sorted(levels) and levels[0] == 0 and levels[-1] == 3
    # waiting points stand clear of the walls and obstacles, inside the map
    points = np.array([p.hold for p in holds])
    assert not points_in_polygons(points, [np.asarray(o) for o in scenario.map.obstacles]).any()
    assert (obs.static.distance(points) >= obs.robot_radius).all()
    # no release so late that the rest of the route cannot be driven at full speed before the horizon
    assert max(p.release_s for p in holds) < scenario.scenario.simulation_config.max_episode_steps * obs.dt
    coarse = route_plans(scenario, 147, WitnessSettings(spacing=2.0, offsets=(0.0,), release_step_s=4.0))
    assert 1 < len(coarse) < len(plans) / 10


def test_a_wait_solves_the_doorway_that_driving_straight_through_loses(matrix) -> None:
    scenario = matrix.get("classic_doorway_medium")
    direct = witness_run(scenario, 147, route_plans(scenario, 147)[0])
    assert direct.record.outcome != "success"  # the route as it is: not a witness
    found = search(scenario, 147, WitnessSettings(max_plans=50))
    assert found.found and found.plan.hold is not None and found.plan.release_s > 0
    assert 1 < found.tried <= 50 and found.plans > 1000 and 0 < found.arrival_s < 50
    parallel = search(
        scenario, 147, WitnessSettings(max_plans=50), workers=2
    )  # the same answer from two processes
    assert parallel.model_copy(update={"seconds": 0}) == found.model_copy(update={"seconds": 0})
    # the witness replayed as a recorded run, independently of the search: it arrives, without contact, on time
    run = witness_run(scenario, 147, found.plan)
    assert run.record.outcome == "success" and run.record.planner == "scripted"
    assert run.record.steps * 0.1 == pytest.approx(found.arrival_s)
    assert "arrives at" in found.summary() and f"plan {found.tried} of {found.plans}" in found.summary()


def test_a_witness_reports_how_close_it_passes_and_a_margin_asks_for_room(matrix) -> None:
    scenario = matrix.get("classic_doorway_medium")
    tight = search(scenario, 147, WitnessSettings(max_plans=50))
    # the first witness slips past a walker: its closest approach, as the replayed run records it independently
    run = witness_run(scenario, 147, tight.plan)
    assert tight.clearance_m == pytest.approx(run.record.safety.min_clearance, abs=1e-3)
    assert (
        0 <= tight.clearance_m < 0.1
        and f"{tight.clearance_m:.2f} m from the closest pedestrian" in tight.summary()
    )
    assert tight.wall_clearance_m is not None and 0 <= tight.wall_clearance_m < 1
    roomy = search(scenario, 147, WitnessSettings(max_plans=50, min_clearance=0.3))
    assert roomy.found and roomy.plan != tight.plan and roomy.tried > tight.tried
    replay = witness_run(scenario, 147, roomy.plan)
    assert replay.record.outcome == "success" and replay.record.safety.min_clearance >= 0.3
    assert roomy.clearance_m == pytest.approx(replay.record.safety.min_clearance, abs=1e-3)


def test_a_search_cut_short_says_so_and_proves_nothing(matrix) -> None:
    scenario = matrix.get("classic_doorway_high")
    cut = search(scenario, 141, WitnessSettings(max_plans=12))
    assert not cut.found and cut.tried == 12 and cut.plans > 1000 and cut.arrival_s is None
    assert (
        cut.summary() == f"no witness among 12 plans (12 of {cut.plans} tried): not proof that no robot could"
    )
    assert Witness.model_validate(cut.model_dump(mode="json")) == cut  # typed end to end (the CLI's --json)
