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

import torch

from foresight.core.predict.nn.checkpoint import read_checkpoint
from foresight.core.predict.nn.train import run_train
from foresight.core.predict.train_config import TrainConfig
from foresight.core.stages.context import StageContext

FIXTURE = Path(__file__).with_name("train_golden.json")
GOLDEN = dict(epochs=2, batch_size=64, hidden=16, blocks=1, lr=3e-3, threads=1, seed=3, sigma_head=True,
              augment_mirror=True, augment_scale=(0.8, 1.25))
CURVE = ("train_loss", "val_loss", "val_ade", "val_fde", "val_nll")


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
    return {"config": GOLDEN, "torch": torch.__version__.split("+")[0], "weights_sha256": _weights_sha256(state),
            "weights": {k: v.flatten().tolist() for k, v in sorted(state.items())},
            "history": [{k: rec[k] for k in ("epoch", *CURVE)} for rec in summary["history"]]}


def main() -> None:
    from tests.unit.predict.conftest import write_curving_dataset

    torch.set_num_threads(1)
    with tempfile.TemporaryDirectory() as tmp:
        data = write_curving_dataset(Path(tmp) / "arcs.npz")
        (Path(tmp) / "work").mkdir()
        record = _record(data, Path(tmp) / "work")
    lines = [f" {json.dumps(k)}: {json.dumps(v)}" for k, v in record.items() if k != "weights"]
    tensors = ",\n".join(f"  {json.dumps(k)}: {json.dumps(v)}" for k, v in record["weights"].items())  # one a line
    FIXTURE.write_text("{\n" + ",\n".join([*lines, f' "weights": {{\n{tensors}\n }}']) + "\n}\n")
    sys.stdout.write(f"wrote {FIXTURE}\n")


if __name__ == "__main__":
    main()
