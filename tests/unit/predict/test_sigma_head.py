"""The model's own forecast spread (sigma head): starts at the calibrated envelope, learns the error's size by
its Gaussian NLL without touching the mean, reaches the planner's Forecast, and old checkpoints keep the envelope."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from foresight.core.predict.forecaster import LearnedForecaster
from foresight.core.predict.nn.checkpoint import load_predictor, read_checkpoint, save_checkpoint
from foresight.core.predict.nn.model import ModelConfig, build_model, masked_gaussian_nll
from foresight.core.predict.timebase import PLANNER_TIMEBASE as TB
from foresight.core.predict.uncertainty import LEARNED_SIGMA
from foresight.core.runtime.context import StageContext
from foresight.core.training.config import TrainConfig
from foresight.core.training.train import run_train
from tests.unit.predict.helpers import make_obs

FAST = dict(epochs=3, batch_size=64, hidden=16, blocks=1, lr=3e-3, threads=1)


def _config(**kw) -> ModelConfig:
    return ModelConfig(TB.history, TB.horizon, TB.dt, hidden=16, blocks=1, edge_dim=8, local_frame=True, **kw)


def test_untrained_head_is_the_envelope_and_leaves_the_mean_alone():
    torch.manual_seed(0)
    model = build_model(_config(sigma_head=True)).eval()
    x = torch.randn(2, 6, 5 * TB.history + 5)
    mask = torch.ones(2, 6)
    pos, sigma = model.forward_dist(x, mask)
    torch.testing.assert_close(pos, model(x, mask))
    np.testing.assert_allclose(
        sigma.detach().numpy(), np.broadcast_to(LEARNED_SIGMA(TB.times), (2, 6, TB.horizon)), rtol=1e-5
    )
    with torch.inference_mode():  # one decision: the traced path gives the same numbers
        p1, s1 = model.forward_dist(x[:1], mask[:1])
    torch.testing.assert_close(p1, pos[:1].detach())
    torch.testing.assert_close(s1, sigma[:1].detach())


def test_a_model_without_head_refuses_to_make_up_a_spread():
    with pytest.raises(ValueError, match="no sigma head"):
        build_model(_config()).forward_dist(torch.zeros(1, 2, 5 * TB.history + 5), torch.ones(1, 2))


def test_nll_is_lowest_at_the_errors_own_spread():
    """Per-axis N(0, 0.3^2) errors: the NLL over sigma is minimal at 0.3, larger 20 % either side; masked points
    do not count."""
    rng = np.random.default_rng(0)
    target = torch.from_numpy(rng.normal(0.0, 0.3, size=(1, 4000, TB.horizon, 2)))
    pred = torch.zeros_like(target)
    mask = torch.ones(target.shape[:-1], dtype=target.dtype)
    mask[:, :100] = 0.0
    target[:, :100] = 50.0  # masked outliers
    nll = [
        float(masked_gaussian_nll(pred, torch.full(mask.shape, s, dtype=target.dtype), target, mask))
        for s in (0.24, 0.3, 0.36)
    ]
    assert nll[1] < nll[0] and nll[1] < nll[2]


def test_training_fits_a_calibrated_spread_and_the_forecast_carries_it(tmp_path, curving_dataset):
    res = run_train(
        TrainConfig(dataset=str(curving_dataset), sigma_head=True, **FAST), StageContext(workdir=tmp_path)
    )
    history = json.loads((tmp_path / "training_summary.json").read_text())["history"]
    assert res.val_ade < res.cv_val_ade
    # the spread learns the errors' size: the held-out NLL falls from the envelope's (epoch 1 is near it), and
    # coverage moves from too little (the envelope is fitted to slower errors than these arcs') towards a
    # Gaussian's 39 % / 86 %
    assert history[-1]["val_nll"] < history[0]["val_nll"] - 1.0
    assert history[0]["val_cover2"] < 0.7 < history[-1]["val_cover2"] and history[-1]["val_cover1"] > 0.3
    predictor = load_predictor(tmp_path / "model.pt")
    assert predictor.has_sigma
    f = LearnedForecaster(predictor)
    for k in range(5):
        fc = f.update(make_obs(k, (0.0, 0.0, 0.0), [1, 2], [[0.2 * k, 0.0], [3.0, 3.0 - 0.1 * k]]))
    assert fc.sigma.shape == (2, TB.horizon) and np.all(fc.sigma >= 0.02)
    assert np.all(np.diff(fc.sigma, axis=1) >= 0)  # the spread never shrinks with the forecast's age
    assert not np.allclose(
        fc.sigma, np.tile(LEARNED_SIGMA(fc.times), (2, 1))
    )  # the model's, not the envelope
    ckpt = read_checkpoint(tmp_path / "model.pt")
    assert ckpt["model_config"]["sigma_head"] is True and "val_cover1" in ckpt["metrics"]


def test_checkpoint_without_the_flag_loads_with_the_envelope(tmp_path, curving_dataset):
    """Checkpoints written before the sigma head have no ``sigma_head`` key: they load, and forecast the envelope."""
    run_train(
        TrainConfig(dataset=str(curving_dataset), **{**FAST, "epochs": 1}), StageContext(workdir=tmp_path)
    )
    ckpt = read_checkpoint(tmp_path / "model.pt")
    del ckpt["model_config"]["sigma_head"]
    save_checkpoint(ckpt, tmp_path / "old.pt")
    predictor = load_predictor(tmp_path / "old.pt")
    assert not predictor.has_sigma
    f = LearnedForecaster(predictor)
    for k in range(3):
        fc = f.update(make_obs(k, (0.0, 0.0, 0.0), [1], [[0.2 * k, 0.0]]))
    np.testing.assert_allclose(fc.sigma, LEARNED_SIGMA(fc.times)[None])


def test_the_shipped_realistic_candidate_predicts_its_spread():
    """model/registry.yaml's predictor-sim-realistic: checksum as listed, a sigma head, a spread growing with t."""
    from pathlib import Path

    import yaml

    repo = Path(__file__).resolve().parents[3]
    entry = next(
        m
        for m in yaml.safe_load((repo / "model/registry.yaml").read_text())["models"]
        if m["id"] == "predictor-sim-realistic"
    )
    predictor = load_predictor(repo / entry["path"], expect_timebase=TB, expect_sha256=entry["sha256"])
    assert predictor.has_sigma and entry["status"] != "default"
    f = LearnedForecaster(predictor)
    for k in range(5):
        fc = f.update(make_obs(k, (0.0, 0.0, 0.0), [1, 2], [[2.0 + 0.25 * k, 0.0], [3.0, 3.0 - 0.25 * k]]))
    assert np.all(np.diff(fc.sigma, axis=1) >= 0) and np.all(fc.sigma >= 0.02)
    assert np.all(
        fc.sigma <= LEARNED_SIGMA(fc.times) * np.exp(3.0) + 1e-6
    )  # the head's bound around the envelope
