"""Training throughput of the default predictor: samples/s (forward + backward + AdamW step) and FLOPs per sample.

Synthetic batches at the planner time base (shapes only matter). Target: >= 10,000 samples/s on 2 CPU cores.
Usage: python bench/train_speed.py [--json] [--threads 2] [--batch 256] [--agents 12] [--seconds 5]
"""

from __future__ import annotations

import argparse
import json
import time

import torch
from torch.utils.flop_counter import FlopCounterMode

from foresight.core.predict.features import feature_dim
from foresight.core.predict.nn.model import ModelConfig, TrajectoryModel, masked_smooth_l1
from foresight.core.predict.timebase import PLANNER_TIMEBASE
from foresight.core.training.config import TrainConfig


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--batch", type=int, default=TrainConfig.model_fields["batch_size"].default)
    ap.add_argument("--agents", type=int, default=12)
    ap.add_argument("--seconds", type=float, default=5.0)
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    tb = PLANNER_TIMEBASE
    cfg = ModelConfig(
        tb.history,
        tb.horizon,
        tb.dt,
        TrainConfig.model_fields["hidden"].default,
        TrainConfig.model_fields["blocks"].default,
        TrainConfig.model_fields["edge_dim"].default,
        TrainConfig.model_fields["local_frame"].default,
    )
    torch.manual_seed(0)
    model = TrajectoryModel(cfg)
    opt = torch.optim.AdamW(model.parameters(), lr=1e-3)
    B, N, T = args.batch, args.agents, tb.horizon
    x, m = torch.randn(B, N, feature_dim(tb.history)), torch.ones(B, N)
    y, ym = torch.randn(B, N, T, 2), torch.ones(B, N, T)

    def step() -> None:
        loss = masked_smooth_l1(model(x, m), y, ym, 0.2)
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()

    with FlopCounterMode(display=False) as counter:
        step()
    for _ in range(5):
        step()
    n, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < args.seconds:
        step()
        n += 1
    elapsed = time.perf_counter() - t0
    out = {
        "samples_per_s": n * B / elapsed,
        "flops_per_sample": counter.get_total_flops() / B,
        "threads": args.threads,
        "batch": B,
        "agents": N,
        "hidden": cfg.hidden,
        "blocks": cfg.blocks,
        "params": sum(p.numel() for p in model.parameters()),
        "target_samples_per_s": 10_000,
    }
    print(
        json.dumps(out, indent=2)
        if args.json
        else f"{out['samples_per_s']:.0f} samples/s, {out['flops_per_sample'] / 1e6:.2f} MFLOP/sample"
    )


if __name__ == "__main__":
    main()
