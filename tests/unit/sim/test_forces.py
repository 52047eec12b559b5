"""Each social-force term against values computed by hand on small fixed scenes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from foresight.core.sim import forces
from foresight.core.sim.forces import as_complex as C
from foresight.core.sim.forces import as_xy
from foresight.core.sim.geometry import SegmentSet
from foresight.core.sim.neighbours import all_pairs, cell_pairs
from foresight.core.sim.params import ForceParams

P = ForceParams()


def test_desired_force_relaxes_towards_desired_velocity_and_brakes_at_goal():
    pos = np.array([[0.0, 0.0], [5.0, 5.0]])
    vel = np.array([[0.0, 0.0], [0.4, 0.0]])
    goal = np.array([[3.0, 4.0], [5.1, 5.0]])  # second ped is within 0.2 m: brake only
    f = as_xy(forces.desired_force(C(pos), C(vel), C(goal), np.array([0.65, 0.65]), P))
    assert f[0] == pytest.approx([0.65 * 0.6 / 0.5, 0.65 * 0.8 / 0.5])
    assert f[1] == pytest.approx([-0.4 / 0.5, 0.0])


def test_social_force_two_standing_peds_by_hand():
    # i at origin, j 1 m to the right, both still: e = t = (-1, 0), theta = 0, B = 0.35
    pos = np.array([[0.0, 0.0], [1.0, 0.0]])
    vel = np.zeros((2, 2))
    f = as_xy(forces.social_force(C(pos), C(vel), None, None, P, cutoff=20.0))
    k = 5.1 * math.exp(-1.0 / 0.35)
    # deceleration term along t plus the sideways term -s * n(t) with s = +1, n(t) = (-t_y, t_x) = (0, -1)
    assert f[0] == pytest.approx([-k, k])
    assert f[1] == pytest.approx([k, -k])


def test_social_force_moving_pair_matches_formula_with_unwrapped_theta():
    pos = np.array([[0.0, 0.0], [-2.0, 0.5]])
    vel = np.array([[0.5, 0.0], [0.3, -0.4]])
    f = as_xy(forces.social_force(C(pos), C(vel), None, None, P, cutoff=20.0))
    # by hand for ped 0
    r = pos[0] - pos[1]
    d = np.hypot(*r)
    e = r / d
    w = 2.0 * (vel[1] - vel[0]) + e
    t = w / np.hypot(*w)
    b = 0.35 * np.hypot(*w) + 1e-8
    theta = math.atan2(t[1], t[0]) - math.atan2(e[1], e[0])
    s = 1.0 if theta >= 0 else -1.0
    expect = math.exp(-d / b - (3 * b * theta) ** 2) * t - s * math.exp(
        -d / b - (2 * b * theta) ** 2
    ) * np.array([-t[1], t[0]])
    assert f[0] == pytest.approx(5.1 * expect)


def test_social_force_vanishes_beyond_cutoff_and_for_coincident_peds():
    pos = np.array([[0.0, 0.0], [9.0, 0.0], [0.0, 0.0]])
    f = forces.social_force(C(pos[:2]), np.zeros(2, complex), None, None, P, cutoff=8.0)
    assert np.all(f == 0)
    f = forces.social_force(C(pos[[0, 2]]), np.zeros(2, complex), None, None, P, cutoff=8.0)
    assert np.all(f == 0) and np.all(np.isfinite(f))


def test_dense_and_cell_list_pairs_give_the_same_force():
    rng = np.random.default_rng(3)
    pos = rng.uniform(0, 60, (300, 2))
    vel = rng.normal(0, 0.5, (300, 2))
    cutoff = P.social_cutoff(0.65)
    z, v = C(pos), C(vel)
    dense = forces.social_force(z, v, None, None, P, cutoff)
    i, j = cell_pairs(pos, cutoff)
    sparse = forces.social_force(z, v, i, j, P, None)  # the cell list returns exact neighbours
    assert np.allclose(dense, sparse, rtol=0, atol=1e-12)
    i, j = all_pairs(300)
    assert np.allclose(dense, forces.social_force(z, v, i, j, P, cutoff), rtol=0, atol=1e-12)


def test_cutoff_error_per_ignored_neighbour_is_bounded():
    # worst case: head-on at the fastest speed, just beyond the cutoff
    vmax = 0.65
    cutoff = P.social_cutoff(vmax)
    assert 8.0 < cutoff < 8.6
    pos = np.array([[0.0, 0.0], [cutoff + 1e-6, 0.0]])
    vel = np.array([[vmax, 0.0], [-vmax, 0.0]])
    full = as_xy(forces.social_force(C(pos), C(vel), None, None, P, cutoff=20.0))
    assert np.hypot(*full[0]) <= P.social_pair_tolerance
    assert P.social_cutoff(10.0) == 20.0  # capped at the reference range


def test_obstacle_force_single_wall_by_hand():
    walls = SegmentSet(np.array([[0.0, 0.0, 10.0, 0.0]]))
    pos = np.array([[5.0, 1.0], [12.0, 0.0]])  # above the middle; 2 m beyond the end point
    f, clearance = forces.obstacle_force(C(pos), walls, P)
    f = as_xy(f)
    assert f[0] == pytest.approx([0.0, 10.0 * 1.0 / 1.57**4])
    assert f[1] == pytest.approx([10.0 * 2.0 / 2.57**4, 0.0])
    assert clearance == pytest.approx([1.0, 2.0])


def test_group_coherence_by_hand():
    pos = np.array([[0.0, 0.0], [4.0, 0.0], [10.0, 10.0]])
    group = np.array([0, 0, 1])
    size = np.array([2.0, 1.0])
    cent = forces.group_centroids(C(pos), group, size)[group]
    f = as_xy(forces.group_coherence_force(C(pos), cent, size[group], P))
    k = 3.0 * (math.tanh(2.0 - 0.5) + 1) / 2
    assert f[0] == pytest.approx([2.0 * k, 0.0])
    assert f[1] == pytest.approx([-2.0 * k, 0.0])
    assert f[2] == pytest.approx([0.0, 0.0])  # singleton


def test_group_repulsion_only_within_range():
    pos = np.array([[0.0, 0.0], [0.5, 0.0], [0.0, 3.0]])
    i, j = np.array([0, 1, 0, 2, 1, 2]), np.array([1, 0, 2, 0, 2, 1])
    f = as_xy(forces.group_repulsion_force(C(pos), i, j, P))
    assert f[0] == pytest.approx([-0.5, 0.0])
    assert f[1] == pytest.approx([0.5, 0.0])
    assert f[2] == pytest.approx([0.0, 0.0])


def test_group_gaze_by_hand():
    # ped 0 walks +x towards (10, 0); the other member is at (1, 1): g = (1, 1)/sqrt2, |c'-x| = sqrt2
    pos = np.array([[0.0, 0.0], [1.0, 1.0]])
    goal = np.array([[10.0, 0.0], [10.0, 0.0]])
    group = np.array([0, 0])
    size = np.array([2.0])
    cent = forces.group_centroids(C(pos), group, size)[group]
    f = as_xy(forces.group_gaze_force(C(pos), C(goal), cent, size[group], P))
    assert f[0] == pytest.approx([4.0 * math.sqrt(2) * (1 / math.sqrt(2)) / 10.0, 0.0])


def test_robot_force_inverse_cube_with_hard_cutoff():
    pos = np.array([[2.0, 0.0], [0.0, 3.4], [0.0, -3.3]])
    f = as_xy(forces.robot_force(C(pos), 0j, 1.0, P))
    assert f[0] == pytest.approx([10.0 / 8.0, 0.0])
    assert f[1] == pytest.approx([0.0, 0.0])  # beyond 2.0 + 0.35 + 1.0 = 3.35 m
    assert f[2] == pytest.approx([0.0, -10.0 / 3.3**3])
