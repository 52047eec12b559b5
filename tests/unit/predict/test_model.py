import numpy as np
import pytest
import torch

from foresight.core.errors import ConfigError
from foresight.core.predict.features import current_index, feature_dim
from foresight.core.predict.nn.checkpoint import (
    TorchPredictor,
    load_predictor,
    make_checkpoint,
    save_checkpoint,
)
from foresight.core.predict.nn.model import (
    ModelConfig,
    TrajectoryModel,
    masked_ade_fde,
    masked_loss,
    masked_smooth_l1,
)
from foresight.core.predict.predictor import ConstantVelocityPredictor, Predictor
from foresight.core.predict.timebase import ETHUCY_TIMEBASE, PLANNER_TIMEBASE

#: the architecture of checkpoints before edges and pedestrian frames, and the current default one
ARCHS = {"ego": {}, "local_edges": {"edge_dim": 8, "local_frame": True}}


def _model(seed=0, **arch):
    torch.manual_seed(seed)
    return TrajectoryModel(ModelConfig(5, 12, 0.2, hidden=16, blocks=2, **arch))


def _batch(B=3, N=4, seed=0):
    rng = np.random.default_rng(seed)
    f = rng.normal(size=(B, N, feature_dim(5))).astype(np.float32)
    m = np.ones((B, N), np.float32)
    m[:, -1] = 0
    f[:, -1] = 0
    return f, m


@pytest.mark.parametrize("arch", ARCHS)
def test_untrained_model_is_constant_velocity_and_masks(arch):
    f, m = _batch()
    p = TorchPredictor(_model(**ARCHS[arch]), PLANNER_TIMEBASE, "m")
    assert isinstance(p, Predictor)
    out = p.predict(f, m)
    np.testing.assert_allclose(out, ConstantVelocityPredictor(PLANNER_TIMEBASE).predict(f, m), atol=1e-5)
    assert not out[:, -1].any()


@pytest.mark.parametrize("arch", ARCHS)
def test_permutation_equivariant_and_inactive_slots_ignored(arch):
    model = _model(**ARCHS[arch])
    for p in model.decoder[-1].parameters():
        torch.nn.init.normal_(p, std=0.1)
    f, m = _batch()
    out = model(torch.tensor(f), torch.tensor(m))
    perm = [2, 0, 1, 3]
    out_p = model(torch.tensor(f[:, perm]), torch.tensor(m[:, perm]))
    torch.testing.assert_close(out_p, out[:, perm], atol=1e-5, rtol=1e-5)
    f2 = f.copy()
    f2[:, -1] = 99.0  # garbage in an inactive slot changes nothing
    torch.testing.assert_close(model(torch.tensor(f2), torch.tensor(m)), out, atol=1e-5, rtol=1e-5)


def _rotate_scene(f: np.ndarray, a: float) -> np.ndarray:
    """The same scene with the ego frame turned by -a: every position, velocity and goal direction rotates by a."""
    c, s = np.cos(a), np.sin(a)
    out = f.copy()
    cols = [(5 * h, 5 * h + 1) for h in range(5)] + [(5 * h + 2, 5 * h + 3) for h in range(5)] + [(27, 28)]
    for x, y in cols:
        out[..., x], out[..., y] = c * f[..., x] - s * f[..., y], s * f[..., x] + c * f[..., y]
    return out


def test_local_frame_model_is_rotation_equivariant():
    """In pedestrian frames the prediction turns with the scene (robot standing still, so nothing is tied to
    the ego axes); the ego-frame model has no such structure."""
    f, m = _batch(B=4, N=5, seed=3)
    f[..., 25:27] = 0.0  # robot v and omega: a still robot
    f[..., 4:25:5] = 1.0  # all history observed
    f[..., 22:24] = np.where(np.abs(f[..., 22:24]) < 0.2, 0.5, f[..., 22:24])  # moving: a defined own frame
    f[:, -1] = 0.0
    a = 0.9
    rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]], np.float32)
    for arch, equivariant in (("local_edges", True), ("ego", False)):
        model = _model(**ARCHS[arch])
        for p in model.decoder[-1].parameters():
            torch.nn.init.normal_(p, std=0.1)
        out = model(torch.tensor(f), torch.tensor(m)).detach().numpy()
        out_r = model(torch.tensor(_rotate_scene(f, a)), torch.tensor(m)).detach().numpy()
        close = np.allclose(out_r, out @ rot.T, atol=1e-4)
        assert close == equivariant, arch


def test_masked_loss_and_metrics_ignore_missing_targets():
    pred = torch.zeros(1, 2, 3, 2)
    target = torch.zeros(1, 2, 3, 2)
    target[0, 0, :, 0] = 3.0  # 3 m error on slot 0
    target[0, 1] = 100.0  # slot 1 has no targets: must not count
    tmask = torch.tensor([[[1.0, 1.0, 1.0], [0.0, 0.0, 0.0]]])
    assert float(masked_smooth_l1(pred, target, tmask, beta=1.0)) == pytest.approx(2.5)
    assert float(masked_loss("euclidean", pred, target, tmask, 1.0)) == pytest.approx(3.0)  # = the ADE
    e, n, fe, fn = masked_ade_fde(pred, target, tmask)
    assert (float(e / n), float(fe / fn)) == (3.0, 3.0)


def _save(tmp_path, model, timebase=PLANNER_TIMEBASE, name="m.pt", **overrides):
    payload = make_checkpoint(
        model, timebase, "robot", {"id": "d", "sha256": "x", "max_agents": 4}, {"val_ade": 1.0}, 3
    )
    payload.update(overrides)
    save_checkpoint(payload, tmp_path / name)
    return tmp_path / name


@pytest.mark.parametrize("arch", ARCHS)
def test_checkpoint_round_trip(tmp_path, arch):
    model = _model(**ARCHS[arch])
    for p in model.decoder[-1].parameters():
        torch.nn.init.normal_(p, std=0.1)
    f, m = _batch()
    expected = TorchPredictor(model, PLANNER_TIMEBASE, "m").predict(f, m)
    loaded = load_predictor(_save(tmp_path, model), expect_timebase=PLANNER_TIMEBASE)
    np.testing.assert_allclose(loaded.predict(f, m), expected, atol=1e-6)
    assert loaded.max_agents == 4 and loaded.timebase == PLANNER_TIMEBASE


def test_checkpoint_mismatches_are_clear_errors(tmp_path):
    path = _save(tmp_path, _model())
    with pytest.raises(ConfigError, match="time base mismatch"):
        load_predictor(path, expect_timebase=ETHUCY_TIMEBASE)
    with pytest.raises(ConfigError, match="feature schema"):
        load_predictor(
            _save(
                tmp_path, _model(), name="f.pt", feature_schema={"names": ["x"], "frame_convention": "robot"}
            )
        )
    with pytest.raises(ConfigError, match="weights do not fit"):
        bad = _model()
        load_predictor(_save(tmp_path, bad, name="w.pt", model_config={**bad.config.to_dict(), "hidden": 8}))
    (tmp_path / "junk.pt").write_bytes(b"not a checkpoint")
    with pytest.raises(ConfigError, match="junk.pt"):
        load_predictor(tmp_path / "junk.pt")
    with pytest.raises(ConfigError, match="expects features"):
        load_predictor(path).predict(np.zeros((1, 2, 3), np.float32), np.ones((1, 2), np.float32))


def test_cv_step_uses_current_velocity_feature():
    f, m = np.zeros((1, 1, feature_dim(5)), np.float32), np.ones((1, 1), np.float32)
    f[0, 0, current_index(5, "vx")] = 1.0
    out = ConstantVelocityPredictor(PLANNER_TIMEBASE).predict(f, m)
    np.testing.assert_allclose(out[0, 0, :, 0], 0.2 * np.arange(1, 13), atol=1e-6)
