"""ADE / FDE over ``target_mask`` only (numpy; the torch training uses the same definitions).

ADE = mean over valid (slot, step) pairs of the Euclidean error [m]; FDE = the same over slots
whose last step is valid. Zero-filled missing targets never count (no fake zero error).
"""

from __future__ import annotations

import numpy as np

from foresight.core.predict.predictor import Predictor


def ade_fde(pred: np.ndarray, target: np.ndarray, target_mask: np.ndarray) -> dict[str, float]:
    """(S, N, T, 2) predictions and targets, (S, N, T) mask -> {ade, fde, points, finals}."""
    err = np.linalg.norm(pred.astype(np.float64) - target, axis=-1)
    valid = target_mask > 0
    final = valid[..., -1]
    return {
        "ade": float(err[valid].mean()) if valid.any() else float("nan"),
        "fde": float(err[..., -1][final].mean()) if final.any() else float("nan"),
        "points": int(valid.sum()),
        "finals": int(final.sum()),
    }


def evaluate_predictor(
    predictor: Predictor, ds, split: str | None = None, batch: int = 4096
) -> dict[str, float]:
    """ADE/FDE of ``predictor`` on a dataset's ``split`` (all samples when None); time bases must agree."""
    predictor.timebase.require_same(ds.meta.timebase, what="dataset")
    idx = np.arange(len(ds)) if split is None else ds.split_indices(split)
    preds = [
        predictor.predict(ds.state[idx[i : i + batch]], ds.mask[idx[i : i + batch]])
        for i in range(0, len(idx), batch)
    ]
    pred = np.concatenate(preds) if preds else np.zeros((0, *ds.target.shape[1:]), np.float32)
    out = ade_fde(pred, ds.target[idx], ds.target_mask[idx])
    out["samples"] = int(len(idx))
    return out
