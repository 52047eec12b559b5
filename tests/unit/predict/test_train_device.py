"""Training on a chosen device (``TrainConfig.device``): how it resolves, and that CPU training is unchanged.

``train_golden.json`` holds the final weights and the per-epoch curves of a tiny run that uses every draw of
the shuffling generator (order, mirror and scale augmentation; sigma head), recorded with the training code
from before the device switch (torch 2.13.0, CPU, one thread). Its sha256 of the weights matched bit for bit on
the machine that recorded it; the test compares to float rounding so that another CPU's kernels do not fail it,
while a changed random stream (or an extra cast) moves every weight far beyond that. No test here needs or
pretends a GPU. Re-record (only after an intended change to training) with
``python -m tests.unit.predict.test_train_device``.
"""

from __future__ import annotations

import hashlib
import json
import sys
import tempfile
from pathlib import Path

import pytest
import torch

from foresight.core.errors import ConfigError
from foresight.core.predict.features import feature_dim, length_channels, mirror_signs
from foresight.core.predict.nn.checkpoint import load_predictor, read_checkpoint
from foresight.core.predict.nn.device import resolve_device, to_cpu
from foresight.core.predict.nn.model import ModelConfig, TrajectoryModel, masked_gaussian_nll, masked_loss
from foresight.core.predict.timebase import PLANNER_TIMEBASE
from foresight.core.runtime.context import StageContext
from foresight.core.training.config import TrainConfig, load_config
from foresight.core.training.train import _mirror_half, _scale, run_train

FIXTURE = Path(__file__).with_name("train_golden.json")
GOLDEN = dict(
    epochs=2,
    batch_size=64,
    hidden=16,
    blocks=1,
    lr=3e-3,
    threads=1,
    seed=3,
    sigma_head=True,
    augment_mirror=True,
    augment_scale=(0.8, 1.25),
)
CURVE = ("train_loss", "val_loss", "val_ade", "val_fde", "val_nll")
TINY = dict(epochs=1, batch_size=64, hidden=8, blocks=1, threads=1)
HAS_GPU = torch.cuda.is_available()


def _weights_sha256(state: dict[str, torch.Tensor]) -> str:
    digest = hashlib.sha256()
    for name in sorted(state):
        digest.update(name.encode() + state[name].contiguous().numpy().tobytes())
    return digest.hexdigest()


def _record(dataset: Path, workdir: Path, **extra) -> dict:
    """The fixture's content for a run of GOLDEN (plus ``extra`` config) in ``workdir``."""
    run_train(TrainConfig(dataset=str(dataset), **GOLDEN, **extra), StageContext(workdir=workdir))
    state = read_checkpoint(workdir / "checkpoints/last.pt")["model"]
    summary = json.loads((workdir / "training_summary.json").read_text())
    return {
        "config": GOLDEN,
        "torch": torch.__version__.split("+")[0],
        "weights_sha256": _weights_sha256(state),
        "weights": {k: v.flatten().tolist() for k, v in sorted(state.items())},
        "history": [{k: rec[k] for k in ("epoch", *CURVE)} for rec in summary["history"]],
    }


def test_auto_is_cuda_only_where_torch_sees_a_gpu(tmp_path, curving_dataset):
    expected = "cuda" if HAS_GPU else "cpu"  # this machine has none: cpu
    assert TrainConfig(dataset="x").device == "auto" and resolve_device("auto").type == expected
    res = run_train(TrainConfig(dataset=str(curving_dataset), **TINY), StageContext(workdir=tmp_path))
    summary = json.loads((tmp_path / "training_summary.json").read_text())
    assert res.device == summary["device"] == expected and summary["config"]["device"] == "auto"


@pytest.mark.skipif(HAS_GPU, reason="needs a machine without a CUDA GPU")
def test_cuda_without_a_gpu_is_a_config_error_naming_device(tmp_path, curving_dataset):
    with pytest.raises(ConfigError, match="device: cuda.*no CUDA GPU") as err:
        run_train(
            TrainConfig(dataset=str(curving_dataset), device="cuda", **TINY), StageContext(workdir=tmp_path)
        )
    assert err.value.item == "device" and not (tmp_path / "checkpoints").exists()  # failed before training


def test_an_unknown_device_names_the_field(tmp_path):
    (tmp_path / "t.yaml").write_text("train:\n  dataset: x.npz\n  device: gpu\n")
    with pytest.raises(ConfigError, match=r"t.yaml.*device"):
        load_config(tmp_path / "t.yaml", TrainConfig, key="train")


def test_cpu_training_matches_the_run_recorded_before_devices(tmp_path, curving_dataset):
    golden = json.loads(FIXTURE.read_text())
    got = _record(curving_dataset, tmp_path, device="cpu")
    assert got["weights"].keys() == golden["weights"].keys()
    for name, values in golden["weights"].items():
        # float32 kernels differ between CPUs (AVX2 vs AVX-512): two epochs on another Xeon moved some weights
        # by up to 1.7e-4 (the losses by 2e-8); a changed training path moves them by far more
        torch.testing.assert_close(
            torch.tensor(got["weights"][name]),
            torch.tensor(values),
            rtol=1e-2,
            atol=1e-3,
            msg=lambda m, name=name: f"{name}: {m}",
        )
    for rec, ref in zip(got["history"], golden["history"], strict=True):
        assert rec == pytest.approx(ref, rel=1e-5, abs=1e-6)


def test_checkpoints_hold_cpu_tensors_and_load_as_before(tmp_path, curving_dataset):
    cfg = TrainConfig(dataset=str(curving_dataset), device="cpu", sigma_head=True, **TINY)
    run_train(cfg, StageContext(workdir=tmp_path))
    for name in ("model.pt", "checkpoints/last.pt"):  # read without map_location: the devices as saved
        payload = torch.load(tmp_path / name, weights_only=True)
        tensors = [v for v in payload["model"].values()]
        tensors += [v for s in payload.get("optimizer", {}).get("state", {}).values() for v in s.values()]
        assert tensors and all(t.device.type == "cpu" for t in tensors)
    assert load_predictor(tmp_path / "model.pt").has_sigma


def test_to_cpu_keeps_containers_and_cpu_tensors_as_they_are():
    state = torch.nn.Linear(2, 3).state_dict()
    out = to_cpu({"model": state, "groups": [{"lr": 0.1, "params": (0, 1)}], "step": torch.tensor(3.0)})
    assert type(out["model"]) is type(state) and out["model"]._metadata == state._metadata
    assert all(
        out["model"][k] is state[k] for k in state
    )  # no copy on the CPU: the saved bytes are unchanged
    assert out["groups"] == [{"lr": 0.1, "params": (0, 1)}] and isinstance(out["groups"][0]["params"], tuple)


def test_a_training_step_never_mixes_devices():
    """Forward, augmentations, losses and backward on torch's ``meta`` device (shapes only, no data): a tensor
    left on the CPU in that path (as the local frame's constants once were) fails here as it would on cuda."""
    tb, meta = PLANNER_TIMEBASE, torch.device("meta")
    model = TrajectoryModel(ModelConfig(tb.history, tb.horizon, tb.dt, 8, 1, 4, True, sigma_head=True)).to(
        meta
    )
    b = {
        "state": torch.empty(4, 6, feature_dim(tb.history), device=meta),
        "mask": torch.ones(4, 6, device=meta),
        "target": torch.empty(4, 6, tb.horizon, 2, device=meta),
        "target_mask": torch.ones(4, 6, tb.horizon, device=meta),
    }
    gen = torch.Generator().manual_seed(0)
    b = _mirror_half(b, torch.from_numpy(mirror_signs(tb.history)).to(meta), gen)
    b = _scale(b, torch.from_numpy(length_channels(tb.history)).to(meta), (0.8, 1.25), gen)
    pred, sigma = model.forward_dist(b["state"], b["mask"])
    loss = masked_loss("smooth_l1", pred, b["target"], b["target_mask"], 0.2) + masked_gaussian_nll(
        pred, sigma, b["target"], b["target_mask"]
    )
    loss.backward()
    assert loss.device == meta and all(
        p.grad.device == meta for p in model.parameters() if p.grad is not None
    )


def main() -> None:
    from tests.unit.predict.conftest import write_curving_dataset

    torch.set_num_threads(1)
    with tempfile.TemporaryDirectory() as tmp:
        data = write_curving_dataset(Path(tmp) / "arcs.npz")
        (Path(tmp) / "work").mkdir()
        record = _record(data, Path(tmp) / "work")
    lines = [f" {json.dumps(k)}: {json.dumps(v)}" for k, v in record.items() if k != "weights"]
    tensors = ",\n".join(
        f"  {json.dumps(k)}: {json.dumps(v)}" for k, v in record["weights"].items()
    )  # one a line
    FIXTURE.write_text("{\n" + ",\n".join([*lines, f' "weights": {{\n{tensors}\n }}']) + "\n}\n")
    sys.stdout.write(f"wrote {FIXTURE}\n")


if __name__ == "__main__":
    main()
