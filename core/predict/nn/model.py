"""The learned graph predictor.

Shapes: B samples, N slots, F features per slot (``core.predict.features``), h hidden, T steps.
- encoder: per-pedestrian MLP over its whole feature row (history positions/velocities/valid flags
  plus the robot/goal channels) -> (B, N, h);
- K residual message-passing blocks; each block's attention is distance-aware with a learned
  weighting: logits_ij = q_i·k_j / sqrt(h) - softplus(a_b)·|p_i - p_j| with p the current
  positions and a_b learned per block, inactive partners masked out; with ``edges`` (the default
  for new models), an edge embedding e_ij = MLP(p_j - p_i, v_j - v_i, |p_j - p_i|) (width
  ``edge_dim``) of the pair's relative position and velocity adds a learned logit term w_b·e_ij
  and a message term W_b sum_j a_ij e_ij: without it a message only knows its sender, not where the sender is
  relative to the receiver, which is what interactions (avoidance, following) depend on;
- decoder: per-step displacements d_k (B, N, T, 2) added to the constant-velocity step v0·dt and
  summed over time: p_k = p_0 + sum_{j<=k} (v0·dt + d_j). The model starts as constant velocity
  and learns corrections to it;
- sigma head (``sigma_head``, new models): per-step per-axis std of an isotropic Gaussian around each position,
  sigma_k = envelope(t_k) · exp(s_k) with the calibrated constant-velocity-like envelope
  (``core.predict.uncertainty.LEARNED_SIGMA``) and s_k = 3 tanh(MLP(h)/3) (starts AT the envelope, bounded to
  e^±3 of it), made non-decreasing in t by a running maximum (the planner extends the spread at its final rate,
  which must not be negative). It reads the final embedding DETACHED and is trained by the Gaussian NLL of the mean's (detached)
  error, so the mean is trained exactly as without it; old checkpoints (no head) keep the fixed envelope;
- modes (``modes`` = K > 1, ``core.predict.nn.modes``): the trajectory above is mode 0; K - 1 winner-takes-all modes
  and a weight head read the final embedding detached, so the network trains exactly as without them.

``local_frame`` (the default for new models): each pedestrian is encoded in its OWN frame (origin
= its current position, x = its current velocity direction; the ego x axis when it stands still):
its history relative to its current position, its velocities, the robot's relative position and
velocity and the goal direction, all rotated into that frame; edges are rotated into the
receiver's frame; the decoder's displacements are rotated back into the features' frame. Walking
dynamics do not depend on where the robot happens to face, so the network no longer has to learn
the same behaviour once per orientation (an equivariance the ego-frame input lacked). The input
features (``core.predict.features``) are unchanged: the frame change is a fixed function of them.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace

import torch
from torch import nn
from torch.nn import functional as F

from foresight.core.predict.features import current_index, feature_dim
from foresight.core.predict.nn.modes import ModeHead, pool_members
from foresight.core.predict.uncertainty import LEARNED_SIGMA


@dataclass(frozen=True)
class ModelConfig:
    history: int  #: H of the time base (fixes the feature layout)
    horizon: int  #: T
    dt: float  #: time-base step [s]
    hidden: int = 64  #: h
    blocks: int = 2  #: K message-passing blocks
    edge_dim: int = (
        0  #: width of the relative-geometry edge embeddings (0 = none, as checkpoints before them)
    )
    local_frame: bool = (
        False  #: encode/decode each pedestrian in its own frame (False = checkpoints before it)
    )
    members: int = 1  #: > 1: an ensemble of that many independently trained models, predictions averaged
    sigma_head: bool = False  #: predict a per-step spread (False = checkpoints before it: the fixed envelope)
    #: forecast = the mean of the network's forecast and the mirror image of its forecast of the mirrored scene
    #: (``core.predict.nn.mirror``): left/right symmetric by construction; applied where a checkpoint predicts
    mirror_average: bool = False
    #: K modes per pedestrian with weights (``core.predict.nn.modes``): mode 0 the deterministic trajectory, K - 1
    #: winner-takes-all modes and a weight head; 1 = none (checkpoints before it)
    modes: int = 1
    #: which mode a forecast with modes ranks most likely (best-of-1): "first" = mode 0, the deterministic trajectory
    #: (its weight raised to the largest of the others', ``modes.first_on_top``), "weight" = the weight head's own
    mode_top: str = "first"

    @property
    def input_dim(self) -> int:
        return LOCAL_EXTRA + 5 * self.history if self.local_frame else feature_dim(self.history)

    def to_dict(self) -> dict:
        return asdict(self)


LOCAL_EXTRA = 10  #: pedestrian-frame channels besides the history: robot rel. pos, |pos|, robot vel, omega, goal dir, goal dist, speed
STILL = 0.05  #: [m/s] below this speed a pedestrian's frame keeps the ego x axis


def local_inputs(features: torch.Tensor, history: int) -> tuple[torch.Tensor, torch.Tensor]:
    """(B, N, 5 H + LOCAL_EXTRA) pedestrian-frame inputs and each frame's rotation R (B, N, 2, 2), rows (c, s) and
    (-s, c) with (c, s) the unit velocity (ego x when still): a row vector x goes into the frame as x @ R^T and
    back as x @ R. One batched matmul for all vectors (few, larger ops: inference is one small batch)."""
    H = history
    steps = features[..., : 5 * H].unflatten(-1, (H, 5))
    pos, vel, valid = steps[..., 0:2], steps[..., 2:4], steps[..., 4:5]
    p0, v0 = pos[..., -1, :], vel[..., -1, :]
    speed = torch.linalg.vector_norm(v0, dim=-1, keepdim=True)
    same = (
        features.dtype == torch.float32 and features.device.type == "cpu"
    )  # the constants as they are (no .to)
    unit_x, row2 = (
        (_UNIT_X, _ROW2)
        if same
        else (_UNIT_X.to(features.device, features.dtype), _ROW2.to(features.device, features.dtype))
    )
    u = torch.where(speed > STILL, v0 / speed.clamp(min=STILL), unit_x)  # (c, s)
    rot = torch.stack([u, u.flip(-1) * row2], dim=-2)  # rows (c, s), (-s, c)
    ego = features[..., 5 * H :]
    vecs = torch.cat(
        [
            (pos - p0.unsqueeze(-2)) * valid,
            vel,
            -p0.unsqueeze(-2),
            (ego[..., 0:2] * unit_x).unsqueeze(-2),
            ego[..., 2:4].unsqueeze(-2),
        ],
        dim=-2,
    )
    r = vecs @ rot.transpose(-1, -2)  # (B, N, 2 H + 3, 2)
    x = torch.cat(
        [
            r[..., : 2 * H, :].flatten(-2),
            valid.flatten(-2),
            r[..., 2 * H, :],
            torch.linalg.vector_norm(p0, dim=-1, keepdim=True),
            r[..., 2 * H + 1, :],
            ego[..., 1:2],
            r[..., 2 * H + 2, :],
            ego[..., 4:5],
            speed,
        ],
        dim=-1,
    )
    return x, rot


_UNIT_X = torch.tensor([1.0, 0.0])
_ROW2 = torch.tensor([-1.0, 1.0])  #: (s, c) * (-1, 1) = (-s, c)


class MessageBlock(nn.Module):
    """One round of distance-weighted attention and a residual update."""

    def __init__(self, hidden: int, edge_dim: int = 0):
        super().__init__()
        self.qkv = nn.Linear(hidden, 3 * hidden)
        self.edge_logit = nn.Linear(edge_dim, 1) if edge_dim else None
        self.edge_value = nn.Linear(edge_dim, hidden, bias=False) if edge_dim else None
        self.distance_weight = nn.Parameter(torch.tensor(0.5))  # softplus -> ~0.97 per metre at init
        self.update = nn.Sequential(nn.Linear(2 * hidden, hidden), nn.ReLU(), nn.Linear(hidden, hidden))
        self.scale = 1.0 / math.sqrt(hidden)

    def forward(
        self, h: torch.Tensor, dist: torch.Tensor, pair_mask: torch.Tensor, edge: torch.Tensor | None = None
    ) -> torch.Tensor:
        """h (B, N, h), dist (B, N, N) [m], pair_mask (B, N, N) bool (True = masked OUT: an inactive partner),
        edge (B, N, N, e) -> (B, N, h)."""
        q, k, v = self.qkv(h).chunk(3, dim=-1)
        logits = (q @ k.transpose(1, 2)) * self.scale - F.softplus(self.distance_weight) * dist
        if self.edge_logit is not None:
            logits = logits + self.edge_logit(edge).squeeze(-1)
        logits = logits.masked_fill(pair_mask, -1e9)
        att = torch.softmax(logits, dim=-1)
        msg = att @ v
        if self.edge_logit is not None:
            msg = msg + self.edge_value((att.unsqueeze(-2) @ edge).squeeze(-2))  # sum_j a_ij e_ij
        return h + self.update(torch.cat([h, msg], dim=-1))


class TrajectoryModel(nn.Module):
    def __init__(self, config: ModelConfig):
        super().__init__()
        self.config = config
        c = config
        self.encoder = nn.Sequential(
            nn.Linear(c.input_dim, c.hidden), nn.ReLU(), nn.Linear(c.hidden, c.hidden), nn.ReLU()
        )
        self.blocks = nn.ModuleList(MessageBlock(c.hidden, c.edge_dim) for _ in range(c.blocks))
        self.edge_encoder = nn.Sequential(nn.Linear(5, c.edge_dim), nn.ReLU()) if c.edge_dim else None
        self.decoder = nn.Sequential(
            nn.Linear(c.hidden, c.hidden), nn.ReLU(), nn.Linear(c.hidden, 2 * c.horizon)
        )
        nn.init.zeros_(self.decoder[-1].weight)  # start exactly at constant velocity
        nn.init.zeros_(self.decoder[-1].bias)
        self.sigma_decoder = None
        if c.sigma_head:
            self.sigma_decoder = nn.Sequential(
                nn.Linear(c.hidden, c.hidden), nn.ReLU(), nn.Linear(c.hidden, c.horizon)
            )
            nn.init.zeros_(self.sigma_decoder[-1].weight)  # start exactly at the envelope
            nn.init.zeros_(self.sigma_decoder[-1].bias)
            times = torch.arange(1, c.horizon + 1, dtype=torch.float32) * c.dt
            self.register_buffer(
                "envelope", torch.from_numpy(LEARNED_SIGMA(times.numpy())).float(), persistent=False
            )
        # built last: the modules above draw the same initial weights with or without modes
        self.mode_head = ModeHead(c.hidden, c.horizon, c.modes) if c.modes > 1 else None
        self._px = current_index(c.history, "px")
        self._vx = current_index(c.history, "vx")

    def forward(self, features: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
        """features (B, N, F), mask (B, N) -> future positions (B, N, T, 2) in the features' frame.

        A planner decision (one sample) runs the NumPy copy of this forward instead (``inference``)."""
        return self._forward(features, mask)

    def forward_dist(self, features: torch.Tensor, mask: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """(positions (B, N, T, 2), sigma (B, N, T) per-axis std [m]); only for a model with ``sigma_head``."""
        if self.sigma_decoder is None:
            raise ValueError("this model has no sigma head (config.sigma_head is False)")
        return self._forward(features, mask, with_sigma=True)

    def forward_modes(
        self, features: torch.Tensor, mask: torch.Tensor, with_sigma: bool = False
    ) -> tuple[torch.Tensor, ...]:
        """(modes (B, N, K, T, 2), mode logits (B, N, K)), with ``with_sigma`` then mode 0's sigma (B, N, T); mode 0 is
        ``forward``'s trajectory. Only for a model with ``modes`` > 1."""
        if self.mode_head is None:
            raise ValueError("this model has no modes (config.modes is 1)")
        return self._forward(features, mask, with_sigma=with_sigma, with_modes=True)

    def _forward(
        self, features: torch.Tensor, mask: torch.Tensor, with_sigma: bool = False, with_modes: bool = False
    ):
        B, N, _ = features.shape
        m = mask.unsqueeze(-1)
        p0 = features[..., self._px : self._px + 2]
        v0 = features[..., self._vx : self._vx + 2]
        local = self.config.local_frame
        x, rot = local_inputs(features, self.config.history) if local else (features, None)
        pair_mask = (mask.unsqueeze(1) <= 0).expand(B, N, N)  # True = inactive partner
        h = self.encoder(x) * m
        edge = None
        if self.edge_encoder is not None and self.blocks:
            pv = torch.cat([p0, v0], dim=-1)
            rel = pv.unsqueeze(1) - pv.unsqueeze(2)  # [b, i, j] = (p_j - p_i, v_j - v_i)
            dist = torch.linalg.vector_norm(rel[..., :2], dim=-1)  # = cdist(p0, p0), without a second pass
            if local:  # into the receiver i's frame
                rel = (rel.unflatten(-1, (2, 2)) @ rot.transpose(-1, -2).unsqueeze(2)).flatten(-2)
            edge = self.edge_encoder(torch.cat([rel, dist.unsqueeze(-1)], dim=-1))
        else:
            dist = torch.cdist(p0, p0)
        for block in self.blocks:
            h = block(h, dist, pair_mask, edge) * m
        delta = self.decoder(h).view(B, N, self.config.horizon, 2)
        if local:  # back from each pedestrian's frame: the inverse rotation
            delta = delta @ rot
        steps = delta + (v0 * self.config.dt).unsqueeze(2)
        positions = (p0.unsqueeze(2) + torch.cumsum(steps, dim=2)) * m.unsqueeze(-1)
        if not (with_sigma or with_modes):
            return positions
        out = (positions,)
        if with_modes:  # offsets from mode 0, both read detached (core.predict.nn.modes)
            offsets, logits = self.mode_head(h.detach())
            if local:
                offsets = offsets @ rot.unsqueeze(2)
            extra = positions.detach().unsqueeze(2) + torch.cumsum(offsets, dim=3) * m[..., None, None]
            out = (torch.cat([positions.unsqueeze(2), extra], dim=2), logits)
        if with_sigma:
            s = 3.0 * torch.tanh(self.sigma_decoder(h.detach()) / 3.0)  # (B, N, T), |s| < 3
            out = (*out, torch.cummax(self.envelope * torch.exp(s), dim=-1).values)  # never shrinks with t
        return out


class EnsembleModel(nn.Module):
    """``config.members`` independently trained models (different seeds); the prediction is their mean, so it
    stays deterministic. Averaging removes part of each member's seed-dependent error."""

    def __init__(self, config: ModelConfig):
        super().__init__()
        self.config = config
        self.members = nn.ModuleList(
            TrajectoryModel(replace(config, members=1)) for _ in range(config.members)
        )

    def forward(self, features: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
        return torch.stack([m(features, mask) for m in self.members]).mean(dim=0)

    def forward_dist(self, features: torch.Tensor, mask: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """The mixture's mean and per-axis spread: sigma^2 = mean of the members' sigma^2 + the members' spread."""
        outs = [m.forward_dist(features, mask) for m in self.members]
        pos = torch.stack([p for p, _ in outs])  # (M, B, N, T, 2)
        var = torch.stack([s for _, s in outs]).pow(2).mean(dim=0) + pos.var(dim=0, unbiased=False).mean(
            dim=-1
        )
        return pos.mean(dim=0), var.sqrt()

    def forward_weighted(
        self, features: torch.Tensor, mask: torch.Tensor
    ) -> tuple[torch.Tensor, torch.Tensor]:
        """The ensemble's K modes and weights (``modes.pool_members``): mode 0 is ``forward``'s mean."""
        outs = [weighted_modes(m, features, mask) for m in self.members]
        return pool_members(outs)


def weighted_modes(
    model: nn.Module, features: torch.Tensor, mask: torch.Tensor
) -> tuple[torch.Tensor, torch.Tensor]:
    """(modes (B, N, K, T, 2), weights (B, N, K) summing to 1) of a network or an ensemble with modes."""
    if isinstance(model, EnsembleModel):
        return model.forward_weighted(features, mask)
    modes, logits = model.forward_modes(features, mask)
    return modes, torch.softmax(logits, dim=-1)


def build_model(config: ModelConfig) -> nn.Module:
    """The model a config describes: one network, or an ensemble of ``members``."""
    return TrajectoryModel(config) if config.members == 1 else EnsembleModel(config)


def masked_smooth_l1(
    pred: torch.Tensor, target: torch.Tensor, target_mask: torch.Tensor, beta: float
) -> torch.Tensor:
    """SmoothL1 over (x, y) of valid (slot, step) points only, averaged over those points."""
    per_point = F.smooth_l1_loss(pred, target, reduction="none", beta=beta).sum(-1)
    return (per_point * target_mask).sum() / target_mask.sum().clamp(min=1.0)


def masked_euclidean(
    pred: torch.Tensor, target: torch.Tensor, target_mask: torch.Tensor, eps: float = 1e-6
) -> torch.Tensor:
    """Mean Euclidean error of valid points: the ADE itself as the loss (its minimiser is what ADE/FDE reward)."""
    err = torch.sqrt(((pred - target) ** 2).sum(-1) + eps)
    return (err * target_mask).sum() / target_mask.sum().clamp(min=1.0)


def masked_loss(
    kind: str, pred: torch.Tensor, target: torch.Tensor, target_mask: torch.Tensor, beta: float
) -> torch.Tensor:
    """The training loss ``kind`` (smooth_l1 | euclidean) over valid points."""
    if kind == "euclidean":
        return masked_euclidean(pred, target, target_mask)
    return masked_smooth_l1(pred, target, target_mask, beta)


def masked_gaussian_nll(
    pred: torch.Tensor, sigma: torch.Tensor, target: torch.Tensor, target_mask: torch.Tensor
) -> torch.Tensor:
    """Mean negative log-likelihood (without log 2 pi) of valid points under an isotropic 2D Gaussian of per-axis std
    ``sigma`` (B, N, T) around ``pred``: 2 log sigma + |pred - target|^2 / (2 sigma^2). The error is detached: the
    spread learns how wrong the mean is, never the mean how to suit the spread."""
    sq = ((pred.detach() - target) ** 2).sum(-1)
    nll = 2.0 * torch.log(sigma) + sq / (2.0 * sigma**2)
    return (nll * target_mask).sum() / target_mask.sum().clamp(min=1.0)


def masked_ade_fde(
    pred: torch.Tensor, target: torch.Tensor, target_mask: torch.Tensor
) -> tuple[torch.Tensor, ...]:
    """Sums for ADE/FDE: (sum of errors, valid points, sum of final errors, valid finals)."""
    err = torch.linalg.vector_norm(pred - target, dim=-1)
    return (
        (err * target_mask).sum(),
        target_mask.sum(),
        (err[..., -1] * target_mask[..., -1]).sum(),
        target_mask[..., -1].sum(),
    )
