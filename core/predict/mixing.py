"""Assembling datasets: episode-level train/val split, and the base + hard-case mix.

The split is decided per episode before any oversampling; the mix repeats only training rows of
hard-case episodes, so validation never sees a duplicate or an overlapping window of a training
episode (the reference duplicated rows, then split by sample).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from foresight.core.errors import ConfigError
from foresight.core.predict.dataset import Dataset, DatasetMeta, EpisodeRecord
from foresight.core.predict.samples import SampleArrays


def assign_splits(n_episodes: int, val_fraction: float, seed: int) -> list[str]:
    """'train'/'val' per episode: a seeded permutation puts round(n·f) episodes (≥ 1 when n ≥ 2) in val."""
    if not 0 <= val_fraction < 1:
        raise ConfigError(f"val_fraction must be in [0, 1), got {val_fraction}", item="val_fraction")
    n_val = round(n_episodes * val_fraction)
    if val_fraction > 0 and n_episodes >= 2:
        n_val = min(max(n_val, 1), n_episodes - 1)
    order = np.random.default_rng(seed).permutation(n_episodes)
    splits = ["train"] * n_episodes
    for i in order[:n_val]:
        splits[int(i)] = "val"
    return splits


def dataset_from_episodes(episodes: list[tuple[EpisodeRecord, SampleArrays]], meta: DatasetMeta) -> Dataset:
    """Concatenate per-episode samples; ``meta.episodes`` is replaced by the given records, in order."""
    meta = replace(meta, episodes=[rec for rec, _ in episodes])
    parts = [s for _, s in episodes]
    if not parts:
        raise ConfigError("no episodes to build a dataset from", item="episodes")
    cat = {
        k: np.concatenate([getattr(p, k) for p in parts]) for k in ("state", "target", "mask", "target_mask")
    }
    ep = np.concatenate([np.full(len(p), i, dtype=np.int64) for i, p in enumerate(parts)])
    return Dataset(**cat, episode=ep, meta=meta)


def mix_datasets(base: Dataset, hard: Dataset, hardcase_repeat: int, source: str = "mix") -> Dataset:
    """base + hard-case, each hard-case TRAINING row repeated ``hardcase_repeat`` times (after the split)."""
    if hardcase_repeat < 1:
        raise ConfigError(
            f"hardcase_repeat must be >= 1, got {hardcase_repeat}", source=source, item="hardcase_repeat"
        )
    a, b = base.meta, hard.meta
    for item, x, y in (
        ("timebase", a.timebase.to_dict(), b.timebase.to_dict()),
        ("max_agents", a.max_agents, b.max_agents),
        ("frame_convention", a.frame_convention, b.frame_convention),
        ("feature_names", a.feature_names, b.feature_names),
    ):
        if x != y:
            raise ConfigError(
                f"base and hard-case datasets differ in {item}: {x!r} vs {y!r}", source=source, item=item
            )
    hard_train = np.array([e.split == "train" for e in b.episodes], dtype=bool)[hard.episode]
    reps = np.where(hard_train, hardcase_repeat, 1)
    rows = np.repeat(np.arange(len(hard)), reps)
    hard_eps = [replace(e, role="hardcase") for e in b.episodes]
    meta = replace(
        a,
        episodes=list(a.episodes) + hard_eps,
        source="mixed" if a.source != b.source else a.source,
        generator={"mix": {"hardcase_repeat": hardcase_repeat}, "base": a.generator, "hardcase": b.generator},
        generator_config_hash="",
        lineage=[
            {"role": "base", "hash": a.generator_config_hash},
            {"role": "hardcase", "hash": b.generator_config_hash},
        ],
    )
    meta.__post_init__()
    return Dataset(
        state=np.concatenate([base.state, hard.state[rows]]),
        target=np.concatenate([base.target, hard.target[rows]]),
        mask=np.concatenate([base.mask, hard.mask[rows]]),
        target_mask=np.concatenate([base.target_mask, hard.target_mask[rows]]),
        episode=np.concatenate([base.episode, hard.episode[rows] + len(a.episodes)]),
        meta=meta,
    )
