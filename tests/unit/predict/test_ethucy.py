import numpy as np
import pytest

from foresight.core.errors import ConfigError
from foresight.core.predict.ethucy import focal_windows, fold_files, import_fold, scene_samples
from foresight.core.predict.features import feature_names
from foresight.core.predict.metrics import evaluate_predictor
from foresight.core.predict.predictor import ConstantVelocityPredictor
from foresight.core.predict.timebase import ETHUCY_TIMEBASE, TimeBase


def _scene(tracks):
    rows = [(f, pid, x, y) for pid, pts in tracks.items() for f, x, y in pts]
    return np.array(rows, dtype=float)


def test_windows_need_consecutive_frames():
    pts = [(f * 10, f * 0.5, 0.0) for f in range(25) if f != 12]  # gap at frame 120
    assert [w[1][0] for w in focal_windows(_scene({1: pts}), 5)] == [
        0,
        10,
        20,
        30,
        40,
        50,
        60,
        70,
        130,
        140,
        150,
        160,
        170,
        180,
        190,
        200,
    ]


def test_observed_only_frame_and_backward_velocity():
    tb = TimeBase(0.4, 3, 2)
    # focal walks +x 0.4 m/step, then turns to +y in the FUTURE: the frame must not see the turn
    focal = [(0, 0.0, 0.0), (10, 0.4, 0.0), (20, 0.8, 0.0), (30, 0.8, 0.4), (40, 0.8, 0.8)]
    neighbour = [(20, 2.0, 1.0), (30, 9.0, 9.0)]  # only at the current frame: partial history
    s = scene_samples(_scene({1: focal, 2: neighbour}), tb, max_agents=3)
    assert len(s) == 1
    names = feature_names(3)
    f = dict(zip(names, s.state[0, 0], strict=True))
    assert f["vx[0]"] == pytest.approx(1.0) and f["vy[0]"] == pytest.approx(0.0)  # (0.8-0.4)/0.4, not central
    assert f["px[-2]"] == pytest.approx(-0.8) and f["valid[-2]"] == 1
    nb = dict(zip(names, s.state[0, 1], strict=True))
    assert (nb["px[0]"], nb["py[0]"], nb["valid[-1]"], nb["vx[0]"]) == pytest.approx((1.2, 1.0, 0.0, 0.0))
    np.testing.assert_allclose(s.target[0, 0], [[0.0, 0.4], [0.0, 0.8]], atol=1e-6)
    assert s.target_mask[0].tolist() == [[1, 1], [0, 0], [0, 0]]
    assert not s.state[0, 0, -5:].any()  # no robot: ego channels zero
    # training splits may carry the neighbours' futures (same focal frame, only where annotated); features unchanged
    n = scene_samples(_scene({1: focal, 2: neighbour}), tb, max_agents=3, neighbour_targets=True)
    np.testing.assert_array_equal(n.state, s.state)
    np.testing.assert_allclose(n.target[0, 0], s.target[0, 0])
    np.testing.assert_allclose(n.target[0, 1, 0], [8.2, 9.0], atol=1e-6)
    assert n.target_mask[0].tolist() == [[1, 1], [1, 0], [0, 0]]


def test_a_repeated_frame_and_id_row_counts_once_the_first():
    tb = TimeBase(0.4, 3, 2)
    focal = [(0, 0.0, 0.0), (10, 0.4, 0.0), (20, 0.8, 0.0), (30, 0.8, 0.4), (40, 0.8, 0.8)]
    rows = np.vstack(
        [_scene({1: focal, 2: [(20, 2.0, 1.0), (30, 3.0, 1.0)]}), [[20, 2, 50.0, 50.0], [30, 2, 9.0, 9.0]]]
    )
    s = scene_samples(rows, tb, max_agents=3, neighbour_targets=True)
    names = feature_names(3)
    for slot in (1, 2):  # the frame lists pedestrian 2 twice: two slots, both at its first row's position
        nb = dict(zip(names, s.state[0, slot], strict=True))
        assert (nb["px[0]"], nb["py[0]"]) == pytest.approx((1.2, 1.0))
    np.testing.assert_allclose(
        s.target[0, 1:, 0], [[2.2, 1.0], [2.2, 1.0]], atol=1e-6
    )  # its future: not (9, 9)


def test_neighbour_targets_leave_windows_and_focal_targets_unchanged():
    tb = TimeBase(0.4, 3, 4)
    walk = {1: [(f * 10, f * 0.4, 0.0) for f in range(12)], 2: [(f * 10, 5.0, f * 0.3) for f in range(3, 12)]}
    plain, extra = (scene_samples(_scene(walk), tb, 2, neighbour_targets=n) for n in (False, True))
    assert len(plain) == len(extra) == 9  # 7 windows of ped 1, 2 of ped 2
    np.testing.assert_array_equal(extra.state, plain.state)
    np.testing.assert_array_equal(extra.target[:, 0], plain.target[:, 0])
    assert extra.target_mask[:, 1].sum() > 0 and plain.target_mask[:, 1].sum() == 0


def test_neighbour_targets_never_on_the_test_split(tmp_path):
    with pytest.raises(ConfigError, match="neighbour targets"):
        import_fold(tmp_path, "zara1", neighbour_targets=("train", "test"))


def test_short_history_is_not_padded():
    tb = TimeBase(0.4, 3, 2)
    focal = [(0, 0.0, 0.0), (10, 0.4, 0.0), (20, 0.8, 0.0), (30, 1.2, 0.0)]  # 4 < H+T = 5 frames
    assert len(scene_samples(_scene({1: focal}), tb, 2)) == 0


def test_test_scene_leak_is_refused(tmp_path):
    for split in ("train", "val", "test"):
        (tmp_path / "zara1" / split).mkdir(parents=True)
    (tmp_path / "zara1" / "test" / "crowds_zara01.txt").write_text("0\t1\t0\t0\n")
    (tmp_path / "zara1" / "train" / "crowds_zara01_train.txt").write_text("0\t1\t0\t0\n")
    with pytest.raises(ConfigError, match="leakage"):
        fold_files(tmp_path, "zara1")
    with pytest.raises(ConfigError, match="unknown fold"):
        fold_files(tmp_path, "nowhere")


def test_cv_reproduces_reference_on_hotel(shared_dir):
    ds = import_fold(shared_dir / "reference" / "ethucy", "hotel", splits=("test",))
    r = evaluate_predictor(ConstantVelocityPredictor(ETHUCY_TIMEBASE), ds, "test")
    assert r["samples"] == 1197
    assert r["ade"] == pytest.approx(0.32, abs=0.01) and r["fde"] == pytest.approx(0.61, abs=0.01)


def test_a_scene_played_backwards():
    from foresight.core.predict.ethucy import reverse_time

    tb = TimeBase(0.4, 3, 2)
    focal = [
        (0, 0.0, 0.0),
        (10, 0.4, 0.0),
        (20, 0.8, 0.0),
        (30, 0.8, 0.4),
        (40, 0.8, 0.8),
    ]  # +x, then a left turn
    rows = _scene({1: focal, 2: [(20, 2.0, 1.0), (30, 3.0, 1.0)]})
    back = reverse_time(rows)
    assert back[:, 0].tolist() == sorted(back[:, 0].tolist()) and set(np.diff(np.unique(back[:, 0]))) == {
        10.0
    }
    np.testing.assert_array_equal(np.sort(reverse_time(back), axis=0), np.sort(rows, axis=0))
    s = scene_samples(back, tb, max_agents=3)
    assert len(s) == 1
    # backwards it walks -y from (0.8, 0.8) to (0.8, 0.0), then turns right to -x: (0.4, 0) and (0, 0) lie 0.4 and
    # 0.8 m to its right in its own frame (x ahead, y left)
    np.testing.assert_allclose(s.target[0, 0], [[0.0, -0.4], [0.0, -0.8]], atol=1e-6)
    names = feature_names(3)
    nb = dict(
        zip(names, s.state[0, 1], strict=True)
    )  # the neighbour's frame 30 is now its frame 10: seen before now
    assert nb["valid[-1]"] == 1 and nb["valid[0]"] == 1


def test_reversed_scenes_never_on_the_test_split(tmp_path):
    with pytest.raises(ConfigError, match="reversed test scene"):
        import_fold(tmp_path, "zara1", reversed_splits=("test",))


def test_reverse_train_needs_training_on_ethucy():
    from pydantic import ValidationError

    from foresight.core.training.predict_eval import PredictEvalConfig

    assert PredictEvalConfig(train={}, ethucy="ethucy", reverse_train=True).reverse_train
    for kwargs in ({"model": "cv", "ethucy": "ethucy"}, {"train": {}, "dataset": "d.npz"}):
        with pytest.raises(ValidationError, match="reverse_train"):
            PredictEvalConfig(reverse_train=True, **kwargs)
