"""Leave-one-scene-out in closed loop: which recorded scenes a checkpoint has seen, and which it held out.

A model trained on recordings (an ETH/UCY fold, your own scenes) keeps the scenes of each split of its dataset in its
checkpoint (``dataset.scenes``, from ``DatasetMeta.recorded_scenes``: file stems such as ``biwi_hotel_train``). Driving
the planner on a replay of a recorded scene (a matrix entry's ``replay: {scene: ...}``) measures that model on people
it has never seen only when the scene was in neither split it learned from: train (its weights) and val (its epoch).
:func:`require_held_out` refuses the model otherwise, naming the scene and the model; :func:`model_for_scene` picks,
among fold models, the one whose test scene the replay's is.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from foresight.core.errors import ConfigError

SEEN_SPLITS = ("train", "val")  #: the splits a model learns from (weights; epoch selection)
SPLIT_SUFFIXES = ("_train", "_val")  #: how ETH/UCY names a scene's part in a fold's train and val folders


def scene_name(stem: str) -> str:
    """The scene a recorded file belongs to: ``biwi_hotel_train`` -> ``biwi_hotel`` (a replay names the whole
    scene's file, ``raw/all_data/biwi_hotel.txt``)."""
    for suffix in SPLIT_SUFFIXES:
        if stem.endswith(suffix):
            return stem.removesuffix(suffix)
    return stem


@dataclass(frozen=True)
class SceneLineage:
    """What a checkpoint trained on recordings has seen (``seen``: scene -> the files of it) and held out."""

    model_id: str
    path: Path
    sha256: str
    seen: dict[str, tuple[str, ...]]  #: scene -> its files in train and val
    held_out: tuple[str, ...]  #: the test split's scenes

    @classmethod
    def from_scenes(
        cls, model_id: str, path: Path, sha256: str, scenes: dict[str, list[str]]
    ) -> SceneLineage:
        seen: dict[str, list[str]] = {}
        for split in SEEN_SPLITS:
            for stem in scenes.get(split, []):
                seen.setdefault(scene_name(stem), []).append(stem)
        held = tuple(sorted({scene_name(s) for s in scenes.get("test", [])}))
        return cls(model_id, Path(path), sha256, {k: tuple(v) for k, v in sorted(seen.items())}, held)

    def provenance(self) -> dict[str, object]:
        return {
            "model_id": self.model_id,
            "checkpoint": str(self.path),
            "sha256": self.sha256,
            "held_out": list(self.held_out),
            "trained_on": sorted(self.seen),
        }


def read_lineage(path: Path, model_id: str | None = None) -> SceneLineage:
    """The scene lineage recorded in a checkpoint; ConfigError naming the file when it records none (a model trained
    on simulator data, or before checkpoints kept their scenes: retrain it)."""
    from foresight.core.predict.nn.checkpoint import checkpoint_bytes, read_checkpoint

    path = Path(path)
    _, sha = checkpoint_bytes(path)
    payload = read_checkpoint(path, expect_sha256=sha)
    scenes = (payload.get("dataset") or {}).get("scenes")
    if not isinstance(scenes, dict) or not scenes.get("train"):
        raise ConfigError(
            "the checkpoint records no recorded scenes it trained on (dataset.scenes): a model trained on simulator "
            "data, or on recordings before checkpoints kept their scenes; train it again (foresight predict-eval "
            "--local --train --ethucy ROOT --fold F)",
            source=path,
            item="dataset.scenes",
        )
    return SceneLineage.from_scenes(model_id or str(path), path, sha, scenes)


def require_held_out(lineage: SceneLineage, scene: str) -> None:
    """ConfigError when the model trained (or chose its epoch) on ``scene``: a replay of it would score the model on
    the very people it learned from."""
    if scene in lineage.seen:
        files = ", ".join(lineage.seen[scene])
        raise ConfigError(
            f"model {lineage.model_id!r} trained on scene {scene!r} ({files}): it cannot drive a replay of that scene "
            f"(leakage); use the fold model that holds {scene!r} out"
            + (f" (this one holds out {', '.join(lineage.held_out)})" if lineage.held_out else ""),
            source=lineage.path,
            item="dataset.scenes",
        )


def model_for_scene(scene: str, models: list[SceneLineage]) -> SceneLineage:
    """The model whose held-out (test) scenes include ``scene``, checked by :func:`require_held_out`; ConfigError
    naming the scene and what each model holds out when none does, or the models when several do."""
    holders = [m for m in models if scene in m.held_out]
    if len(holders) > 1:
        raise ConfigError(
            f"{len(holders)} models hold out replay scene {scene!r} ({', '.join(m.model_id for m in holders)}): "
            "give one set of fold models, or name the one to use",
            item="fold models",
        )
    if holders:
        require_held_out(holders[0], scene)
        return holders[0]
    given = "; ".join(f"{m.model_id}: {', '.join(m.held_out) or 'none'}" for m in models) or "no models given"
    raise ConfigError(
        f"no fold model holds out replay scene {scene!r} (held out by the models given: {given})",
        item="fold models",
    )
