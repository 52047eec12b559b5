"""Latency of one prediction for one batch of 16 pedestrians (the planner's per-step call), median ms.

``median_ms``: ``TorchPredictor.predict`` on one sample, which runs the NumPy forward (``core.predict.nn.inference``,
what a planner decision runs); ``torch_median_ms``: the same sample through the torch model (what batches run).
Both measured in isolation: in closed loop the planner's own work between two calls makes each slower (the torch
forward about twice). Target: <= 0.5 ms. Usage: python bench/predict_latency.py [--json] [--threads 1] [--peds 16]
[--model PATH]
"""

from __future__ import annotations

import argparse
import json
import statistics
import time

import numpy as np
import torch

from foresight.core.predict.features import feature_dim
from foresight.core.predict.nn.checkpoint import TorchPredictor, load_predictor
from foresight.core.predict.nn.model import ModelConfig, TrajectoryModel
from foresight.core.predict.timebase import PLANNER_TIMEBASE
from foresight.core.training.config import TrainConfig


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--peds", type=int, default=16)
    ap.add_argument("--repeats", type=int, default=2000)
    ap.add_argument("--model", help="checkpoint (default: an untrained model of the default size)")
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    if args.model:
        predictor = load_predictor(args.model)
    else:
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
        predictor = TorchPredictor(TrajectoryModel(cfg), tb, "default-size")
    rng = np.random.default_rng(0)
    x = rng.normal(size=(1, args.peds, feature_dim(predictor.timebase.history))).astype(np.float32)
    m = np.ones((1, args.peds), np.float32)
    xt, mt = torch.from_numpy(x), torch.from_numpy(m)

    def through_torch():
        with torch.inference_mode():
            predictor.model(xt, mt)

    times, torch_times = (
        _times(lambda: predictor.predict(x, m), args.repeats),
        _times(through_torch, args.repeats),
    )
    out = {
        "median_ms": statistics.median(times),
        "p90_ms": float(np.percentile(times, 90)),
        "torch_median_ms": statistics.median(torch_times),
        "peds": args.peds,
        "threads": args.threads,
        "target_ms": 0.5,
    }
    print(
        json.dumps(out, indent=2)
        if args.json
        else f"median {out['median_ms']:.3f} ms (p90 {out['p90_ms']:.3f}); torch {out['torch_median_ms']:.3f} ms"
    )


def _times(call, repeats: int) -> list[float]:
    """Milliseconds of ``repeats`` calls after 100 warm-up calls."""
    for _ in range(100):
        call()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        call()
        times.append((time.perf_counter() - t0) * 1e3)
    return times


if __name__ == "__main__":
    main()
