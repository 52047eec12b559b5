"""Mirror averaging (``core.predict.nn.mirror``): a checkpoint with ``mirror_average`` forecasts the mean of the network
and its mirror twin, so its forecast of the mirrored scene is exactly the mirror image of its forecast."""

from dataclasses import replace

import numpy as np
import pytest

from foresight.core.predict.features import mirror_signs
from foresight.core.predict.nn.checkpoint import TorchPredictor
from foresight.core.predict.timebase import PLANNER_TIMEBASE
from tests.unit.predict.test_inference import ARCHS, _sample, _trained_like

FLIP = np.array([1.0, -1.0], np.float32)


def _predictors(arch: str) -> tuple[TorchPredictor, TorchPredictor]:
    """The same random network twice: as trained, and with mirror averaging switched on in its config."""
    model = _trained_like(ARCHS[arch])
    twin = _trained_like(ARCHS[arch])
    twin.config = replace(twin.config, mirror_average=True)
    for m in getattr(twin, "members", []):
        m.config = replace(m.config, mirror_average=True)
    return TorchPredictor(model, PLANNER_TIMEBASE, "plain"), TorchPredictor(
        twin, PLANNER_TIMEBASE, "mirrored"
    )


def test_mirror_average_is_symmetric_where_the_network_is_not():
    plain, mirrored = _predictors("local_edges_sigma")
    f, m = _sample()
    signs = mirror_signs(PLANNER_TIMEBASE.history)
    for batch in (1, 2):  # one sample runs the NumPy forward, batches the torch model
        fs, ms = np.repeat(f[None], batch, 0), np.repeat(m[None], batch, 0)
        net, net_of_mirror = plain.predict(fs, ms), plain.predict(fs * signs, ms)
        assert np.abs(net_of_mirror - net * FLIP).max() > 0.05  # the random network is far from symmetric
        got, got_of_mirror = mirrored.predict(fs, ms), mirrored.predict(fs * signs, ms)
        np.testing.assert_allclose(got_of_mirror, got * FLIP, atol=1e-4)
        np.testing.assert_allclose(got, (net + net_of_mirror * FLIP) / 2, atol=1e-4)
        assert not got[:, -2:].any()  # inactive slots stay zero


def test_mirror_mixture_spread_covers_both_twins():
    plain, mirrored = _predictors("ensemble_sigma")
    f, m = _sample()
    signs = mirror_signs(PLANNER_TIMEBASE.history)
    pos, sigma = plain.predict_dist(f[None], m[None])
    pos_m, sigma_m = plain.predict_dist((f * signs)[None], m[None])
    got_pos, got_sigma = mirrored.predict_dist(f[None], m[None])
    np.testing.assert_allclose(got_pos, (pos + pos_m * FLIP) / 2, atol=1e-4)
    gap = ((pos - pos_m * FLIP) / 2) ** 2
    np.testing.assert_allclose(got_sigma**2, (sigma**2 + sigma_m**2) / 2 + gap.mean(-1), rtol=1e-3, atol=1e-6)
    assert (got_sigma >= np.minimum(sigma, sigma_m) - 1e-6).all()


def test_train_config_switch_reaches_the_checkpoint(tmp_path, curving_dataset):
    """``train.mirror_average`` is stored in the (ensemble's) model config, so the saved model forecasts symmetrically."""
    from foresight.core.predict.dataset import load_dataset
    from foresight.core.predict.nn.checkpoint import load_predictor
    from foresight.core.runtime.context import StageContext
    from foresight.core.training.config import TrainConfig
    from foresight.core.training.train import run_train

    cfg = TrainConfig(
        dataset=str(curving_dataset),
        epochs=1,
        batch_size=64,
        hidden=16,
        blocks=1,
        threads=1,
        ensemble=2,
        augment_mirror=True,
        mirror_average=True,
    )
    run_train(cfg, StageContext(workdir=tmp_path))
    model, member = (
        load_predictor(tmp_path / "model.pt"),
        load_predictor(tmp_path / "members" / "0" / "model.pt"),
    )
    assert model.mirror_average and member.mirror_average and model.model.config.members == 2
    ds = load_dataset(curving_dataset)
    x, m = ds.state[:16], ds.mask[:16]
    signs = mirror_signs(ds.meta.timebase.history)
    np.testing.assert_allclose(model.predict(x * signs, m), model.predict(x, m) * FLIP, atol=1e-4)
    assert not TrainConfig(
        dataset="d"
    ).mirror_average  # off by default: the planner's forecasts cost one pass


def test_mirror_average_without_mirrored_training_is_refused(tmp_path):
    """A model trained where walkers keep a side would average with a forecast of a world that does not exist."""
    from foresight.core.errors import ConfigError
    from foresight.core.training.config import TrainConfig, load_config

    path = tmp_path / "train.yaml"
    path.write_text("train:\n  dataset: d\n  mirror_average: true\n")
    with pytest.raises(ConfigError, match="mirror_average needs augment_mirror"):
        load_config(path, TrainConfig, "train")
    assert TrainConfig(dataset="d", augment_mirror=True, mirror_average=True).mirror_average
