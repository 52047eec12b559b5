import json
from pathlib import Path

import pytest
import torch

from foresight.core.errors import ConfigError
from foresight.core.predict.nn.checkpoint import read_checkpoint
from foresight.core.predict.nn.selection import Selection
from foresight.core.runtime.context import StageContext
from foresight.core.training.config import TrainConfig, load_config
from foresight.core.training.train import run_train

FAST = dict(epochs=4, batch_size=64, hidden=16, blocks=1, lr=3e-3, threads=1)


def test_short_training_learns_and_writes_complete_summary(tmp_path, curving_dataset):
    res = run_train(TrainConfig(dataset=str(curving_dataset), **FAST), StageContext(workdir=tmp_path))
    summary = json.loads((tmp_path / "training_summary.json").read_text())
    hist = summary["history"]
    assert len(hist) == 4 and hist[-1]["train_loss"] < hist[0]["train_loss"]
    assert res.val_ade < res.cv_val_ade  # arcs: learnable beyond constant velocity
    for key in (
        "best",
        "selection",
        "quality_gates",
        "dataset_stats",
        "dataset",
        "cv_val",
        "total_runtime_s",
        "code_version",
        "config",
    ):
        assert key in summary
    assert summary["quality_gates"]["checks"]["val_ade_below_cv"] is True
    assert summary["dataset"]["sha256"] and summary["selection_mode"] == "val_loss"
    ckpt = read_checkpoint(tmp_path / "model.pt")
    assert ckpt["epoch"] == res.best_epoch and ckpt["dataset"]["source"] == "sim"


def test_resume_after_interruption_matches_uninterrupted(tmp_path, curving_dataset):
    full = tmp_path / "full"
    part = tmp_path / "part"
    full.mkdir(), part.mkdir()
    run_train(TrainConfig(dataset=str(curving_dataset), **FAST), StageContext(workdir=full))
    run_train(TrainConfig(dataset=str(curving_dataset), **{**FAST, "epochs": 2}), StageContext(workdir=part))
    logs = []
    run_train(TrainConfig(dataset=str(curving_dataset), **FAST), StageContext(workdir=part, log=logs.append))
    assert logs == ["resumed after epoch 2"]
    a, b = read_checkpoint(full / "checkpoints/last.pt"), read_checkpoint(part / "checkpoints/last.pt")
    for k in a["model"]:
        torch.testing.assert_close(a["model"][k], b["model"][k])
    assert len(b["train_state"]["history"]) == 4


def test_proxy_callback_drives_selection(tmp_path, curving_dataset):
    calls = []

    def proxy(path):
        calls.append(path.name)
        return {"success": 0.5 if "0002" in path.name else 0.2, "clearance": 0.4}

    res = run_train(
        TrainConfig(dataset=str(curving_dataset), proxy_every=2, **FAST),
        StageContext(workdir=tmp_path),
        proxy=proxy,
    )
    assert calls == ["epoch_0002.pt", "epoch_0004.pt"]
    assert res.selection_mode == "proxy" and res.best_epoch == 2


def test_selection_order():
    s = Selection(proxy_enabled=True)
    assert s.offer({"epoch": 1, "val_loss": 1.0}) and s.mode == "val_loss_fallback"
    assert s.offer({"epoch": 2, "val_loss": 2.0, "proxy": {"success": 0.1, "clearance": 0.3}})
    assert not s.offer({"epoch": 3, "val_loss": 0.1})  # val loss no longer replaces a proxy pick
    assert s.offer({"epoch": 4, "val_loss": 3.0, "proxy": {"success": 0.1, "clearance": 0.5}})
    assert s.offer({"epoch": 5, "val_loss": 2.0, "proxy": {"success": 0.1, "clearance": 0.5}})
    assert not s.offer({"epoch": 6, "val_loss": 0.5, "proxy": {"success": 0.0, "clearance": 9.0}})
    assert s.best["epoch"] == 5


def test_gate_failure_is_reported(tmp_path, curving_dataset):
    cfg = TrainConfig(
        dataset=str(curving_dataset),
        **{**FAST, "epochs": 1},
        gates={"max_val_ade": 0.001},
        augment_mirror=True,
    )
    res = run_train(cfg, StageContext(workdir=tmp_path))
    assert not res.gates_passed
    assert (
        json.loads((tmp_path / "training_summary.json").read_text())["quality_gates"]["checks"][
            "val_ade_below_limit"
        ]
        is False
    )


def test_bad_config_file_names_field(tmp_path):
    (tmp_path / "t.yaml").write_text("train:\n  dataset: x.npz\n  epochs: -1\n")
    with pytest.raises(ConfigError, match=r"t.yaml.*epochs"):
        load_config(tmp_path / "t.yaml", TrainConfig, key="train")


def test_proxy_wired_to_the_evaluation_engine(tmp_path, curving_dataset):
    from foresight.core.runtime.refs import BUILTIN_CONFIG_ROOT

    cfg = TrainConfig(
        dataset=str(curving_dataset),
        proxy_every=1,
        proxy={"scenarios": ["crossing_low"], "seeds_per_scenario": 1, "max_steps": 20},
        **{**FAST, "epochs": 1},
    )
    res = run_train(cfg, StageContext(workdir=tmp_path, resolve_bundle=lambda ident: BUILTIN_CONFIG_ROOT))
    summary = json.loads((tmp_path / "training_summary.json").read_text())
    proxy = summary["selection"]["proxy_history"][0]
    assert res.selection_mode == "proxy" and proxy["episodes"] == 1.0 and 0.0 <= proxy["success"] <= 1.0
    # the same planner with constant velocity on the same episodes, once, paired with every candidate
    assert (tmp_path / "proxy_eval" / "cv" / "episodes.jsonl").is_file()
    assert (
        proxy["vs_cv_delta"] == pytest.approx(proxy["success"] - proxy["cv_success"])
        and 0 < proxy["vs_cv_p"] <= 1
    )
    assert summary["quality_gates"]["closed_loop"]["cv_success"] == proxy["cv_success"]


def test_closed_loop_training_gate_against_constant_velocity(tmp_path, curving_dataset):
    def proxy(delta):
        return lambda path: {
            "success": 0.5,
            "clearance": 0.4,
            "cv_success": 0.5 - delta,
            "vs_cv_delta": delta,
            "vs_cv_p": 0.01,
        }

    cfg = TrainConfig(
        dataset=str(curving_dataset),
        proxy_every=1,
        **{**FAST, "epochs": 1},
        gates={"require_proxy_not_below_cv": True, "require_beat_cv": False},
    )
    worse = run_train(cfg, StageContext(workdir=tmp_path / "worse"), proxy=proxy(-0.2))
    summary = json.loads((tmp_path / "worse" / "training_summary.json").read_text())["quality_gates"]
    assert not worse.gates_passed and summary["checks"]["proxy_success_not_below_cv"] is False
    assert summary["closed_loop"] == {
        "success": 0.5,
        "clearance": 0.4,
        "episodes": None,
        "cv_success": 0.7,
        "vs_cv_delta": -0.2,
        "vs_cv_p": 0.01,
    }
    assert run_train(cfg, StageContext(workdir=tmp_path / "better"), proxy=proxy(0.1)).gates_passed
    no_proxy = run_train(cfg.model_copy(update={"proxy_every": 0}), StageContext(workdir=tmp_path / "none"))
    assert not no_proxy.gates_passed  # required but never measured: the gate fails


def test_resume_refuses_another_model_config(tmp_path, curving_dataset):
    run_train(
        TrainConfig(dataset=str(curving_dataset), **{**FAST, "epochs": 1}), StageContext(workdir=tmp_path)
    )
    with pytest.raises(ConfigError, match="cannot resume"):
        run_train(
            TrainConfig(dataset=str(curving_dataset), **{**FAST, "epochs": 2, "hidden": 8}),
            StageContext(workdir=tmp_path),
        )


def test_resume_accepts_a_checkpoint_written_before_newer_model_fields(tmp_path, curving_dataset):
    """A run interrupted before a model field existed (here ``mirror_average``) resumes: absent means its default."""
    from foresight.core.predict.nn.checkpoint import save_checkpoint

    run_train(
        TrainConfig(dataset=str(curving_dataset), **{**FAST, "epochs": 1}), StageContext(workdir=tmp_path)
    )
    last = tmp_path / "checkpoints" / "last.pt"
    state = read_checkpoint(last)
    del state["model_config"]["mirror_average"]
    save_checkpoint(state, last)
    res = run_train(
        TrainConfig(dataset=str(curving_dataset), **{**FAST, "epochs": 2}), StageContext(workdir=tmp_path)
    )
    assert [h["epoch"] for h in json.loads(Path(res.summary).read_text())["history"]] == [1, 2]


def test_cosine_schedule_is_a_function_of_the_epoch():
    from foresight.core.training.train import epoch_lr

    cfg = TrainConfig(dataset="d.npz", epochs=4, lr=1.0, lr_schedule="cosine")
    assert [round(epoch_lr(cfg, e), 3) for e in (1, 2, 3, 4)] == [1.0, 0.854, 0.5, 0.146]
    assert epoch_lr(TrainConfig(dataset="d.npz", lr=0.3), 7) == 0.3


def test_ensemble_averages_its_members(tmp_path, curving_dataset):
    """Members are ordinary runs with seeds seed, seed + 1; the checkpoint predicts their mean."""
    import numpy as np

    from foresight.core.predict.dataset import load_dataset
    from foresight.core.predict.nn.checkpoint import load_predictor

    res = run_train(
        TrainConfig(dataset=str(curving_dataset), ensemble=2, **{**FAST, "epochs": 2}),
        StageContext(workdir=tmp_path),
    )
    members = [load_predictor(tmp_path / "members" / str(k) / "model.pt") for k in range(2)]
    ensemble = load_predictor(tmp_path / "model.pt")
    assert ensemble.model.config.members == 2
    ds = load_dataset(curving_dataset)
    x, m = ds.state[:16], ds.mask[:16]
    a, b = (p.predict(x, m) for p in members)
    assert not np.allclose(a, b)  # different seeds, different members
    np.testing.assert_allclose(ensemble.predict(x, m), (a + b) / 2, atol=1e-5)
    summary = json.loads((tmp_path / "training_summary.json").read_text())
    assert [s["seed"] for s in summary["members"]] == [0, 1] and summary["history"]
    assert summary["best"]["val_ade"] == pytest.approx(res.val_ade) and "ensemble of 2" in res.selection_mode


def test_scale_augmentation_scales_lengths_and_targets_together():
    from foresight.core.predict.features import feature_names, length_channels
    from foresight.core.training.train import _scale

    names = feature_names(2)
    state = torch.ones(3, 2, len(names))
    b = _scale(
        {"state": state, "target": torch.ones(3, 2, 4, 2), "mask": torch.ones(3, 2)},
        torch.from_numpy(length_channels(2)),
        (0.5, 2.0),
        torch.Generator().manual_seed(0),
    )
    f = b["target"][:, 0, 0, 0]
    assert ((f >= 0.5) & (f <= 2.0)).all() and not torch.allclose(f, f[0].expand(3))
    row = dict(zip(names, b["state"][0, 0].tolist(), strict=True))
    assert row["px[0]"] == pytest.approx(float(f[0])) and row["vy[-1]"] == pytest.approx(float(f[0]))
    assert row["valid[0]"] == 1.0 and row["goal_ux"] == 1.0 and row["ego_w"] == 1.0
    with pytest.raises(ValueError, match="augment_scale"):
        TrainConfig(dataset="d.npz", augment_scale=(2.0, 1.0))


def test_jitter_augmentation_moves_past_positions_and_recomputes_velocities():
    """Noise on past positions only (the current one is the frame's origin), each velocity the features' own
    difference of the noisy positions, invalid steps and the ego channels untouched; no noise = the same rows."""
    import numpy as np

    from foresight.core.predict.features import Window, extract_features
    from foresight.core.predict.timebase import TimeBase
    from foresight.core.training.train import _jitter

    tb = TimeBase(dt=0.4, history=4, horizon=3)
    hist = np.array(
        [[[0.0, 0.0], [0.5, 0.1], [1.0, 0.1], [1.6, 0.2]], [[3.0, 1.0], [3.0, 1.4], [3.1, 1.8], [3.1, 2.2]]]
    )
    valid = np.array([[True, True, True, True], [False, True, True, True]])
    f = extract_features(
        Window(np.array([1.6, 0.2, 0.1]), np.zeros(2), None, np.array([1, 2]), hist, valid), tb, 3
    )
    state = torch.from_numpy(np.repeat(f.features[None], 5, axis=0))
    same = _jitter({"state": state}, 0.0, 4, 0.4, torch.Generator().manual_seed(0))["state"]
    assert torch.allclose(same, state, atol=1e-5)
    out = _jitter({"state": state}, 0.1, 4, 0.4, torch.Generator().manual_seed(0))["state"]
    steps, before = out[..., :20].reshape(5, 3, 4, 5), state[..., :20].reshape(5, 3, 4, 5)
    assert torch.equal(steps[:, :, -1, :2], before[:, :, -1, :2])  # current positions kept
    assert (steps[:, :2, :-1, :2] != before[:, :2, :-1, :2]).any() and torch.equal(
        steps[:, 1, 0], before[:, 1, 0]
    )
    assert torch.allclose(
        steps[:, :, 1:, 2:4],
        (steps[:, :, 1:, :2] - steps[:, :, :-1, :2]) / 0.4 * (steps[:, :, 1:, 4:5] * steps[:, :, :-1, 4:5]),
        atol=1e-5,
    )
    assert torch.equal(out[..., 20:], state[..., 20:]) and torch.equal(steps[..., 4], before[..., 4])
    assert torch.equal(out[:, 2], state[:, 2])  # an empty slot stays empty
