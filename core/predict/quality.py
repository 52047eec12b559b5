"""Dataset summary statistics and fail-fast checks against degenerate data.

A dataset with no active targets, constant targets or pedestrians that never move trains a model
that looks perfect (zero loss) and predicts nothing; these checks stop it before training.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from foresight.core.errors import ConfigError
from foresight.core.predict.features import current_index


@dataclass(frozen=True)
class QualityLimits:
    min_samples: int = 64
    min_active_target_ratio: float = 0.02  #: fraction of active slots' future steps with a target
    min_target_std: float = 1e-6  #: [m]
    min_mean_displacement: float = 1e-3  #: mean |target[T-1] - current position| [m]


def summarize(ds) -> dict[str, Any]:
    """Counts, active ratios and displacement statistics (over the whole dataset and per split)."""
    return SummaryStats(len(ds.meta.episodes)).add(ds).result(ds.meta.episodes)


class SummaryStats:
    """``summarize`` gathered chunk by chunk (a dataset written in pieces never is in memory whole): sums, the
    targets' mean and spread merged per chunk (Chan et al.), and the final displacements (one float per slot)."""

    def __init__(self, n_episodes: int) -> None:
        self.samples = 0
        self.per_episode = np.zeros(n_episodes, np.int64)
        self.mask_sum = self.mask_size = self.target_mask_sum = 0.0
        self.horizon = 0
        self.n, self.mean, self.m2 = 0, 0.0, 0.0
        self.disp: list[np.ndarray] = []

    def add(self, ds) -> SummaryStats:
        """Add a chunk of windows (a Dataset: arrays and meta)."""
        self.samples += len(ds)
        self.per_episode += np.bincount(ds.episode, minlength=len(self.per_episode))[: len(self.per_episode)]
        self.mask_sum += float(ds.mask.sum(dtype=np.float64))
        self.mask_size += ds.mask.size
        self.target_mask_sum += float(ds.target_mask.sum(dtype=np.float64))
        self.horizon = ds.target_mask.shape[-1]
        values = ds.target[ds.target_mask > 0].astype(np.float64).ravel()
        if len(values):
            n, mean = len(values), float(values.mean())
            m2 = float(((values - mean) ** 2).sum())
            delta, total = mean - self.mean, self.n + n
            self.mean += delta * n / total
            self.m2 += m2 + delta**2 * self.n * n / total
            self.n = total
        self.disp.append(_final_displacements(ds))
        return self

    def result(self, episodes) -> dict[str, Any]:
        disp = np.concatenate(self.disp) if self.disp else np.zeros(0, np.float32)
        split = np.array([e.split for e in episodes], dtype=object)
        per_split = {s: int(self.per_episode[split == s].sum()) for s in ("train", "val", "test")}
        eps = {s: sum(1 for e in episodes if e.split == s) for s in ("train", "val", "test")}
        active = self.mask_sum
        return {
            "samples": self.samples,
            "episodes": len(episodes),
            "samples_per_split": per_split,
            "episodes_per_split": eps,
            "active_agent_ratio": self.mask_sum / self.mask_size if self.mask_size else 0.0,
            "active_target_ratio": self.target_mask_sum / (active * self.horizon) if active else 0.0,
            "target_std_m": float(np.sqrt(self.m2 / self.n)) if self.n else 0.0,
            "final_displacement_m": {
                "mean": float(disp.mean()) if len(disp) else 0.0,
                "p50": float(np.percentile(disp, 50)) if len(disp) else 0.0,
                "p95": float(np.percentile(disp, 95)) if len(disp) else 0.0,
            },
        }


def _final_displacements(ds) -> np.ndarray:
    """|target at the last step - current position| [m] of slots whose last target exists."""
    px = current_index(ds.meta.timebase.history, "px")
    valid = ds.target_mask[..., -1] > 0
    return np.linalg.norm(ds.target[..., -1, :][valid] - ds.state[..., px : px + 2][valid], axis=-1)


def check_quality(ds, source: str, limits: QualityLimits | None = None) -> dict[str, Any]:
    """Return the summary, or raise ConfigError naming the first degenerate property."""
    limits = limits or QualityLimits()
    s = summarize(ds)
    problems = [
        (
            s["samples"] < limits.min_samples,
            "samples",
            f"only {s['samples']} samples (< {limits.min_samples})",
        ),
        (
            s["active_target_ratio"] <= limits.min_active_target_ratio,
            "target_mask",
            f"active target ratio {s['active_target_ratio']:.4f} <= {limits.min_active_target_ratio}: no usable targets",
        ),
        (
            s["target_std_m"] <= limits.min_target_std,
            "target",
            f"targets are constant (std {s['target_std_m']:.2e} m)",
        ),
        (
            s["final_displacement_m"]["mean"] <= limits.min_mean_displacement,
            "target",
            f"pedestrians do not move (mean displacement {s['final_displacement_m']['mean']:.2e} m)",
        ),
    ]
    for bad, item, message in problems:
        if bad:
            raise ConfigError(f"degenerate dataset: {message}", source=source, item=item)
    return s
