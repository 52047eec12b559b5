"""The network's K modes with weights (``core.predict.nn.modes``): shapes and weights, mode 0 trained exactly as
without modes, winner-takes-all modes that find both branches of a bimodal future, and the forecast that carries
them to predict-eval and the planner."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from foresight.core.errors import ConfigError
from foresight.core.predict import forecast_metrics
from foresight.core.predict.features import feature_dim
from foresight.core.predict.forecast import check_forecast
from foresight.core.predict.forecaster import LearnedForecaster
from foresight.core.predict.nn.checkpoint import load_predictor, make_checkpoint, save_checkpoint
from foresight.core.predict.nn.model import ModelConfig, TrajectoryModel, build_model, weighted_modes
from foresight.core.predict.nn.modes import first_on_top
from foresight.core.predict.timebase import PLANNER_TIMEBASE as TB
from foresight.core.runtime.context import StageContext
from foresight.core.training.config import TrainConfig
from foresight.core.training.predict_eval import PredictEvalConfig, run_predict_eval
from foresight.core.training.train import train_epoch
from tests.unit.predict.helpers import make_obs

K = 4


def _config(**kw) -> ModelConfig:
    return ModelConfig(TB.history, TB.horizon, TB.dt, hidden=16, blocks=1, edge_dim=8, local_frame=True, **kw)


def _bimodal(n: int, seed: int) -> dict[str, torch.Tensor]:
    """n samples of one pedestrian walking along x at 1 m/s (the same past every time) that then curves left or
    right (a fair coin, 0.8 m/s^2 sideways): no forecast from the past can tell which; a second pedestrian stands far
    off. Ego-frame features as ``core.predict.features`` lays them out."""
    rng = np.random.default_rng(seed)
    H, T, dt = TB.history, TB.horizon, TB.dt
    state = np.zeros((n, 2, feature_dim(H)), np.float32)
    steps = state[:, :, : 5 * H].reshape(n, 2, H, 5)
    steps[:, 0, :, 0] = (np.arange(H) - (H - 1)) * dt  # px: at the origin now
    steps[:, 0, :, 2] = 1.0  # vx
    steps[:, 1, :, 0], steps[:, 1, :, 1] = 6.0, 6.0  # standing
    steps[..., 4] = 1.0
    state[:, :, : 5 * H] = steps.reshape(n, 2, 5 * H)
    t = np.arange(1, T + 1) * dt
    side = rng.choice([-1.0, 1.0], size=n)
    target = np.zeros((n, 2, T, 2), np.float32)
    target[:, 0, :, 0] = t
    target[:, 0, :, 1] = side[:, None] * 0.4 * t**2
    target[:, 1] = 6.0
    return {
        "state": torch.from_numpy(state),
        "mask": torch.ones(n, 2),
        "target": torch.from_numpy(target),
        "target_mask": torch.ones(n, 2, T),
    }


def _train(modes: int, data: dict[str, torch.Tensor], epochs: int) -> TrajectoryModel:
    config = TrainConfig(
        dataset="toy", epochs=epochs, batch_size=64, lr=3e-3, loss="euclidean", modes=modes, threads=1
    )
    torch.manual_seed(0)
    model = TrajectoryModel(_config(modes=modes))
    opt = torch.optim.AdamW(model.parameters(), lr=config.lr, weight_decay=config.weight_decay)
    for epoch in range(1, epochs + 1):
        train_epoch(model, opt, data, config, epoch)
    return model.eval()


@pytest.mark.parametrize("members", [1, 3])
def test_modes_and_weights_have_the_contract_shapes(members):
    torch.manual_seed(0)
    model = build_model(_config(modes=K, members=members)).eval()
    x, mask = torch.randn(3, 5, feature_dim(TB.history)), torch.ones(3, 5)
    with torch.inference_mode():
        modes, weights = weighted_modes(model, x, mask)
        assert modes.shape == (3, 5, K, TB.horizon, 2) and weights.shape == (3, 5, K)
        torch.testing.assert_close(weights.sum(-1), torch.ones(3, 5))
        assert torch.all(weights >= 0)
        torch.testing.assert_close(modes[:, :, 0], model(x, mask))  # mode 0 is the deterministic forecast
        assert (modes[:, :, 1:] - modes[:, :, :1]).abs().amax() > 1e-3  # the extra modes start apart


def test_a_model_without_modes_refuses_to_make_them_up():
    with pytest.raises(ValueError, match="no modes"):
        build_model(_config()).forward_modes(torch.zeros(1, 2, feature_dim(TB.history)), torch.ones(1, 2))


def test_mode_zero_trains_exactly_as_without_modes():
    """The head reads detached inputs and its gradients are clipped apart: for the same seed and batches the network
    ends with the same weights, bit for bit, so adding modes cannot change best-of-1 of mode 0."""
    data = _bimodal(256, 1)
    plain, multi = _train(1, data, 2), _train(K, data, 2)
    shared = plain.state_dict()
    for name, value in multi.state_dict().items():
        if not name.startswith("mode_head."):
            assert torch.equal(value, shared[name]), name
    with torch.inference_mode():
        assert torch.equal(plain(data["state"], data["mask"]), multi(data["state"], data["mask"]))


def test_winner_takes_all_modes_find_both_branches_of_a_bimodal_future():
    """Left or right at random after the same past: mode 0 can only learn the middle; the WTA modes learn both
    branches, so minADE over the modes falls far below best-of-1, and the weights split between the branches."""
    train, test = _bimodal(512, 2), _bimodal(256, 3)
    model = _train(K, train, 25)
    with torch.inference_mode():
        modes, weights = weighted_modes(model, test["state"], test["mask"])
    r = forecast_metrics.score(
        modes[:, :1].numpy(),
        weights[:, :1].numpy(),
        test["target"][:, :1].numpy(),
        test["target_mask"][:, :1].numpy(),
    )
    first = forecast_metrics.score(
        modes[:, :1, :1].numpy(),
        np.ones((256, 1, 1)),
        test["target"][:, :1].numpy(),
        test["target_mask"][:, :1].numpy(),
    )
    side = 0.4 * TB.times**2  # the branches' lateral offset: what a forecast of the middle misses
    assert first["ade"] > 0.6 * side.mean()
    assert r["min_ade"] < 0.35 * first["ade"]
    finals = modes[:, 0, :, -1, 1]  # each mode's final lateral position
    assert finals.max() > 0.5 * side[-1] and finals.min() < -0.5 * side[-1]  # a mode on each branch
    w = weights[:, 0]
    assert float(w[finals > 0.3 * side[-1]].sum() / w.sum()) > 0.25  # both branches carry weight
    assert float(w[finals < -0.3 * side[-1]].sum() / w.sum()) > 0.25


def test_the_checkpoint_forecast_carries_the_modes(tmp_path):
    """A checkpoint records its mode count; predict-eval and the planner's forecaster both get all K modes with
    weights summing to 1, mode 0 being the predictor's own deterministic forecast."""
    torch.manual_seed(0)
    model = TrajectoryModel(_config(modes=K))
    save_checkpoint(make_checkpoint(model, TB, "robot", {"id": "toy"}, {}, 1), tmp_path / "m.pt")
    predictor = load_predictor(tmp_path / "m.pt")
    assert predictor.n_modes == K and predictor.model.config.modes == K
    data = _bimodal(5, 0)
    modes, weights = predictor.predict_modes(data["state"].numpy(), data["mask"].numpy())
    assert modes.shape == (5, 2, K, TB.horizon, 2)
    np.testing.assert_allclose(weights.sum(-1), 1.0, atol=1e-9)
    np.testing.assert_array_equal(
        modes[:, :, 0], predictor.predict(data["state"].numpy(), data["mask"].numpy())
    )
    f = LearnedForecaster(predictor)
    for k in range(TB.history):
        fc = f.update(make_obs(k, (0.0, 0.0, 0.0), [1, 2], [[0.2 * k, 0.0], [3.0, 3.0 - 0.1 * k]]))
    check_forecast(fc, "modes", ped_ids=np.array([1, 2]), min_modes=K, timebase=TB)
    assert fc.n_modes == K and not np.allclose(fc.modes[:, 1], fc.modes[:, 0])
    assert np.all(fc.top == 0)  # mode_top "first": the deterministic trajectory is the most likely


def test_mode_zero_is_ranked_first_only_by_the_rule_that_says_so(tmp_path):
    """mode_top "first" raises mode 0's weight to the largest of the others' (their ratios kept); "weight" gives the
    weight head's probabilities unchanged, whose top mode may be any."""
    w = np.array([[0.1, 0.6, 0.3], [0.5, 0.2, 0.3]])
    np.testing.assert_allclose(first_on_top(w), [np.array([0.6, 0.6, 0.3]) / 1.5, [0.5, 0.2, 0.3]])
    torch.manual_seed(0)
    model = TrajectoryModel(_config(modes=K, mode_top="weight"))
    save_checkpoint(make_checkpoint(model, TB, "robot", {"id": "toy"}, {}, 1), tmp_path / "w.pt")
    data = _bimodal(64, 0)
    _, raw = load_predictor(tmp_path / "w.pt").predict_modes(data["state"].numpy(), data["mask"].numpy())
    with torch.inference_mode():
        head = weighted_modes(model.eval(), data["state"], data["mask"])[1].numpy()
    np.testing.assert_allclose(raw, head, atol=1e-6)
    payload = make_checkpoint(model, TB, "robot", {"id": "toy"}, {}, 1)
    payload["model_config"]["mode_top"] = "likeliest"
    save_checkpoint(payload, tmp_path / "bad.pt")
    with pytest.raises(ConfigError, match="mode_top must be one of first, weight"):
        load_predictor(tmp_path / "bad.pt")


@pytest.mark.parametrize("modes", [1, K])
def test_predict_eval_labels_the_modes_it_had(tmp_path, curving_dataset, modes):
    """predict-eval on a checkpoint: K = 20 asked; minADE is over the modes the model has (labelled with that
    count), best-of-1 is the largest weight's mode and mode 0's numbers come beside it. A checkpoint from before
    modes (no ``modes`` key) loads as one mode."""
    torch.manual_seed(0)
    payload = make_checkpoint(TrajectoryModel(_config(modes=modes)), TB, "robot", {"id": "toy"}, {}, 1)
    if modes == 1:
        del payload["model_config"]["modes"]
    save_checkpoint(payload, tmp_path / "m.pt")
    config = PredictEvalConfig(model=str(tmp_path / "m.pt"), dataset=str(curving_dataset))
    result = run_predict_eval(config, StageContext(workdir=tmp_path / "work", local_files=True))
    (fold,) = result.folds.values()
    assert fold.modes == modes and fold.best_of == modes and fold.best_of_asked == 20
    if modes == 1:
        assert fold.min_ade == pytest.approx(fold.ade) and fold.first_ade is None
    else:
        assert fold.min_ade < fold.first_ade and fold.first_ade is not None
        assert fold.ade == pytest.approx(fold.first_ade)  # mode 0 ranked most likely (mode_top "first")
    assert result.average.best_of == modes
