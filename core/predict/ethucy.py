"""ETH/UCY import (leave-one-scene-out folds) into the common dataset format.

Protocol (``shared/docs/prediction-real-data.md``): a sample is one pedestrian (the focal one)
present in H + T consecutive annotated frames (frame step 10 = 0.4 s; a frame gap breaks a
track), sliding by one frame. Neighbours are the other pedestrians present at the current frame,
with whatever part of the observed history they have (valid flags; never future data). Frame
convention ``focal_pedestrian``: the focal pedestrian's current position and last observed
displacement place the frame (observed steps only). Only the focal slot carries targets, so
ADE/FDE over ``target_mask`` are the benchmark's per-window numbers; training splits may also
carry the neighbours' futures (``neighbour_targets``: where each neighbour is annotated, in the
same focal frame), which gives the model several supervised pedestrians per window instead of one
without changing what is scored (validation and test stay focal-only).

Leakage rules enforced here: the fold's test scene never appears in its train/val files; velocities
are backward differences (``extract_features``); the full H-step history of the focal pedestrian is
required.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import ConfigDict, Field

from foresight.core.bounds import BoundedConfig
from foresight.core.errors import ConfigError, NotFoundError
from foresight.core.predict.dataset import REVERSED, Dataset, DatasetMeta, EpisodeRecord, save_dataset
from foresight.core.predict.features import Window, extract_features, world_to_ego
from foresight.core.predict.mixing import dataset_from_episodes
from foresight.core.predict.samples import SampleArrays
from foresight.core.predict.timebase import ETHUCY_TIMEBASE, TimeBase
from foresight.core.runtime.context import StageContext
from foresight.core.runtime.refs import Ident
from foresight.core.scenarios.ethucy import read_scene

FOLDS = ("eth", "hotel", "univ", "zara1", "zara2")
#: scene-file prefixes of each fold's held-out scene; they must never be in that fold's train/val
TEST_SCENES = {
    "eth": ("biwi_eth",),
    "hotel": ("biwi_hotel",),
    "univ": ("students001", "students003"),
    "zara1": ("crowds_zara01",),
    "zara2": ("crowds_zara02",),
}
FRAME_STEP = 10  #: frame-index units per annotation
FRAME_DT = 0.4  #: seconds per annotation [s]


def _stride(timebase: TimeBase) -> int:
    k = round(timebase.dt / FRAME_DT)
    if k < 1 or abs(k * FRAME_DT - timebase.dt) > 1e-6:
        raise ConfigError(
            f"ETH/UCY is annotated every {FRAME_DT} s; time base dt {timebase.dt} is not a multiple",
            item="timebase.dt",
        )
    return k


def focal_windows(rows: np.ndarray, span: int, step: int = FRAME_STEP) -> Iterator[tuple[int, np.ndarray]]:
    """(ped id, (span,) frame numbers) of every run of ``span`` consecutive annotated frames (``step`` apart)."""
    for pid in np.unique(rows[:, 1]):
        frames = np.sort(rows[rows[:, 1] == pid, 0].astype(np.int64))
        gaps = np.diff(frames) != step
        breaks = np.concatenate([[0], np.cumsum(gaps)])  # run label per frame
        for i in range(len(frames) - span + 1):
            if breaks[i] == breaks[i + span - 1]:
                yield int(pid), frames[i : i + span]


class _SceneTable:
    """One scene file as dense (frames, pedestrians) arrays: a window's history, future and neighbours' targets are
    then a few index operations instead of a search per frame and sample. Where a file repeats a (frame, id) row the
    first one counts, as the per-frame match it replaces did."""

    def __init__(self, rows: np.ndarray):
        frame, ped = rows[:, 0].astype(np.int64), rows[:, 1].astype(np.int64)
        self.frames, f_idx = np.unique(frame, return_inverse=True)
        self.peds, p_idx = np.unique(ped, return_inverse=True)
        _, first = np.unique(f_idx * len(self.peds) + p_idx, return_index=True)
        self.pos = np.zeros((len(self.frames), len(self.peds), 2))  #: [m]
        self.present = np.zeros((len(self.frames), len(self.peds)), dtype=bool)
        self.pos[f_idx[first], p_idx[first]] = rows[first, 2:4]
        self.present[f_idx[first], p_idx[first]] = True
        order = np.argsort(f_idx, kind="stable")  # each frame's ids in file order
        self.ids = np.split(ped[order], np.cumsum(np.bincount(f_idx, minlength=len(self.frames)))[:-1])

    def rows_of(self, frames: np.ndarray) -> np.ndarray:
        return np.searchsorted(self.frames, frames)

    def cols_of(self, ids: np.ndarray) -> np.ndarray:
        return np.searchsorted(self.peds, ids)


def scene_samples(
    rows: np.ndarray,
    timebase: TimeBase,
    max_agents: int,
    neighbour_targets: bool = False,
    *,
    stride: int | None = None,
    frame_step: int = FRAME_STEP,
) -> SampleArrays:
    """All focal-pedestrian windows of one scene file, on ``timebase`` (neighbours' futures as targets too when
    ``neighbour_targets``; for training splits only). Other recordings than ETH/UCY's give their annotations'
    ``frame_step`` (frame units apart) and ``stride`` (annotations per time-base step)."""
    k = stride or _stride(timebase)
    H, T = timebase.history, timebase.horizon
    span = (H + T - 1) * k + 1
    scene = _SceneTable(rows)
    out = {n: [] for n in ("state", "target", "mask", "target_mask")}
    for pid, frames in focal_windows(rows, span, frame_step):
        grid = scene.rows_of(frames[::k])  # H + T grid points (all annotated: the focal pedestrian is there)
        ids = scene.ids[grid[H - 1]]
        ids = np.concatenate([[pid], ids[ids != pid]])
        cols = scene.cols_of(ids)
        hist, valid = scene.pos[grid[:H]][:, cols].transpose(1, 0, 2), scene.present[grid[:H]][:, cols].T
        d = hist[0, -1] - hist[0, -2] if H > 1 else np.zeros(2)
        heading = float(np.arctan2(d[1], d[0])) if np.hypot(*d) > 1e-9 else 0.0
        w = Window(np.array([*hist[0, -1], heading]), np.zeros(2), None, ids, hist, valid)
        f = extract_features(w, timebase, max_agents)
        target = np.zeros((max_agents, T, 2), np.float32)
        tmask = np.zeros((max_agents, T), np.float32)
        target[0], tmask[0] = world_to_ego(scene.pos[grid[H:], cols[0]], f.origin, f.heading), 1.0
        if neighbour_targets:
            slots = np.nonzero(f.ped_ids[1:] >= 0)[0] + 1
            seen = scene.present[grid[H:]][:, scene.cols_of(f.ped_ids[slots])].T  # (slots, T)
            future = world_to_ego(
                scene.pos[grid[H:]][:, scene.cols_of(f.ped_ids[slots])], f.origin, f.heading
            )
            target[slots] = np.where(seen[..., None], future.transpose(1, 0, 2), 0.0)
            tmask[slots] = seen
        for name, value in (
            ("state", f.features),
            ("mask", f.mask),
            ("target", target),
            ("target_mask", tmask),
        ):
            out[name].append(value)
    n = len(out["state"])
    if not n:
        return SampleArrays(
            np.zeros((0, max_agents, 5 * H + 5), np.float32),
            np.zeros((0, max_agents, T, 2), np.float32),
            np.zeros((0, max_agents), np.float32),
            np.zeros((0, max_agents, T), np.float32),
            np.zeros(0, np.int64),
        )
    return SampleArrays(
        np.stack(out["state"]),
        np.stack(out["target"]),
        np.stack(out["mask"]),
        np.stack(out["target_mask"]),
        np.arange(n, dtype=np.int64),
    )


def reverse_time(rows: np.ndarray) -> np.ndarray:
    """The scene played backwards, rows (frame, ped_id, x, y) with frame f renumbered first + last - f (annotated
    frames stay FRAME_STEP apart, so every window of the scene is a window of the reversed one, read backwards)."""
    out = rows.copy()
    out[:, 0] = rows[:, 0].min() + rows[:, 0].max() - rows[:, 0]
    return out[np.argsort(out[:, 0], kind="stable")]


def fold_files(root: Path, fold: str) -> dict[str, list[Path]]:
    """{split: files} of a fold folder, after checking that no test scene leaks into train/val."""
    if fold not in FOLDS:
        raise ConfigError(
            f"unknown fold {fold!r}; expected one of {', '.join(FOLDS)}", source=root, item="fold"
        )
    base = Path(root) / fold
    if not base.is_dir():
        raise NotFoundError(f"ETH/UCY fold folder {base} does not exist")
    files = {s: sorted((base / s).glob("*.txt")) for s in ("train", "val", "test")}
    for split in ("train", "val"):
        for path in files[split]:
            if path.name.startswith(TEST_SCENES[fold]):
                raise ConfigError(
                    f"test scene {path.stem} of fold {fold} appears in its {split} split (leakage)",
                    source=path,
                    item=split,
                )
    for path in files["test"]:
        if not path.name.startswith(TEST_SCENES[fold]):
            raise ConfigError(f"{path.name} is not fold {fold}'s test scene", source=path, item="test")
    return files


def import_fold(
    root: Path,
    fold: str,
    timebase: TimeBase = ETHUCY_TIMEBASE,
    max_agents: int = 12,
    splits: tuple[str, ...] = ("train", "val", "test"),
    neighbour_targets: tuple[str, ...] = (),
    reversed_splits: tuple[str, ...] = (),
) -> Dataset:
    """One dataset with the fold's train, val and test files as episodes of those splits; the splits named in
    ``neighbour_targets`` (training only: never test) also carry the neighbours' futures, and each file of the splits
    in ``reversed_splits`` (training only) is followed by that scene played backwards (``reverse_time``)."""
    if "test" in neighbour_targets:
        raise ConfigError(
            "neighbour targets on the test split would change what is scored", item="neighbour_targets"
        )
    if "test" in reversed_splits:
        raise ConfigError("a reversed test scene would change what is scored", item="reversed_splits")
    files = fold_files(root, fold)
    episodes = []
    for split in splits:
        for path in files[split]:
            rec = EpisodeRecord(scenario=f"{split}/{path.stem}", seed=None, split=split, role="real")
            rows = read_scene(path)
            episodes.append((rec, scene_samples(rows, timebase, max_agents, split in neighbour_targets)))
            if split in reversed_splits:
                rec = EpisodeRecord(
                    scenario=f"{split}/{path.stem}{REVERSED}", seed=None, split=split, role="real"
                )
                episodes.append(
                    (rec, scene_samples(reverse_time(rows), timebase, max_agents, split in neighbour_targets))
                )
    meta = DatasetMeta(
        timebase=timebase,
        max_agents=max_agents,
        frame_convention="focal_pedestrian",
        source="real",
        episodes=[],
        generator={
            "kind": "ethucy",
            "fold": fold,
            "splits": list(splits),
            "files": {s: [p.name for p in files[s]] for s in splits},
            "frame_step": FRAME_STEP,
            "frame_dt": FRAME_DT,
            "max_agents": max_agents,
            **({"neighbour_targets": list(neighbour_targets)} if neighbour_targets else {}),
            **({"reversed_splits": list(reversed_splits)} if reversed_splits else {}),
        },
    )
    return dataset_from_episodes(episodes, meta)


class ImportEthucyConfig(BoundedConfig):
    """Stage ``import_ethucy``: one fold of an ETH/UCY folder on the worker's disk -> a dataset artifact."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    root: str  #: folder holding <fold>/train|val|test (e.g. shared/reference/ethucy)
    fold: str
    max_agents: int = Field(default=12, ge=1, le=256)
    output: str = "dataset.npz"


class ImportDatasetConfig(BoundedConfig):
    """Job ``import_dataset``: one fold of a named data root (the service maps names to folders on its disk,
    so the spec holds no server path)."""

    model_config = ConfigDict(extra="forbid", frozen=True)
    source: Literal["ethucy"] = "ethucy"
    root: Ident = "ethucy"  #: data root name (``GET /v1/data-roots``), never a path
    fold: Literal["eth", "hotel", "univ", "zara1", "zara2"]
    max_agents: int = Field(default=12, ge=1, le=256)


def run_import_ethucy(config: ImportEthucyConfig, ctx: StageContext) -> dict[str, Any]:
    """Write the fold's dataset (train/val/test episodes) and return its record (path, sha256, meta, summary)."""
    ctx.progress(0.0, f"importing fold {config.fold}")
    ds = import_fold(Path(config.root), config.fold, ETHUCY_TIMEBASE, config.max_agents)
    record = save_dataset(ds, ctx.artifact(config.output))
    ctx.progress(1.0, f"{len(ds)} samples")
    return {**record, "path": config.output}
