"""Imported scenes as prediction datasets, folds by scene, and TrajNet++ export.

``import_scenes`` reads every file first (``trajdata``: a malformed line stops the import naming file and line
before anything is written), then cuts each scene into focal-pedestrian windows with ETH/UCY's protocol and leakage
rules (``ethucy.scene_samples``: full observed history, backward-difference velocities, normalised on observed steps
only) on the declared time base. Each scene is an episode; ``test_scene`` names the held-out one (the others train;
``val_scene`` optionally validates), and ``scene_folds`` gives leave-one-scene-out over whatever scenes there are.
``import_scenes_to`` writes the windows to the dataset file piece by piece (``DatasetWriter``), so memory stays
bounded however long the recording, under a temporary name renamed at the end: a failed import leaves nothing.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator

from foresight.core import files
from foresight.core.errors import ConfigError
from foresight.core.predict.dataset import Dataset, DatasetMeta, EpisodeRecord
from foresight.core.predict.dataset_writer import DatasetWriter
from foresight.core.predict.ethucy import scene_samples
from foresight.core.predict.features import STEP_CHANNELS
from foresight.core.predict.mixing import dataset_from_episodes
from foresight.core.predict.samples import SampleArrays
from foresight.core.predict.timebase import ETHUCY_TIMEBASE, TimeBase
from foresight.core.predict.trajdata import parse_columns, read_scene_file, scene_files


class ImportScenesConfig(BaseModel):
    """Your own recordings -> one dataset: format, declared frame interval and units, time base, held-out scene."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    path: str  #: one file, or a folder of them (one scene per file)
    format: Literal["trajnet", "text"] = "text"
    columns: str = "frame,id,x,y"  #: text: the column order (other names are skipped columns)
    frame_interval: float = Field(gt=0, le=60)  #: [s] between consecutive annotated frames
    frame_step: float | None = Field(
        default=None, gt=0
    )  #: frame-number units per annotation (None: inferred)
    units: Literal["m", "cm", "mm"] = "m"
    timebase: dict[str, Any] = Field(default_factory=ETHUCY_TIMEBASE.to_dict)  #: dt, history, horizon
    max_agents: int = Field(default=12, ge=1, le=256)
    test_scene: str | None = None  #: the held-out scene (file stem); None: every scene is test (score only)
    val_scene: str | None = None

    @model_validator(mode="after")
    def _check(self) -> ImportScenesConfig:
        parse_columns(self.columns)
        tb = self.time_base()
        self.stride(tb)
        if self.val_scene is not None and self.val_scene == self.test_scene:
            raise ValueError("val_scene and test_scene must differ")
        return self

    def time_base(self) -> TimeBase:
        return TimeBase.from_dict(self.timebase, source="timebase")

    def stride(self, tb: TimeBase) -> int:
        k = round(tb.dt / self.frame_interval)
        if k < 1 or abs(k * self.frame_interval - tb.dt) > 1e-6 * max(1.0, tb.dt):
            raise ConfigError(
                f"time base dt {tb.dt:g} s is not a whole multiple of the frame interval {self.frame_interval:g} s",
                item="timebase.dt",
            )
        return k


def read_scenes(config: ImportScenesConfig) -> list[tuple[str, np.ndarray]]:
    """(scene name, rows) of every file, all read and checked before any window is cut."""
    paths = scene_files(Path(config.path), config.format)
    names = [p.stem for p in paths]
    for name, item in ((config.test_scene, "test_scene"), (config.val_scene, "val_scene")):
        if name is not None and name not in names:
            raise ConfigError(f"no scene {name!r} (scenes: {', '.join(names)})", item=item)
    cols = parse_columns(config.columns)
    return [
        (
            p.stem,
            read_scene_file(p, config.format, config.frame_interval, cols, config.frame_step, config.units),
        )
        for p in paths
    ]


def _split(name: str, config: ImportScenesConfig) -> str:
    if config.test_scene is None:
        return "test"
    return "test" if name == config.test_scene else "val" if name == config.val_scene else "train"


SEGMENT_FRAMES = (
    250  #: annotations per piece a long scene is cut in (the window table is frames x pedestrians)
)


def segments(rows: np.ndarray, span: int, length: int = SEGMENT_FRAMES) -> Iterator[np.ndarray]:
    """Rows (sorted by frame, consecutive annotations 1 apart) in pieces of ``length`` window starts, each with the
    ``span - 1`` frames after it: every window of ``span`` frames lies in exactly one piece, and a piece's table
    stays small however long the recording."""
    frames = rows[:, 0]
    lo, hi = int(frames[0]), int(frames[-1])
    if hi - lo + 1 <= length + span - 1:
        yield rows
        return
    for a in range(lo, hi + 1, length):
        i, j = np.searchsorted(frames, [a, a + length + span - 1], side="left")
        if j - i:
            yield rows[i:j]


def window_parts(rows: np.ndarray, tb: TimeBase, k: int, max_agents: int) -> Iterator[SampleArrays]:
    """A scene's windows, piece by piece (``segments``): what one piece of a long recording holds at a time."""
    span = (tb.history + tb.horizon - 1) * k + 1
    for piece in segments(rows, span):
        yield scene_samples(piece, tb, max_agents, stride=k, frame_step=1)


def _windows(rows: np.ndarray, tb: TimeBase, k: int, max_agents: int) -> SampleArrays:
    parts = list(window_parts(rows, tb, k, max_agents))
    if len(parts) == 1:
        return parts[0]
    cat = {
        n: np.concatenate([getattr(p, n) for p in parts]) for n in ("state", "target", "mask", "target_mask")
    }
    return SampleArrays(**cat, step=np.arange(len(cat["state"]), dtype=np.int64))


def _meta(scenes: list[tuple[str, np.ndarray]], config: ImportScenesConfig) -> DatasetMeta:
    episodes = [EpisodeRecord(scenario=n, seed=None, split=_split(n, config), role="real") for n, _ in scenes]
    return DatasetMeta(
        timebase=config.time_base(),
        max_agents=config.max_agents,
        frame_convention="focal_pedestrian",
        source="real",
        episodes=episodes,
        generator={"kind": "scenes", **config.model_dump(), "scenes": [n for n, _ in scenes]},
    )


def _no_windows(config: ImportScenesConfig) -> ConfigError:
    tb = config.time_base()
    return ConfigError(
        f"no window of {tb.history + tb.horizon} consecutive annotations at {tb.describe()} in any scene",
        source=config.path,
    )


def build_dataset(scenes: list[tuple[str, np.ndarray]], config: ImportScenesConfig) -> Dataset:
    """One dataset of the scenes' windows, each scene an episode of its split."""
    tb = config.time_base()
    k = config.stride(tb)
    meta = _meta(scenes, config)
    episodes = [
        (rec, _windows(rows, tb, k, config.max_agents))
        for rec, (_, rows) in zip(meta.episodes, scenes, strict=True)
    ]
    if not sum(len(s.state) for _, s in episodes):
        raise _no_windows(config)
    return dataset_from_episodes(episodes, meta)


def import_scenes(config: ImportScenesConfig) -> Dataset:
    return build_dataset(read_scenes(config), config)


def import_scenes_to(config: ImportScenesConfig, path: Path) -> dict[str, Any]:
    """``save_dataset(import_scenes(config), path)`` in bounded memory: the windows go to the file piece by piece
    (``DatasetWriter``), never all at once. Every file is read and checked first; returns the dataset record."""
    scenes = read_scenes(config)
    tb = config.time_base()
    k = config.stride(tb)
    with DatasetWriter(path, _meta(scenes, config)) as writer:
        for i, (_, rows) in enumerate(scenes):
            for part in window_parts(rows, tb, k, config.max_agents):
                writer.add(i, part)
        if not writer.count:
            raise _no_windows(config)
        return writer.finish()


def scene_folds(
    scenes: list[tuple[str, np.ndarray]], config: ImportScenesConfig
) -> Iterator[tuple[str, Dataset]]:
    """Leave-one-scene-out: (held-out scene, dataset with it as test and the others as train), scene by scene."""
    if len(scenes) < 2:
        raise ConfigError("leave-one-scene-out needs at least two scenes", source=config.path)
    for name, _ in scenes:
        fold = config.model_copy(update={"test_scene": name, "val_scene": None})
        yield name, build_dataset(scenes, fold)


def export_trajnet(ds: Dataset, path: Path, dt: float | None = None) -> int:
    """Write every sample of ``ds`` as one TrajNet++ scene (its focal pedestrian primary) in the sample's own frame:
    observed steps from the features, the future from the targets. Frames are numbered per sample so that scenes
    never overlap; pedestrian ids are sample x slots + slot. Returns the number of scenes written."""
    tb = ds.meta.timebase
    dt = dt or tb.dt
    H, T = tb.history, tb.horizon
    C = len(STEP_CHANNELS)
    px, py, ok = (STEP_CHANNELS.index(c) for c in ("px", "py", "valid"))
    cols = np.arange(H) * C
    N = ds.mask.shape[1]
    fps = round(1.0 / dt, 6)
    with files.replacing(Path(path)) as tmp, tmp.open("w", encoding="utf-8") as out:
        for s in range(len(ds)):
            base = s * (H + T)
            primary = s * N
            out.write(
                json.dumps({"scene": {"id": s, "p": primary, "s": base, "e": base + H + T - 1, "fps": fps}})
            )
            out.write("\n")
            for slot in np.flatnonzero(ds.mask[s] > 0).tolist():
                f = ds.state[s, slot]
                for h in range(H):
                    if f[cols[h] + ok] > 0.5:
                        rec = {
                            "f": base + h,
                            "p": primary + slot,
                            "x": round(float(f[cols[h] + px]), 4),
                            "y": round(float(f[cols[h] + py]), 4),
                        }
                        out.write(json.dumps({"track": rec}) + "\n")
                for t in np.flatnonzero(ds.target_mask[s, slot] > 0).tolist():
                    x, y = (round(float(v), 4) for v in ds.target[s, slot, t])
                    out.write(
                        json.dumps({"track": {"f": base + H + t, "p": primary + slot, "x": x, "y": y}}) + "\n"
                    )
    return len(ds)
