"""The field's prediction metrics over K-mode forecasts, on the points ``target_mask`` marks.

- best-of-1 ADE / FDE: the most likely mode's (the first of equal weights), as a deterministic predictor's;
- minADE_K / minFDE_K: the best of the K most likely modes, each pedestrian on its own (ADE and FDE pick their
  modes separately, as published); K = 20 by the field's convention, always reported with the K used;
- NLL: mean negative log-likelihood [nats] of the true position under the mixture of Gaussians (isotropic sigma or
  full covariance) at each scored point, where the predictor gives a spread;
- calibration: the share of true positions within 1 and 2 sigma of the most likely mode (Mahalanobis radius;
  a calibrated 2-D Gaussian holds 39.3 % and 86.5 %).
"""

from __future__ import annotations

import numpy as np

EXPECTED_WITHIN = {1: 1.0 - np.exp(-0.5), 2: 1.0 - np.exp(-2.0)}  #: 2-D Gaussian mass within 1 and 2 sigma
VAR_FLOOR = 1e-6  #: [m^2] a zero spread is scored as this (a point mass has no likelihood)


def _top_k(weights: np.ndarray, k: int) -> np.ndarray:
    """(S, N, k') indices of the k most likely modes (stable: the first of equal weights first)."""
    order = np.argsort(-weights, axis=-1, kind="stable")
    return order[..., :k]


def score(
    modes: np.ndarray,
    weights: np.ndarray,
    target: np.ndarray,
    target_mask: np.ndarray,
    spread: np.ndarray | None = None,
    best_of: int = 20,
) -> dict[str, float | int | None]:
    """Metrics of forecasts ``modes`` (S, N, K, T, 2) with ``weights`` (S, N, K) against ``target`` (S, N, T, 2)
    on ``target_mask`` (S, N, T); ``spread`` (S, N, K, T) or (S, N, K, T, 2, 2), None when there is none."""
    modes = np.asarray(modes, dtype=np.float64)
    valid = np.asarray(target_mask) > 0
    final = valid[..., -1]
    K = modes.shape[2]
    out: dict[str, float | int | None] = {"points": int(valid.sum()), "finals": int(final.sum())}
    err = np.linalg.norm(modes - np.asarray(target, dtype=np.float64)[:, :, None], axis=-1)  # (S, N, K, T)
    top = _top_k(weights, K)
    best = np.take_along_axis(err, top[..., :1, None], axis=2)[:, :, 0]  # (S, N, T)
    out["ade"] = float(best[valid].mean()) if valid.any() else float("nan")
    out["fde"] = float(best[..., -1][final].mean()) if final.any() else float("nan")
    k = min(best_of, K)
    sub = np.take_along_axis(err, top[..., :k, None], axis=2)  # (S, N, k, T)
    w = valid[:, :, None].astype(np.float64)
    per_mode_ade = (sub * w).sum(-1) / np.maximum(w.sum(-1), 1)  # (S, N, k)
    scored = valid.any(-1)
    out["best_of"] = k
    out["min_ade"] = float(per_mode_ade.min(axis=2)[scored].mean()) if scored.any() else float("nan")
    out["min_fde"] = float(sub[..., -1].min(axis=2)[final].mean()) if final.any() else float("nan")
    out.update(nll=None, within_1sigma=None, within_2sigma=None)
    if spread is not None and valid.any():
        out.update(
            _likelihood(modes, np.asarray(weights, float), np.asarray(target, float), valid, spread, top)
        )
    return out


def _likelihood(modes, weights, target, valid, spread, top) -> dict[str, float]:
    d = target[:, :, None] - modes  # (S, N, K, T, 2)
    spread = np.asarray(spread, dtype=np.float64)
    if spread.ndim == modes.ndim + 1:  # full covariance (S, N, K, T, 2, 2)
        cov = spread + VAR_FLOOR * np.eye(2)
        inv = np.linalg.inv(cov)
        m2 = np.einsum("...i,...ij,...j->...", d, inv, d)
        logdet = np.log(np.linalg.det(cov))
    else:
        var = np.maximum(spread**2, VAR_FLOOR)
        m2 = (d**2).sum(-1) / var
        logdet = 2.0 * np.log(var)
    logp = -0.5 * m2 - 0.5 * logdet - np.log(2.0 * np.pi)  # (S, N, K, T) per-mode log density
    lw = np.log(np.maximum(weights, 1e-300))[..., None]
    a = logp + lw
    mx = a.max(axis=2, keepdims=True)
    mix = (mx + np.log(np.exp(a - mx).sum(axis=2, keepdims=True)))[:, :, 0]  # (S, N, T)
    r = np.sqrt(np.take_along_axis(m2, top[..., :1, None], axis=2)[:, :, 0])  # most likely mode's radius
    return {
        "nll": float(-mix[valid].mean()),
        "within_1sigma": float((r[valid] <= 1.0).mean()),
        "within_2sigma": float((r[valid] <= 2.0).mean()),
    }
