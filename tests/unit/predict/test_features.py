import math

import numpy as np

from foresight.core.predict.features import (
    Window,
    current_index,
    ego_to_world,
    extract_features,
    feature_dim,
    feature_names,
    world_to_ego,
)
from foresight.core.predict.history import LiveHistory
from foresight.core.predict.samples import samples_from_trace, trace_window
from foresight.core.predict.timebase import PLANNER_TIMEBASE, TimeBase
from tests.unit.predict.helpers import make_trace, scripted_episode


def test_frame_transform_hand_computed():
    # robot at (1, 2) facing +y (90 deg): (1, 5) is 3 m ahead, (0, 2) 1 m to the left, (2, 2) 1 m to the right
    origin, heading = np.array([1.0, 2.0]), math.pi / 2
    ego = world_to_ego(np.array([[1.0, 5.0], [0.0, 2.0], [2.0, 2.0]]), origin, heading)
    np.testing.assert_allclose(ego, [[3.0, 0.0], [0.0, 1.0], [0.0, -1.0]], atol=1e-12)
    # 30 deg: (dx, dy) = (1, 0) -> (cos30, -sin30)
    np.testing.assert_allclose(
        world_to_ego(np.array([2.0, 2.0]), origin, math.pi / 6), [math.sqrt(3) / 2, -0.5], atol=1e-12
    )
    pts = np.random.default_rng(0).normal(size=(5, 3, 2))
    np.testing.assert_allclose(ego_to_world(world_to_ego(pts, origin, 0.7), origin, 0.7), pts, atol=1e-12)


def test_features_hand_computed_values():
    tb = TimeBase(0.5, 2, 3)
    # robot at origin facing +y; ped walked from (1, 0) to (1, 1) in 0.5 s; goal 4 m ahead
    w = Window(
        ego_pose=np.array([0.0, 0.0, math.pi / 2]),
        ego_motion=np.array([0.7, -0.1]),
        goal=np.array([0.0, 4.0]),
        ped_ids=np.array([3]),
        ped_hist=np.array([[[1.0, 0.0], [1.0, 1.0]]]),
        hist_valid=np.array([[True, True]]),
    )
    f = extract_features(w, tb, max_agents=2)
    names = feature_names(2)
    got = dict(zip(names, f.features[0], strict=True))
    assert f.features.shape == (2, feature_dim(2)) and list(f.mask) == [1, 0] and list(f.ped_ids) == [3, -1]
    np.testing.assert_allclose(
        [got["px[-1]"], got["py[-1]"], got["vx[-1]"], got["valid[-1]"]], [0, -1, 0, 1], atol=1e-6
    )
    np.testing.assert_allclose(
        [got["px[0]"], got["py[0]"], got["vx[0]"], got["vy[0]"]], [1, -1, 2, 0], atol=1e-6
    )
    np.testing.assert_allclose(
        [got[c] for c in ("ego_v", "ego_w", "goal_ux", "goal_uy", "goal_dist")],
        [0.7, -0.1, 1, 0, 4],
        atol=1e-6,
    )
    assert not f.features[1].any()
    assert current_index(2, "px") == names.index("px[0]")


def test_velocity_is_backward_difference_only():
    tb = TimeBase(1.0, 3, 2)
    hist = np.array([[[0.0, 0.0], [1.0, 0.0], [3.0, 0.0]]])
    w = Window(np.zeros(3), np.zeros(2), None, np.array([0]), hist, np.array([[False, True, True]]))
    f = extract_features(w, tb, 1).features[0]
    names = feature_names(3)
    assert f[names.index("vx[0]")] == 2.0  # (3 - 1) / 1, never the central (3 - 0) / 2
    assert f[names.index("vx[-1]")] == 0.0 and f[names.index("px[-2]")] == 0.0  # unobserved step


def test_nearest_first_and_truncation():
    tb = TimeBase(0.1, 1, 1)
    hist = np.array([[[5.0, 0.0]], [[1.0, 0.0]], [[3.0, 0.0]]])
    w = Window(np.zeros(3), np.zeros(2), None, np.array([10, 11, 12]), hist, np.ones((3, 1), bool))
    assert list(extract_features(w, tb, 2).ped_ids) == [11, 12]


def test_trace_path_equals_live_path():
    trace, observations, waypoints = scripted_episode(steps=40)
    live = LiveHistory(PLANNER_TIMEBASE)
    for t, obs in enumerate(observations):
        live.observe(obs)
        a = extract_features(live.window(), PLANNER_TIMEBASE, 3)
        b = extract_features(trace_window(trace, t, PLANNER_TIMEBASE, waypoints), PLANNER_TIMEBASE, 3)
        np.testing.assert_array_equal(a.features, b.features)
        np.testing.assert_array_equal(a.ped_ids, b.ped_ids)
        np.testing.assert_array_equal(a.mask, b.mask)


def test_trace_samples_targets_and_respawn_masking():
    trace, _, waypoints = scripted_episode(steps=40)
    tb = PLANNER_TIMEBASE  # stride 2, horizon 12 -> 24 steps ahead
    s = samples_from_trace(trace, tb, max_agents=6, waypoints=waypoints)
    assert list(s.step) == [0, 2, 4, 6, 8, 10, 12, 14, 16]
    assert s.state.shape == (9, 6, feature_dim(5)) and s.target.shape == (9, 6, 12, 2)
    # step 0: slots for ids 0, 1, 2 (3 is absent until step 5), 3 empty slots
    k = 0
    f = extract_features(trace_window(trace, 0, tb, waypoints), tb, 6)
    assert f.mask.sum() == 3 and s.mask[k].sum() == 3
    slot2 = list(f.ped_ids).index(2)
    # id 2 respawns at step 20 = horizon step 10 from t=0: future steps 10..12 masked
    np.testing.assert_array_equal(s.target_mask[k, slot2], [1] * 9 + [0] * 3)
    slot0 = list(f.ped_ids).index(0)
    expected = world_to_ego(trace.ped_pos[2:25:2, 0], trace.robot[0, :2], trace.robot[0, 2])
    np.testing.assert_allclose(s.target[k, slot0], expected, atol=1e-5)
    assert not s.target_mask[:, 3:].any() or s.mask[:, 3:].any()
    assert np.all(s.target_mask <= s.mask[..., None])


def test_short_trace_gives_no_samples():
    trace = make_trace(np.zeros((5, 5)), np.zeros((5, 1), np.int64), np.zeros((5, 1, 2)))
    s = samples_from_trace(trace, PLANNER_TIMEBASE, 4, None)
    assert len(s) == 0 and s.state.shape == (0, 4, feature_dim(5))


def test_mirror_signs_mirror_a_window():
    tb = TimeBase(0.5, 2, 3)
    hist = np.array([[[1.0, 0.5], [2.0, 1.5]]])
    w = Window(
        np.array([0.0, 0.0, 0.0]),
        np.array([0.7, 0.3]),
        np.array([3.0, 4.0]),
        np.array([1]),
        hist,
        np.ones((1, 2), bool),
    )
    mirrored = Window(
        w.ego_pose, np.array([0.7, -0.3]), np.array([3.0, -4.0]), w.ped_ids, hist * [1.0, -1.0], w.hist_valid
    )
    from foresight.core.predict.features import mirror_signs

    np.testing.assert_allclose(
        extract_features(w, tb, 1).features * mirror_signs(2),
        extract_features(mirrored, tb, 1).features,
        atol=1e-6,
    )


def test_gather_history_with_an_empty_older_frame():
    """A pedestrian that appears after a frame with nobody in it: its earlier grid point is simply unobserved."""
    from foresight.core.predict.features import gather_history

    frame_ids = [
        np.array([], dtype=np.int64),
        np.array([7, 3], dtype=np.int64),
        np.array([3], dtype=np.int64),
    ]
    frame_pos = [np.zeros((0, 2)), np.array([[9.0, 9.0], [1.0, 1.0]]), np.array([[1.5, 1.0]])]
    pos, valid = gather_history(frame_ids, frame_pos, 1, 3, np.array([3]))
    np.testing.assert_array_equal(valid, [[False, True, True]])
    np.testing.assert_allclose(pos, [[[0.0, 0.0], [1.0, 1.0], [1.5, 1.0]]])
