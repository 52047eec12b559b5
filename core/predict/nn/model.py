"""The learned graph predictor.

Shapes: B samples, N slots, F features per slot (``core.predict.features``), h hidden, T steps.
- encoder: per-pedestrian MLP over its whole feature row (history positions/velocities/valid flags
  plus the robot/goal channels) -> (B, N, h);
- K residual message-passing blocks; each block's attention is distance-aware with a learned
  weighting: logits_ij = q_i·k_j / sqrt(h) - softplus(a_b)·|p_i - p_j| with p the current
  positions and a_b learned per block, inactive partners masked out;
- decoder: per-step displacements d_k (B, N, T, 2) added to the constant-velocity step v0·dt and
  summed over time: p_k = p_0 + sum_{j<=k} (v0·dt + d_j). The model starts as constant velocity
  and learns corrections to it.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import torch
from torch import nn
from torch.nn import functional as F

from core.predict.features import current_index, feature_dim


@dataclass(frozen=True)
class ModelConfig:
    history: int  #: H of the time base (fixes the feature layout)
    horizon: int  #: T
    dt: float  #: time-base step [s]
    hidden: int = 64  #: h
    blocks: int = 2  #: K message-passing blocks

    @property
    def input_dim(self) -> int:
        return feature_dim(self.history)

    def to_dict(self) -> dict:
        return asdict(self)


class MessageBlock(nn.Module):
    """One round of distance-weighted attention and a residual update."""

    def __init__(self, hidden: int):
        super().__init__()
        self.qkv = nn.Linear(hidden, 3 * hidden)
        self.distance_weight = nn.Parameter(torch.tensor(0.5))  # softplus -> ~0.97 per metre at init
        self.update = nn.Sequential(nn.Linear(2 * hidden, hidden), nn.ReLU(), nn.Linear(hidden, hidden))
        self.scale = 1.0 / math.sqrt(hidden)

    def forward(self, h: torch.Tensor, dist: torch.Tensor, pair_mask: torch.Tensor) -> torch.Tensor:
        """h (B, N, h), dist (B, N, N) [m], pair_mask (B, N, N) bool -> (B, N, h)."""
        q, k, v = self.qkv(h).chunk(3, dim=-1)
        logits = (q @ k.transpose(1, 2)) * self.scale - F.softplus(self.distance_weight) * dist
        logits = logits.masked_fill(~pair_mask, -1e9)
        msg = torch.softmax(logits, dim=-1) @ v
        return h + self.update(torch.cat([h, msg], dim=-1))


class TrajectoryModel(nn.Module):
    def __init__(self, config: ModelConfig):
        super().__init__()
        self.config = config
        c = config
        self.encoder = nn.Sequential(nn.Linear(c.input_dim, c.hidden), nn.ReLU(), nn.Linear(c.hidden, c.hidden), nn.ReLU())
        self.blocks = nn.ModuleList(MessageBlock(c.hidden) for _ in range(c.blocks))
        self.decoder = nn.Sequential(nn.Linear(c.hidden, c.hidden), nn.ReLU(), nn.Linear(c.hidden, 2 * c.horizon))
        nn.init.zeros_(self.decoder[-1].weight)  # start exactly at constant velocity
        nn.init.zeros_(self.decoder[-1].bias)
        self._px = current_index(c.history, "px")
        self._vx = current_index(c.history, "vx")

    def forward(self, features: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
        """features (B, N, F), mask (B, N) -> future positions (B, N, T, 2) in the features' frame."""
        B, N, _ = features.shape
        m = mask.unsqueeze(-1)
        p0 = features[..., self._px : self._px + 2]
        v0 = features[..., self._vx : self._vx + 2]
        dist = torch.cdist(p0, p0)
        pair_mask = (mask.unsqueeze(1) > 0).expand(B, N, N)
        h = self.encoder(features) * m
        for block in self.blocks:
            h = block(h, dist, pair_mask) * m
        delta = self.decoder(h).view(B, N, self.config.horizon, 2)
        steps = delta + (v0 * self.config.dt).unsqueeze(2)
        return (p0.unsqueeze(2) + torch.cumsum(steps, dim=2)) * m.unsqueeze(-1)


def masked_smooth_l1(pred: torch.Tensor, target: torch.Tensor, target_mask: torch.Tensor, beta: float) -> torch.Tensor:
    """SmoothL1 over (x, y) of valid (slot, step) points only, averaged over those points."""
    per_point = F.smooth_l1_loss(pred, target, reduction="none", beta=beta).sum(-1)
    return (per_point * target_mask).sum() / target_mask.sum().clamp(min=1.0)


def masked_ade_fde(pred: torch.Tensor, target: torch.Tensor, target_mask: torch.Tensor) -> tuple[torch.Tensor, ...]:
    """Sums for ADE/FDE: (sum of errors, valid points, sum of final errors, valid finals)."""
    err = torch.linalg.vector_norm(pred - target, dim=-1)
    return ((err * target_mask).sum(), target_mask.sum(),
            (err[..., -1] * target_mask[..., -1]).sum(), target_mask[..., -1].sum())
