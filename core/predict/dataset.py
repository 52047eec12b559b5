"""The prediction dataset: one ``.npz`` of arrays plus a JSON metadata record (also written beside
it as ``<name>.json`` with the summary, for people).

Arrays: ``state`` (S, N, F) float32, ``target`` (S, N, T, 2) float32 (ego frame at the sample's
step), ``mask`` (S, N), ``target_mask`` (S, N, T), ``episode`` (S,) int64 (row in the episode
table). The episode table in the metadata holds each episode's (scenario, seed) and its split
(train | val | test): splits are by episode, decided before any oversampling, so no window of a
validation episode is ever also a training window.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from foresight.core import files
from foresight.core.errors import ConfigError, NotFoundError
from foresight.core.predict.features import FRAME_CONVENTIONS, feature_dim, feature_names
from foresight.core.predict.quality import summarize
from foresight.core.predict.timebase import TimeBase
from foresight.core.version import code_version

SCHEMA_VERSION = "foresight.predict.dataset/1"
ARRAYS = ("state", "target", "mask", "target_mask", "episode")
SPLITS = ("train", "val", "test")
REVERSED = "~reversed"  #: suffix of a recorded scene played backwards (``ethucy.import_fold``)


@dataclass
class EpisodeRecord:
    scenario: str  #: scenario name (simulator) or scene file (real data)
    seed: int | None  #: episode seed; None for real data
    split: str  #: train | val | test
    role: str = "base"  #: base | hardcase | real


@dataclass
class DatasetMeta:
    timebase: TimeBase
    max_agents: int
    frame_convention: str  #: see core.predict.features
    source: Literal["sim", "real", "mixed"]
    episodes: list[EpisodeRecord]
    generator: dict[str, Any] = field(default_factory=dict)  #: the config that produced it
    generator_config_hash: str = ""
    code_version: str = field(default_factory=code_version)
    schema_version: str = SCHEMA_VERSION
    feature_names: list[str] = field(default_factory=list)
    lineage: list[dict[str, Any]] = field(default_factory=list)  #: parent datasets (id, hash, role)

    def __post_init__(self) -> None:
        if not self.feature_names:
            self.feature_names = feature_names(self.timebase.history)
        if not self.generator_config_hash:
            self.generator_config_hash = config_hash(self.generator)

    def recorded_scenes(self) -> dict[str, list[str]]:
        """The recorded scenes (real-data episodes: ``split/scene file``, a backwards copy under its scene) of each
        split: what a model trained on this dataset has seen, kept in its checkpoint so that a closed-loop run on a
        replay of a recorded scene can refuse a model that trained on it. Empty for simulator data."""
        scenes: dict[str, set[str]] = {}
        for e in self.episodes:
            if e.role == "real":
                scene = e.scenario.split("/", 1)[-1].removesuffix(REVERSED)
                scenes.setdefault(e.split, set()).add(scene)
        return {split: sorted(names) for split, names in sorted(scenes.items())}

    def to_json(self) -> dict[str, Any]:
        d = asdict(self)
        d["timebase"] = self.timebase.to_dict()
        return d

    @classmethod
    def from_json(cls, d: dict[str, Any], source: str) -> DatasetMeta:
        if d.get("schema_version") != SCHEMA_VERSION:
            raise ConfigError(
                f"unsupported dataset schema {d.get('schema_version')!r}, expected {SCHEMA_VERSION}",
                source=source,
                item="schema_version",
            )
        d = dict(d)
        d["timebase"] = TimeBase.from_dict(d["timebase"], source=source)
        d["episodes"] = [EpisodeRecord(**e) for e in d["episodes"]]
        return cls(**d)


def config_hash(config: Any) -> str:
    """sha256 (first 16 hex) of a config's canonical JSON."""
    return hashlib.sha256(json.dumps(config, sort_keys=True, default=str).encode()).hexdigest()[:16]


@dataclass
class Dataset:
    state: np.ndarray
    target: np.ndarray
    mask: np.ndarray
    target_mask: np.ndarray
    episode: np.ndarray
    meta: DatasetMeta

    def __len__(self) -> int:
        return len(self.episode)

    def validate(self, source: str = "dataset") -> Dataset:
        """Raise ConfigError when the arrays do not agree with each other or with the metadata."""
        S, N, T, F = (
            len(self.episode),
            self.meta.max_agents,
            self.meta.timebase.horizon,
            feature_dim(self.meta.timebase.history),
        )
        want = {"state": (S, N, F), "target": (S, N, T, 2), "mask": (S, N), "target_mask": (S, N, T)}
        for name, shape in want.items():
            if getattr(self, name).shape != shape:
                raise ConfigError(
                    f"array {name} has shape {getattr(self, name).shape}, expected {shape}",
                    source=source,
                    item=name,
                )
        if S and (self.episode.min() < 0 or self.episode.max() >= len(self.meta.episodes)):
            raise ConfigError("episode index outside the episode table", source=source, item="episode")
        if self.meta.frame_convention not in FRAME_CONVENTIONS:
            raise ConfigError(
                f"unknown frame convention {self.meta.frame_convention!r}",
                source=source,
                item="frame_convention",
            )
        if self.meta.feature_names != feature_names(self.meta.timebase.history):
            raise ConfigError(
                "feature names differ from this code's feature layout", source=source, item="feature_names"
            )
        if np.any(self.target_mask > self.mask[..., None]):
            raise ConfigError("target_mask set on an inactive slot", source=source, item="target_mask")
        return self

    def split_indices(self, split: str) -> np.ndarray:
        """Sample indices whose episode belongs to ``split``."""
        in_split = np.array([e.split == split for e in self.meta.episodes], dtype=bool)
        return np.flatnonzero(in_split[self.episode]) if len(self.meta.episodes) else np.zeros(0, np.int64)

    def subset(self, index: np.ndarray) -> Dataset:
        return Dataset(
            self.state[index],
            self.target[index],
            self.mask[index],
            self.target_mask[index],
            self.episode[index],
            self.meta,
        )


def save_dataset(ds: Dataset, path: Path) -> dict[str, Any]:
    """Write ``path`` (.npz) and ``path.with_suffix('.json')`` (metadata + summary); return the record."""
    ds.validate(str(path))
    path = Path(path)
    meta_json = json.dumps(ds.meta.to_json(), sort_keys=True)
    with files.replacing(path) as tmp, tmp.open("wb") as fh:
        np.savez_compressed(fh, **{k: getattr(ds, k) for k in ARRAYS}, meta_json=np.array(meta_json))
    record = {
        "path": str(path),
        "sha256": file_sha256(path),
        "meta": ds.meta.to_json(),
        "summary": summarize(ds),
    }
    files.write_text(path.with_suffix(".json"), json.dumps(record, indent=2, sort_keys=True))
    return record


def load_dataset(path: Path) -> Dataset:
    path = Path(path)
    if not path.is_file():
        raise NotFoundError(f"dataset file {path} does not exist")
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: z[k] for k in ARRAYS}
            meta = json.loads(str(z["meta_json"]))
    except (KeyError, ValueError, OSError) as exc:
        raise ConfigError(f"not a prediction dataset ({exc})", source=path) from None
    return Dataset(**arrays, meta=DatasetMeta.from_json(meta, str(path))).validate(str(path))


def file_sha256(path: Path) -> str:
    h = hashlib.sha256()
    with Path(path).open("rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def resolve_dataset_path(ref: str, ctx) -> Path:
    """A local ``.npz`` path as given (in-process runs only), else a dataset id resolved by the stage context."""
    return ctx.local_file(ref, (".npz",)) or ctx.resolve_dataset(ref)
