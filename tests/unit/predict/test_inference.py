"""The NumPy forward (one planner decision) computes what the torch model computes, for every architecture."""

import numpy as np
import pytest
import torch

from foresight.core.predict.features import feature_dim
from foresight.core.predict.nn.checkpoint import TorchPredictor
from foresight.core.predict.nn.inference import ModelForward
from foresight.core.predict.nn.model import ModelConfig, build_model
from foresight.core.predict.timebase import PLANNER_TIMEBASE

ARCHS = {
    "ego": {},  # checkpoints before edges and pedestrian frames
    "local_edges": {"edge_dim": 8, "local_frame": True},
    "local_edges_sigma": {"edge_dim": 8, "local_frame": True, "sigma_head": True},
    "ensemble_sigma": {"edge_dim": 8, "local_frame": True, "sigma_head": True, "members": 3},
    "no_blocks": {"edge_dim": 8, "local_frame": True, "blocks": 0},
}


def _trained_like(arch: dict, seed: int = 0) -> torch.nn.Module:
    """A model with every weight drawn at random (an untrained one starts exactly at constant velocity)."""
    torch.manual_seed(seed)
    cfg = {"hidden": 16, "blocks": 2, **arch}
    model = build_model(ModelConfig(5, 12, 0.2, **cfg)).eval()
    with torch.no_grad():
        for p in model.parameters():
            p.normal_(0.0, 0.3)
    return model


def _sample(n: int = 6, seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    f = rng.normal(size=(n, feature_dim(5))).astype(np.float32)
    f[1, 5 * 4 + 2 : 5 * 4 + 4] = 0.0  # one pedestrian standing (the ego-x frame)
    m = np.ones(n, np.float32)
    m[-2:] = 0  # inactive slots
    f[-2:] = 0
    return f, m


@pytest.mark.parametrize("arch", ARCHS)
def test_numpy_forward_equals_the_torch_model(arch):
    model = _trained_like(ARCHS[arch])
    f, m = _sample()
    fast = ModelForward(model)
    with torch.no_grad():
        want = model(torch.tensor(f[None]), torch.tensor(m[None]))[0].numpy()
        np.testing.assert_allclose(fast.positions(f, m), want, rtol=1e-4, atol=1e-4)
        assert np.abs(want).max() > 1.0  # not a trivially small output
        if ARCHS[arch].get("sigma_head"):
            pos, sigma = model.forward_dist(torch.tensor(f[None]), torch.tensor(m[None]))
            got_pos, got_sigma = fast.distribution(f, m)
            np.testing.assert_allclose(got_pos, pos[0].numpy(), rtol=1e-4, atol=1e-4)
            np.testing.assert_allclose(got_sigma, sigma[0].numpy(), rtol=1e-4, atol=1e-6)
        else:
            with pytest.raises(ValueError, match="no sigma head"):
                fast.distribution(f, m)


def test_predictor_runs_one_sample_in_numpy_and_batches_in_torch():
    model = _trained_like(ARCHS["local_edges_sigma"])
    p = TorchPredictor(model, PLANNER_TIMEBASE, "m")
    f, m = _sample()
    batch_f, batch_m = np.stack([f, f[::-1]]), np.stack([m, m[::-1]])
    both = p.predict(batch_f, batch_m)  # torch
    one = p.predict(f[None], m[None])  # numpy
    np.testing.assert_allclose(one[0], both[0], rtol=1e-4, atol=1e-4)
    pos, sigma = p.predict_dist(f[None], m[None])
    assert pos.shape == (1, len(f), 12, 2) and sigma.shape == (1, len(f), 12)
    assert not one[0, -2:].any()  # inactive slots stay zero
