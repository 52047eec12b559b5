"""K modes per pedestrian with weights: the network's multimodal head (``ModelConfig.modes`` = K > 1).

- mode 0 is the network's deterministic trajectory, trained with the training loss as a model without modes is;
- modes 1..K-1 are offsets from mode 0 (per-step displacements in the pedestrian's frame, summed over time), decoded
  from the final embedding and trained winner-takes-all: per pedestrian only the extra mode closest to the truth
  (mean displacement error over its valid steps) takes the loss, the others a small share (``WTA_EPSILON``) so that
  no mode is left untrained;
- a weight head gives K logits per pedestrian, trained by cross-entropy toward the mode (of all K, mode 0 included)
  closest to the truth: a mode's weight is the predicted probability that it is the closest.

The head reads the embedding and mode 0 DETACHED and its gradients are clipped apart from the network's: the network
and mode 0 train exactly as without modes (the same weights, bit for bit, for the same seed), so mode 0's best-of-1
cannot get worse by adding modes. Whether the most likely mode (largest weight, the forecast contract's rule) is mode 0
is for the weights to say: trained to pick the closest of 20 modes, the head's top mode is a narrow guess and scores
far worse on ADE than mode 0, which is trained for the lowest expected displacement error. So by default
(``ModelConfig.mode_top`` "first") a forecast ranks mode 0 most likely: its weight is raised to the largest of the
other modes' and the weights renormalised (``first_on_top``); "weight" leaves the head's weights as they are.
predict-eval's best-of-1 is the forecast's most likely mode either way, and it reports mode 0's numbers beside it.
"""

from __future__ import annotations

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F

WTA_EPSILON = 0.05  #: share of the winner-takes-all loss spread over the losing modes (relaxed WTA)
INIT_SCALE = (
    0.3  #: the extra modes' last layer starts at this fraction of torch's default init: spread, not far
)


class ModeHead(nn.Module):
    """Offsets of K-1 extra modes (B, N, K-1, T, 2) in each pedestrian's frame and K mode logits (B, N, K)."""

    def __init__(self, hidden: int, horizon: int, modes: int):
        super().__init__()
        self.extra, self.horizon = modes - 1, horizon
        self.offsets = nn.Sequential(
            nn.Linear(hidden, 2 * hidden),
            nn.ReLU(),
            nn.Linear(2 * hidden, 2 * hidden),
            nn.ReLU(),
            nn.Linear(2 * hidden, self.extra * horizon * 2),
        )
        with torch.no_grad():  # random, small: the modes start apart (identical modes never win apart)
            self.offsets[-1].weight.mul_(INIT_SCALE)
            self.offsets[-1].bias.zero_()
        self.logits = nn.Sequential(nn.Linear(hidden, hidden), nn.ReLU(), nn.Linear(hidden, modes))

    def forward(self, h: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        B, N, _ = h.shape
        steps = self.offsets(h).view(B, N, self.extra, self.horizon, 2)
        return steps, self.logits(h)


def mode_errors(modes: torch.Tensor, target: torch.Tensor, target_mask: torch.Tensor) -> torch.Tensor:
    """(B, N, K) mean displacement error of each mode over the pedestrian's valid steps (0 where none is valid)."""
    err = torch.sqrt(((modes - target.unsqueeze(2)) ** 2).sum(-1) + 1e-6)  # (B, N, K, T)
    tm = target_mask.unsqueeze(2)
    return (err * tm).sum(-1) / tm.sum(-1).clamp(min=1.0)


def mode_loss(
    modes: torch.Tensor, logits: torch.Tensor, target: torch.Tensor, target_mask: torch.Tensor
) -> torch.Tensor:
    """Relaxed winner-takes-all loss of the extra modes (``modes[:, :, 1:]``) plus the weight head's cross-entropy
    toward the closest of all K modes; each pedestrian counts by its valid points, as the training loss does."""
    ade = mode_errors(modes, target, target_mask)  # (B, N, K)
    points = target_mask.sum(-1)  # (B, N)
    valid = points > 0
    extra = ade[..., 1:]
    share = torch.full_like(extra, WTA_EPSILON / max(extra.shape[-1] - 1, 1))
    share.scatter_(
        -1, extra.detach().argmin(-1, keepdim=True), 1.0 - WTA_EPSILON if extra.shape[-1] > 1 else 1.0
    )
    wta = (share * extra).sum(-1)
    ce = F.cross_entropy(logits[valid], ade.detach().argmin(-1)[valid], reduction="none")
    total = points.sum().clamp(min=1.0)
    return ((wta * points).sum() + (ce * points[valid]).sum()) / total


def pool_members(outs: list[tuple[torch.Tensor, torch.Tensor]]) -> tuple[torch.Tensor, torch.Tensor]:
    """An ensemble's K modes from its members' (modes (B, N, K, T, 2), weights (B, N, K)): mode 0 the members' mean
    mode 0 (the ensemble's deterministic forecast) with their mean weight; modes 1..K-1 the first member's, sharing the
    rest of the weight in that member's proportions. A member's extra modes are in no order that matches another's,
    so they are never averaged; pooling all members' and keeping the K-1 of largest weight was measured worse (on the
    ETH/UCY univ fold minADE20 0.301 against the first member's own 0.221): the members' likeliest modes are near
    copies of each other, and the pool loses the less likely ones that cover the rare futures."""
    first = torch.stack([o[0][:, :, 0] for o in outs]).mean(0)
    w0 = torch.stack([o[1][:, :, 0] for o in outs]).mean(0, keepdim=True).movedim(0, -1)
    modes, weights = outs[0]
    rest = weights[..., 1:] / weights[..., 1:].sum(-1, keepdim=True).clamp(min=1e-12)
    return torch.cat([first.unsqueeze(2), modes[:, :, 1:]], dim=2), torch.cat([w0, (1.0 - w0) * rest], dim=-1)


MODE_TOP = (
    "first",
    "weight",
)  #: ``ModelConfig.mode_top``: mode 0 ranked most likely, or the weight head's top mode


def first_on_top(weights: np.ndarray) -> np.ndarray:
    """(..., K) weights with mode 0's raised to the largest of the others' (where it is below), renormalised to sum to
    1: mode 0 then is the most likely mode (the first of equal weights), every other mode keeps its relative weight."""
    w = np.array(weights, dtype=np.float64)
    w[..., 0] = np.maximum(w[..., 0], w[..., 1:].max(axis=-1))
    return w / w.sum(axis=-1, keepdims=True)
