"""One planner decision's forward pass of a trained predictor in NumPy: the arithmetic of ``TrajectoryModel``
on one sample (N slots), without torch.

Why: a decision runs the model once on about a dozen pedestrians, where torch spends its time dispatching
~60 tiny operations, not computing. Measured in closed loop (``bench/planner_latency.py``, 16 pedestrians) the
torch forward took ~0.37 ms of a 2.3 ms decision (twice its time in isolation: the planner's own work between
two calls evicts torch's code and data from the caches); this one ~0.05 ms. The weights are copied once from the
trained module, which stays the one definition of the model: ``tests/unit/predict/test_inference.py`` holds this
to the torch forward for every architecture (float32 rounding apart).
"""

from __future__ import annotations

import numpy as np
import torch
from torch import nn

from foresight.core.predict.nn.model import STILL, EnsembleModel, TrajectoryModel

Dense = tuple[np.ndarray, np.ndarray | None]  #: (weight (in, out), bias (out,) or None) of an nn.Linear


def _dense(layer: nn.Linear) -> Dense:
    bias = None if layer.bias is None else layer.bias.detach().cpu().numpy().copy()
    return layer.weight.detach().cpu().numpy().T.copy(), bias


def _apply(x: np.ndarray, layer: Dense, relu: bool = False) -> np.ndarray:
    w, b = layer
    y = x @ w
    if b is not None:
        y += b
    return np.maximum(y, 0, out=y) if relu else y


class NetworkForward:
    """The forward pass of one ``TrajectoryModel`` (its weights at construction) on features (N, F), mask (N,)."""

    def __init__(self, model: TrajectoryModel):
        self.config = model.config
        self.encoder = [_dense(model.encoder[0]), _dense(model.encoder[2])]
        self.edge = (
            _dense(model.edge_encoder[0]) if model.edge_encoder is not None and len(model.blocks) else None
        )
        self.blocks = [
            {
                "qkv": _dense(b.qkv),
                "scale": np.float32(b.scale),
                "distance": np.float32(torch.nn.functional.softplus(b.distance_weight.detach()).item()),
                "edge_logit": None if b.edge_logit is None else _dense(b.edge_logit),
                "edge_value": None if b.edge_value is None else _dense(b.edge_value),
                "update": (_dense(b.update[0]), _dense(b.update[2])),
            }
            for b in model.blocks
        ]
        self.decoder = [_dense(model.decoder[0]), _dense(model.decoder[2])]
        self.sigma = (
            None
            if model.sigma_decoder is None
            else [_dense(model.sigma_decoder[0]), _dense(model.sigma_decoder[2])]
        )
        self.envelope = None if model.sigma_decoder is None else model.envelope.cpu().numpy()
        self.px, self.vx = model._px, model._vx

    def __call__(self, features: np.ndarray, mask: np.ndarray, with_sigma: bool = False):
        """Positions (N, T, 2) in the features' frame; with ``with_sigma`` also the spread (N, T)."""
        c, N = self.config, len(features)
        m = mask[:, None]
        p0, v0 = features[:, self.px : self.px + 2], features[:, self.vx : self.vx + 2]
        x, rot_t = _local_inputs(features, c.history) if c.local_frame else (features, None)
        h = _apply(_apply(x, self.encoder[0], True), self.encoder[1], True) * m
        pv = np.concatenate([p0, v0], axis=-1)
        rel = pv[None, :, :] - pv[:, None, :]  # [i, j] = (p_j - p_i, v_j - v_i)
        dist = np.sqrt(rel[..., 0] ** 2 + rel[..., 1] ** 2)
        edge = None
        if self.edge is not None:
            if rot_t is not None:  # into the receiver i's frame
                rel = (rel.reshape(N, N, 2, 2) @ rot_t[:, None]).reshape(N, N, 4)
            edge = _apply(np.concatenate([rel, dist[..., None]], axis=-1), self.edge, True)
        inactive = (mask <= 0)[None, :]  # an inactive partner j
        for b in self.blocks:
            q, k, v = np.split(_apply(h, b["qkv"]), 3, axis=-1)
            logits = (q @ k.T) * b["scale"] - b["distance"] * dist
            if edge is not None:
                logits += _apply(edge, b["edge_logit"])[..., 0]
            logits = np.where(inactive, np.float32(-1e9), logits)
            att = np.exp(logits - logits.max(axis=-1, keepdims=True))
            att /= att.sum(axis=-1, keepdims=True)
            msg = att @ v
            if edge is not None:
                msg += np.einsum("ij,ije->ie", att, edge) @ b["edge_value"][0]  # sum_j a_ij e_ij, then W
            u1, u2 = b["update"]
            h = (h + _apply(_apply(np.concatenate([h, msg], axis=-1), u1, True), u2)) * m
        delta = _apply(_apply(h, self.decoder[0], True), self.decoder[1]).reshape(N, c.horizon, 2)
        if rot_t is not None:  # back from each pedestrian's frame: x R = x (R^T)^T
            delta = delta @ rot_t.transpose(0, 2, 1)
        positions = (p0[:, None] + np.cumsum(delta + (v0 * np.float32(c.dt))[:, None], axis=1)) * m[:, None]
        if not with_sigma:
            return positions
        if self.sigma is None:
            raise ValueError("this model has no sigma head (config.sigma_head is False)")
        s = 3.0 * np.tanh(_apply(_apply(h, self.sigma[0], True), self.sigma[1]) / 3.0)
        return positions, np.maximum.accumulate(self.envelope * np.exp(s), axis=-1)


def _local_inputs(features: np.ndarray, history: int) -> tuple[np.ndarray, np.ndarray]:
    """``model.local_inputs`` for one sample: the pedestrian-frame inputs (N, 5 H + LOCAL_EXTRA) and each frame's
    R^T (N, 2, 2) (columns (c, s) and (-s, c)): a row vector x goes into the frame as x @ R^T."""
    H, N = history, len(features)
    steps = features[:, : 5 * H].reshape(N, H, 5)
    pos, vel, valid = steps[..., 0:2], steps[..., 2:4], steps[..., 4:5]
    p0, v0 = pos[:, -1], vel[:, -1]
    speed = np.sqrt(np.add.reduce(v0 * v0, axis=-1, keepdims=True))
    u = np.where(
        speed > STILL, v0 / np.maximum(speed, np.float32(STILL)), np.array([1, 0], dtype=features.dtype)
    )
    rot_t = np.empty((N, 2, 2), dtype=features.dtype)
    rot_t[:, 0, 0], rot_t[:, 1, 0], rot_t[:, 0, 1], rot_t[:, 1, 1] = u[:, 0], u[:, 1], -u[:, 1], u[:, 0]
    ego = features[:, 5 * H :]
    robot_x = np.zeros_like(ego[:, 0:2])
    robot_x[:, 0] = ego[:, 0]  # the robot's x (as the torch model's ego[..., 0:2] * (1, 0))
    vecs = np.concatenate(
        [(pos - p0[:, None]) * valid, vel, -p0[:, None], robot_x[:, None], ego[:, None, 2:4]], axis=1
    )
    r = vecs @ rot_t  # (N, 2 H + 3, 2)
    x = np.concatenate(
        [
            r[:, : 2 * H].reshape(N, -1),
            valid.reshape(N, -1),
            r[:, 2 * H],
            np.sqrt(np.add.reduce(p0 * p0, axis=-1, keepdims=True)),
            r[:, 2 * H + 1],
            ego[:, 1:2],
            r[:, 2 * H + 2],
            ego[:, 4:5],
            speed,
        ],
        axis=-1,
    )
    return x, rot_t


class ModelForward:
    """The NumPy forward of a trained model (one network or an ensemble, as ``build_model`` makes them)."""

    def __init__(self, model: nn.Module):
        members = model.members if isinstance(model, EnsembleModel) else [model]
        self.members = [NetworkForward(m) for m in members]

    def positions(self, features: np.ndarray, mask: np.ndarray) -> np.ndarray:
        """(N, T, 2): the members' mean, as ``EnsembleModel.forward``."""
        if len(self.members) == 1:
            return self.members[0](features, mask)
        return np.mean([f(features, mask) for f in self.members], axis=0)

    def distribution(self, features: np.ndarray, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(N, T, 2) positions and (N, T) per-axis spread; an ensemble's as ``EnsembleModel.forward_dist``."""
        outs = [f(features, mask, with_sigma=True) for f in self.members]
        if len(outs) == 1:
            return outs[0]
        pos = np.stack([p for p, _ in outs])
        var = np.mean(np.stack([s for _, s in outs]) ** 2, axis=0) + pos.var(axis=0).mean(axis=-1)
        return pos.mean(axis=0), np.sqrt(var)
