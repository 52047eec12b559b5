"""Leave-one-scene-out in closed loop: a checkpoint trained on recordings keeps the scenes it saw, and a model that saw a
replay's scene is refused for it, naming the scene and the model."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from foresight.core.errors import ConfigError
from foresight.core.predict.held_out import (
    SceneLineage,
    model_for_scene,
    read_lineage,
    require_held_out,
    scene_name,
)
from foresight.core.runtime.context import StageContext
from foresight.core.training.predict_eval import PredictEvalConfig, run_predict_eval
from tests.unit.bench_scripts import BENCH, load_bench

REPO = BENCH.parent
TINY = {"epochs": 1, "ensemble": 1, "hidden": 8, "blocks": 1, "batch_size": 512}
HOTEL_REPLAY = "replay_biwi_hotel_6850"  #: a stress-suite replay of the hotel fold's test scene
ETH_REPLAY = "replay_biwi_eth_1030"  #: ... of a scene the hotel fold trains on


def _lineage(scenes: dict[str, list[str]], ident: str = "m") -> SceneLineage:
    return SceneLineage.from_scenes(ident, Path(f"/models/{ident}.pt"), "0" * 64, scenes)


def test_scene_names_drop_the_split_suffix_only():
    assert scene_name("biwi_hotel_train") == "biwi_hotel" and scene_name("students001_val") == "students001"
    assert scene_name("biwi_eth") == "biwi_eth" and scene_name("uni_examples") == "uni_examples"


def test_a_model_that_saw_the_scene_in_train_or_val_is_refused_by_name():
    eth_fold = _lineage(
        {
            "train": ["biwi_hotel_train", "crowds_zara01_train"],
            "val": ["crowds_zara02_val"],
            "test": ["biwi_eth"],
        },
        "eth-fold",
    )
    require_held_out(eth_fold, "biwi_eth")  # its test scene: fine
    require_held_out(eth_fold, "students001")  # never seen at all: fine
    with pytest.raises(ConfigError) as trained:
        require_held_out(eth_fold, "biwi_hotel")
    assert "'eth-fold'" in str(trained.value) and "'biwi_hotel'" in str(trained.value)
    assert "biwi_hotel_train" in str(trained.value) and "holds out biwi_eth" in str(trained.value)
    with pytest.raises(ConfigError, match="'crowds_zara02'"):  # validation chose its epoch: seen too
        require_held_out(eth_fold, "crowds_zara02")


def test_the_fold_model_holding_the_scene_out_is_picked_and_none_is_an_error():
    eth = _lineage({"train": ["biwi_hotel_train"], "test": ["biwi_eth"]}, "eth-fold")
    univ = _lineage({"train": ["biwi_eth_train"], "test": ["students001", "students003"]}, "univ-fold")
    assert model_for_scene("students003", [eth, univ]) is univ
    assert model_for_scene("biwi_eth", [eth, univ]) is eth
    with pytest.raises(
        ConfigError, match="no fold model holds out replay scene 'crowds_zara01'.*univ-fold: "
    ):
        model_for_scene("crowds_zara01", [eth, univ])
    twice = _lineage({"train": ["biwi_hotel_train"], "test": ["biwi_eth"]}, "eth-fold-seed1")
    with pytest.raises(
        ConfigError, match="2 models hold out replay scene 'biwi_eth' \\(eth-fold, eth-fold-seed1\\)"
    ):
        model_for_scene("biwi_eth", [eth, twice])
    leaky = _lineage({"train": ["biwi_eth_train"], "test": ["biwi_eth"]}, "leaky")  # held out and trained on
    with pytest.raises(ConfigError, match="'leaky' trained on scene 'biwi_eth'"):
        model_for_scene("biwi_eth", [leaky])


def test_a_simulator_model_records_no_scenes_and_is_refused_as_a_fold_model():
    path = REPO / "model" / "predictor-sim-default.pt"
    with pytest.raises(ConfigError, match="records no recorded scenes") as err:
        read_lineage(path)
    assert str(path) in str(err.value)


@pytest.fixture(scope="module")
def hotel_fold(shared_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A tiny hotel-fold model (first 400 rows of each recording, one epoch): trained on biwi_eth, holds biwi_hotel out."""
    root = tmp_path_factory.mktemp("ethucy")
    for src in sorted((shared_dir / "reference" / "ethucy" / "hotel").glob("*/*.txt")):
        dst = root / "hotel" / src.parent.name / src.name
        dst.parent.mkdir(parents=True, exist_ok=True)
        dst.write_text("".join(src.read_text().splitlines(keepends=True)[:400]))
    work = tmp_path_factory.mktemp("folds") / "hotel"
    config = PredictEvalConfig(train=TINY, ethucy=str(root), folds=["hotel"], reverse_train=True)
    run_predict_eval(config, StageContext(workdir=work, local_files=True))
    return work / "hotel" / "train" / "model.pt"


def test_a_trained_fold_checkpoint_keeps_its_scenes(hotel_fold: Path):
    lin = read_lineage(hotel_fold, "hotel-fold")
    assert lin.held_out == ("biwi_hotel",)
    assert {"biwi_eth", "crowds_zara01", "students001", "uni_examples"} <= set(lin.seen)
    assert "biwi_hotel" not in lin.seen  # the reversed copies are the same scenes, not new ones
    assert lin.seen["biwi_eth"] == ("biwi_eth_train", "biwi_eth_val")
    with pytest.raises(ConfigError, match="'hotel-fold' trained on scene 'biwi_eth'"):
        require_held_out(lin, "biwi_eth")


def _bench(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, str(BENCH / "real_data_closed_loop.py"), *args],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=300,
    )


def test_the_comparison_runs_each_predictor_on_the_same_replay_episode(hotel_fold: Path):
    run = _bench(
        "--fold-models", str(hotel_fold.parents[2]), "--scenarios", HOTEL_REPLAY, "--max-steps", "20",
        "--workers", "1", "--json",
    )  # fmt: skip
    assert run.returncode == 0, run.stderr[-2000:]
    out = json.loads(run.stdout)
    assert out["episodes"] == 1 and set(out["predictors"]) == {"ethucy", "default", "cv"}
    model = out["ethucy_models"]["biwi_hotel"]
    assert model["model_id"] == str(hotel_fold) and model["held_out"] == ["biwi_hotel"]
    assert "biwi_eth" in model["trained_on"] and "biwi_hotel" not in model["trained_on"]
    rows = {r["predictor"]: r for r in out["episode_rows"]}
    assert rows["ethucy"]["held_out_scene"] == "biwi_hotel" and rows["ethucy"]["model_id"] == str(hotel_fold)
    assert rows["default"]["model_id"] == "predictor-sim-default" and rows["cv"]["model_id"] == "cv"
    assert {(r["scenario"], r["seed"]) for r in rows.values()} == {(HOTEL_REPLAY, 0)}
    assert set(out["paired"]) == {"ethucy_vs_default", "ethucy_vs_cv"}


def test_a_model_trained_on_the_replays_scene_is_refused_naming_scene_and_model(hotel_fold: Path):
    pinned = _bench(
        "--fold-models", str(hotel_fold), "--model-for", f"biwi_eth={hotel_fold}", "--scenarios", ETH_REPLAY,
        "--max-steps", "5", "--workers", "1", "--json",
    )  # fmt: skip
    assert pinned.returncode != 0 and not pinned.stdout
    assert f"model '{hotel_fold}' trained on scene 'biwi_eth'" in pinned.stderr and "leakage" in pinned.stderr
    unheld = _bench("--fold-models", str(hotel_fold), "--scenarios", ETH_REPLAY, "--max-steps", "5", "--json")
    assert unheld.returncode != 0 and "no fold model holds out replay scene 'biwi_eth'" in unheld.stderr
    stray = _bench(
        "--fold-models", str(hotel_fold), "--model-for", f"biwi_eth={hotel_fold}", "--scenarios", HOTEL_REPLAY, "--json"
    )  # fmt: skip
    assert stray.returncode != 0 and "--model-for biwi_eth: no chosen replay scenario" in stray.stderr


def test_paired_counts_and_intervals_are_per_episode():
    summarize = load_bench("real_data_closed_loop").summarize
    outcomes = {  # (scenario, seed): ethucy, default, cv
        ("a", 0): ("success", "collision_pedestrian", "success"),
        ("a", 1): ("success", "success", "timeout"),
        ("b", 0): ("collision_pedestrian", "success", "collision_pedestrian"),
    }
    rows = [
        {"scenario": s, "seed": k, "predictor": w, "outcome": o}
        for (s, k), got in outcomes.items()
        for w, o in zip(("ethucy", "default", "cv"), got, strict=True)
    ]
    out = summarize(rows, {"a": "biwi_eth", "b": "biwi_hotel"})
    assert out["episodes"] == 3
    assert out["predictors"]["ethucy"]["success"] == 2 and out["predictors"]["cv"]["timeouts"] == 1
    assert out["predictors"]["default"]["success_per_scene"] == {"biwi_eth": "1/2", "biwi_hotel": "1/1"}
    assert out["predictors"]["ethucy"]["collision_interval"][0] > 0.0
    assert out["paired"]["ethucy_vs_default"]["success"] == {
        "ethucy_only": 1,
        "default_only": 1,
        "mcnemar_p": 1.0,
    }
    assert out["paired"]["ethucy_vs_cv"]["success"]["ethucy_only"] == 1
    assert out["paired"]["ethucy_vs_cv"]["collision"] == {"ethucy_only": 0, "cv_only": 0, "mcnemar_p": 1.0}
