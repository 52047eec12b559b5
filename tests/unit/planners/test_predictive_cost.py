"""Cost terms and candidates of the predictive planner on hand-built situations."""

from __future__ import annotations

import numpy as np
import pytest

from foresight.core.planners.predictive.config import PredictivePlannerConfig, SamplingConfig
from foresight.core.planners.predictive.cost import RoutePotential
from foresight.core.planners.predictive.planner import PredictivePlanner
from foresight.core.planners.predictive.sampling import first_candidates
from foresight.core.predict.forecaster import ConstantVelocityForecaster
from foresight.core.predict.timebase import PLANNER_TIMEBASE
from foresight.core.sim.robot import RobotLimits
from tests.unit.planners.scenes import corridor_map, info_for, observation


def _planner(map_def, config=None) -> PredictivePlanner:
    p = PredictivePlanner(config, ConstantVelocityForecaster(PLANNER_TIMEBASE))
    p.reset(info_for(map_def))
    return p


def test_candidates_span_distinct_turn_rates():
    cands = first_candidates(SamplingConfig(), RobotLimits(), 1.0, near_field=False)
    rates = np.unique(cands[:, 1])
    assert len(rates) == 9 and rates.min() == pytest.approx(-1.0) and rates.max() == pytest.approx(1.0)
    assert np.all(np.diff(rates) > 0.2)  # evenly spread, not collapsed onto the limits
    assert [0.0, 0.0] in cands.tolist()  # braking is always available
    assert cands[:, 0].max() == pytest.approx(2.0)


def test_near_field_densifies_turn_rates_and_speeds():
    far = first_candidates(SamplingConfig(), RobotLimits(), 1.0, near_field=False)
    near = first_candidates(
        SamplingConfig(near_field={"speed_cap": 0.5}), RobotLimits(), 1.0, near_field=True
    )
    assert len(np.unique(near[:, 1])) > len(np.unique(far[:, 1]))
    assert len(np.unique(near[:, 0])) > len(np.unique(far[:, 0]))
    assert near[:, 0].max() == pytest.approx(1.0)  # near-field speed cap 0.5 of 2 m/s


def test_pedestrian_on_straight_path_makes_straight_costlier():
    m = corridor_map()
    cmds = np.array([[1.5, 0.0], [1.5, 0.6]])
    free = _planner(m).score_commands(observation(m), cmds)[0]
    blocked_total, terms = _planner(m).score_commands(observation(m, peds=[(8.5, 10.0)]), cmds)
    assert free[0] < free[1]  # without the pedestrian, straight is best
    assert blocked_total[0] > blocked_total[1]  # with it, swerving is cheaper
    assert terms["collision"][0] > 0 and terms["collision"][0] > terms["collision"][1]


def test_collision_uses_true_radii():
    """A pedestrian 1.3 m beside the straight path (within r_robot + r_ped = 1.4 m) is a predicted collision."""
    m = corridor_map()
    terms = _planner(m).score_commands(observation(m, peds=[(8.0, 11.3)]), np.array([[1.5, 0.0]]))[1]
    assert terms["collision"][0] > 0


def test_wall_ahead_is_penalised():
    wall = ((9.0, 0.0), (10.0, 0.0), (10.0, 20.0), (9.0, 20.0))  # blocks the corridor 3 m ahead
    m = corridor_map(obstacles=(wall,))
    total, terms = _planner(m).score_commands(observation(m), np.array([[2.0, 0.0], [0.0, 0.0]]))
    assert terms["static_collision"][0] > 0 and terms["static_collision"][1] == 0
    assert total[0] > total[1]


def test_route_progress_follows_waypoints():
    """Around a corner, moving toward the next waypoint counts as progress, cutting straight to the goal does not."""
    route = np.array([[10.0, 10.0], [10.0, 20.0]])
    pot = RoutePotential(route, switch_radius=2.0, goal_tolerance=2.0)
    start = pot.start(np.array([0.0, 10.0]))
    along = pot(np.array([[[5.0, 10.0]]]))[0][0]
    cut = pot(np.array([[[3.5, 13.5]]]))[0][0]  # ~5 m closer to the goal in a straight line
    assert start - along == pytest.approx(5.0)
    assert along < cut


def test_goal_inside_tolerance_has_zero_potential():
    pot = RoutePotential(np.array([[10.0, 10.0], [20.0, 10.0]]), switch_radius=2.0, goal_tolerance=2.0)
    pts = np.array([[[5.0, 10.0], [18.5, 10.0], [25.0, 10.0]]])
    phi = [pot(pts[:, : k + 1])[0][0] for k in range(3)]  # the potential after each step of the rollout
    assert phi[1] == 0.0 and phi[2] == 0.0 and phi[0] > 0


def test_static_field_never_overestimates_clearance():
    wall = ((9.0, 0.0), (10.0, 0.0), (10.0, 20.0), (9.0, 20.0))
    m = corridor_map(obstacles=(wall,))
    p = _planner(m, PredictivePlannerConfig())
    obs = observation(m)
    field = p._static_field(obs)
    pts = np.random.default_rng(0).uniform([0, 0], [30, 20], size=(500, 2))
    exact = obs.static.distance(pts)
    approx = field(pts)
    assert np.all(approx <= exact + 1e-9) and np.all(exact - approx < 0.2)
    assert field(np.array([[-1.0, 5.0]]))[0] < 0  # outside the map


def test_after_a_stall_a_waiting_pedestrian_is_trusted_to_make_room_for_a_slow_robot():
    """Yield, then commit: a standing pedestrian near a stalled robot is taken to step away from an edging robot."""
    m = corridor_map()
    obs = observation(
        m, velocity=(0.0, 0.0), peds=[(6.5, 10.0)]
    )  # standing 0.1 m beyond the 1.4 m contact distance
    creep = np.array([[0.3, 0.0]])

    def collision(config: dict, assertiveness: float) -> float:
        p = _planner(m, PredictivePlannerConfig.from_dict(config))
        p._memory.crowd.stall.level = assertiveness  # 1: as after a few seconds without route progress
        return float(p.score_commands(obs, creep)[1]["collision"][0])

    nobody_waits = {"safety": {"crowd": {"yielding": {"speed": 0.0}}}}
    assert collision({}, 1.0) < collision(
        nobody_waits, 1.0
    )  # committed: the pedestrian is expected to step back
    assert collision({}, 0.0) == pytest.approx(collision(nobody_waits, 0.0))  # at ease nobody is assumed to


def test_a_walking_pedestrian_is_never_taken_to_wait():
    m = corridor_map()
    p = _planner(m)
    walking = observation(m, velocity=(0.0, 0.0), peds=[(6.5, 10.0)], ped_vels=[(-1.0, 0.0)])
    assert not p._memory.crowd.waits(walking, walking.ped_ids, contact=1.4).any()
    standing = observation(m, velocity=(0.0, 0.0), peds=[(6.5, 10.0)])
    assert p._memory.crowd.waits(standing, standing.ped_ids, contact=1.4).all()


@pytest.mark.parametrize("steps_back", [False, True])
def test_a_pedestrian_who_holds_its_ground_while_the_robot_closes_in_is_not_trusted_again(steps_back):
    """The trust is tested: standing put for ``yield_test_s`` while the robot closes in revokes it for the episode."""
    m = corridor_map()
    p = _planner(m)
    test_steps = int(round(p.config.safety.crowd.yielding.test_s / 0.1))
    waiting = None
    for step in range(test_steps + 5):
        robot_x = 5.0 + 0.02 * step  # edging forward at 0.2 m/s
        ped_x = 7.0 + (0.03 * step if steps_back else 0.0)  # the pedestrian steps back faster, or not at all
        obs = observation(m, pose=(robot_x, 10.0, 0.0), velocity=(0.2, 0.0), peds=[(ped_x, 10.0)], step=step)
        waiting = p._memory.crowd.waits(obs, obs.ped_ids, contact=1.4)
    assert bool(waiting[0]) is steps_back
    assert (0 in p._memory.crowd.waits.holds) is not steps_back


def test_assertiveness_grows_while_stalled_and_decays_with_progress():
    m = corridor_map()
    p = _planner(m)
    s = p.config.safety.stall
    dt, t, a = 0.1, 0.0, []
    for _ in range(int((s.after_s + s.ramp_s) / dt) + 5):  # standing still
        a.append(p._memory.crowd.stall(10.0, t, dt))
        t += dt
    assert a[0] == 0.0 and a[int(s.after_s / dt) - 1] == 0.0 and a[-1] == 1.0
    phi = 10.0
    for _ in range(int(s.after_s / dt) + 10):  # driving at 1 m/s along the route
        phi -= 1.0 * dt
        t += dt
        last = p._memory.crowd.stall(phi, t, dt)
    assert 0.0 < last < 1.0  # ramps down gradually, no reset


def test_rollouts_are_read_at_the_forecast_times():
    from foresight.core.errors import ConfigError
    from foresight.core.planners.predictive.rollout import eval_steps, extend_forecast, rollout
    from foresight.core.sim.robot import unicycle_step

    times = PLANNER_TIMEBASE.times  # 0.2 s grid
    idx = eval_steps(times, 0.1)
    assert idx.tolist() == list(range(1, 24, 2))  # state after step 2, 4, ... = time 0.2, 0.4, ...
    with pytest.raises(ConfigError):
        eval_steps(np.array([0.15, 0.3]), 0.1)
    # the rollout is the simulator's step, applied step by step
    s0 = np.array([[0.0, 0.0, 0.3, 0.5, 0.0]])
    cmds = np.tile([1.5, 0.4], (1, 5, 1))
    states = rollout(s0, cmds, RobotLimits(), 0.1)
    s = s0[0]
    for _ in range(5):
        s = unicycle_step(s, np.array([1.5, 0.4]), RobotLimits(), 0.1)
    assert np.allclose(states[0, -1], s)
    pos, sig, t = extend_forecast(
        np.array([[[0.0, 0.0], [0.2, 0.0]]]), np.array([[0.1, 0.15]]), np.array([0.2, 0.4]), 2
    )
    assert t.tolist() == pytest.approx([0.2, 0.4, 0.6, 0.8]) and pos[0, -1].tolist() == pytest.approx(
        [0.6, 0.0]
    )
    assert sig[0].tolist() == pytest.approx(
        [0.1, 0.15, 0.2, 0.25]
    )  # the spread keeps growing at its last rate


def _walker_towards_standing_robot(m):
    """A standing robot facing its route (+x) and a pedestrian 3.5 m to its side walking straight at it (1.3 m/s)."""
    return observation(m, velocity=(0.0, 0.0), peds=[(5.0, 13.5)], ped_vels=[(0.0, -1.3)], step=3)


def _observe_walk(planner, m):
    """Feed the walker's last steps so the forecaster sees its velocity, then return the current observation."""
    for k in range(3):
        planner.forecaster.observe(
            observation(m, velocity=(0.0, 0.0), peds=[(5.0, 13.5 + 0.13 * (3 - k))], step=k)
        )
    return _walker_towards_standing_robot(m)


def test_standing_still_in_a_walkers_path_is_a_predicted_collision_and_the_robot_moves_away():
    """No discount for a robot standing still: it gets out of the way of a pedestrian who will not yield."""
    m = corridor_map()
    p = _planner(m)
    obs = _observe_walk(p, m)
    total, terms = p.score_commands(obs, np.array([[0.0, 0.0], [2.0, 0.0]]))
    assert terms["collision"][0] > 0 and terms["risk"][0] > 1.0  # several contact steps expected
    assert terms["risk"][1] < 0.25 * terms["risk"][0] and total[1] < total[0]  # speeding away along the route
    p = _planner(m)
    v, _ = p.plan(_observe_walk(p, m))
    assert v > 0.0 and p.diagnostics["terms"]["risk"] < 0.5 * terms["risk"][0]


def test_chance_margin_and_risk_grow_with_the_forecast_spread():
    """The collision margin is ``confidence`` sigmas, and the contact probability reads sigma: wider spread, more cost."""
    m = corridor_map()
    obs = observation(m, velocity=(1.0, 0.0), peds=[(9.0, 11.6)])  # to the side of the robot's line, standing
    cmd = np.array([[1.0, 0.0]])
    base = _planner(
        m, PredictivePlannerConfig.from_dict({"safety": {"pedestrians": {"confidence": 0.0}}})
    ).score_commands(obs, cmd)[1]
    wide = _planner(
        m, PredictivePlannerConfig.from_dict({"safety": {"pedestrians": {"confidence": 2.0}}})
    ).score_commands(obs, cmd)[1]
    assert wide["collision"][0] > base["collision"][0]
    assert base["risk"][0] == wide["risk"][0] > 0  # risk is the probability itself, no margin


def test_contact_probability_is_the_normal_tail():
    """Independent check of the logistic approximation against math.erfc."""
    import math

    from foresight.core.planners.predictive.cost import RISK_CUTOFF, contact_probability

    z = np.linspace(-4, 2.99, 200)
    exact = np.array([0.5 * math.erfc(x / math.sqrt(2)) for x in z])
    assert np.max(np.abs(contact_probability(z) - exact)) < 0.01
    assert contact_probability(np.array([RISK_CUTOFF, 10.0])).tolist() == [0.0, 0.0]


def test_after_a_stall_only_a_standing_pedestrian_is_expected_to_make_room():
    """A pedestrian forecast to stand near a stalled robot is waiting for it; one who walks on never makes room."""
    m = corridor_map()
    waiting = PredictivePlannerConfig.from_dict({"safety": {"crowd": {"waiting_room": 0.7}}})
    p = _planner(m, waiting)
    times = PLANNER_TIMEBASE.times
    standing = np.repeat([[[7.0, 10.0]]], len(times), axis=1)  # (1, K, 2)
    walking = np.array([7.0, 10.0]) + times[None, :, None] * np.array([0.0, 1.3])
    assert p._memory.crowd.waiting_room(standing, times, 0.0).tolist() == [0.0]  # no stall, no room
    assert p._memory.crowd.waiting_room(standing, times, 1.0).tolist() == [
        pytest.approx(p.config.safety.crowd.waiting_room)
    ]
    assert p._memory.crowd.waiting_room(walking, times, 1.0).tolist() == [0.0]
    creep = np.array([[0.3, 0.0]])
    obs = observation(m, velocity=(0.0, 0.0), peds=[(7.6, 10.0)], step=0)
    fresh = p.score_commands(obs, creep)[1]
    stalled = _planner(m, waiting)
    for k in range(80):  # 8 s standing still: assertiveness ramps to 1
        stalled._memory.crowd.stall(stalled._route(obs).start(obs.robot_pose[:2]), 0.1 * k, 0.1)
    late = stalled.score_commands(observation(m, velocity=(0.0, 0.0), peds=[(7.6, 10.0)], step=80), creep)[1]
    assert late["risk"][0] < fresh["risk"][0] and late["collision"][0] < fresh["collision"][0]
    assert _planner(m)._memory.crowd.waiting_room(standing, times, 1.0).tolist() == [0.0]  # off by default


def test_what_a_rollout_meets_after_arriving_costs_nothing():
    """The episode ends at the goal: a pedestrian and a wall just beyond it are never met (``search.ends_at_goal``)."""
    wall = ((13.0, 0.0), (14.0, 0.0), (14.0, 20.0), (13.0, 20.0))
    m = corridor_map(obstacles=(wall,))
    obs = observation(
        m, pose=(5.0, 10.0, 0.0), velocity=(2.0, 0.0), route=((10.0, 10.0),), peds=[(12.0, 10.0)]
    )
    cmds = np.array([[2.0, 0.0]])  # reaches the goal's 2 m tolerance at x = 8 within a second, then drives on
    off = PredictivePlannerConfig.from_dict({"search": {"ends_at_goal": False}})
    _, beyond = _planner(m, off).score_commands(obs, cmds)
    _, ends = _planner(m).score_commands(obs, cmds)
    assert (
        beyond["collision"][0] > 0 and beyond["static_collision"][0] > 0
    )  # met after the goal, when counted
    assert ends["collision"][0] == 0 and ends["static_collision"][0] == 0 and ends["hard_clearance"][0] == 0
    short = _planner(m).score_commands(obs, np.array([[0.0, 0.0]]))[1]  # short of the goal it is still there
    assert short["progress"][0] < ends["progress"][0]


def test_price_of_the_chosen_course_is_its_cost_and_a_course_into_a_walker_costs_more():
    """``price``: a course the planner did not choose, judged against the decision's own forecast (a witness's)."""
    m = corridor_map()
    p = _planner(m)
    with pytest.raises(RuntimeError, match="before plan"):
        p.price(np.array([[1.0, 0.0]]))
    p.plan(observation(m, peds=[(9.0, 10.0)], ped_vels=[(-1.0, 0.0)]))
    diag = p.diagnostics
    chosen = np.concatenate([np.repeat([[v, w]], n, axis=0) for n, v, w in diag["sequence"]])
    cost, parts = p.price(chosen)
    assert cost == pytest.approx(diag["cost"], abs=1e-9)  # the same cost, recomputed from the commands alone
    assert sum(parts.values()) == pytest.approx(cost) and parts["progress"] <= 0  # weighted shares of it
    head_on, into = p.price(np.array([[2.0, 0.0]]))  # held: straight at the walker coming down the corridor
    assert head_on > cost and into["collision"] > parts["collision"]
