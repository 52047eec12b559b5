"""CrowdNav's social metrics: discomfort frequency at the scenario's distance and CrowdNav++'s intrusion."""

from __future__ import annotations

import numpy as np

from foresight.core.evaluation.metrics import EpisodeGeometry, derive, social_steps
from tests.unit.evaluation.traces import make_trace


def _geom(**kw) -> EpisodeGeometry:
    return EpisodeGeometry(robot_radius=0.3, ped_radius=0.3, horizon=50, route=np.array([[10.0, 0.0]]), **kw)


def test_none_where_the_scenario_defines_no_social_metrics() -> None:
    tr = make_trace(np.zeros((5, 2)), [np.full((5, 2), 3.0)], dt=0.25)
    assert social_steps(derive(tr, _geom()), _geom()) == {"discomfort_steps": None, "intrusion_steps": None}


def test_discomfort_counts_steps_below_the_distance_and_intrusion_looks_at_the_true_future() -> None:
    robot = np.zeros((9, 2))  # standing at the origin for 8 steps
    ped = np.column_stack([np.linspace(2.0, 0.75, 9), np.zeros(9)])  # walks up to 0.75 m (clearance 0.15 m)
    g = _geom(discomfort_clearance=0.2, intrusion_steps=5)
    out = social_steps(derive(make_trace(robot, [ped], dt=0.25), g), g)
    gap = ped[:, 0] - 0.6
    assert out["discomfort_steps"] == int((gap[1:] < 0.2).sum()) == 1
    assert out["intrusion_steps"] == 0  # never within 0.6 m of where it will be
    far_then_close = np.column_stack([[3.0, 3.0, 3.0, 3.0, 0.5, 0.5, 3.0, 3.0, 3.0], np.zeros(9)])
    out = social_steps(derive(make_trace(robot, [far_then_close], dt=0.25), g), g)
    # the robot stands where the pedestrian will be at states 4 and 5: states 1..4 see it coming (within 5 steps)
    assert out["intrusion_steps"] == 4
    respawned = np.array([[0] * 4 + [7] * 5])  # a new id at state 4 is not the same pedestrian's future
    tr = make_trace(robot, [far_then_close], ped_ids=respawned.T, dt=0.25)
    assert social_steps(derive(tr, g), g)["intrusion_steps"] == 1  # only state 4's own future (state 5)
