"""bench/ethucy_sweep.py: variants of a training config trained per fold in worker processes, averaged per variant."""

import json
import subprocess
import sys

import pytest

from tests.unit.bench_scripts import BENCH, load_bench

SWEEP = BENCH / "ethucy_sweep.py"


def test_table_averages_complete_variants_only():
    table = load_bench("ethucy_sweep").table
    rows = [
        {"variant": "a", "fold": f, "ade": a, "fde": 2 * a, "cv_ade": 1.0, "cv_fde": 2.0, "seconds": 1.0}
        for f, a in (("eth", 0.9), ("hotel", 0.3))
    ]
    rows.append(
        {"variant": "b", "fold": "eth", "ade": 0.8, "fde": 1.6, "cv_ade": 1.0, "cv_fde": 2.0, "seconds": 1.0}
    )
    rows.append({"variant": "b", "fold": "hotel", "error": "ValueError: boom"})
    out = table(rows, ["eth", "hotel"])
    assert out["a"]["ade"] == pytest.approx(0.6) and out["a"]["fde"] == pytest.approx(1.2)
    assert out["a"]["folds"] == {"eth": [0.9, 1.8], "hotel": [0.3, 0.6]}
    assert out["b"] == {"incomplete": ["hotel"]}  # no average from some folds


def test_the_stage_keys_of_a_variant_go_beside_its_training_config():
    stage_values = load_bench("ethucy_sweep").stage_values
    assert stage_values({"epochs": 3, "reverse_train": True}) == {
        "train": {"epochs": 3},
        "reverse_train": True,
    }
    assert stage_values({"epochs": 3}) == {"train": {"epochs": 3}}


def test_bad_arguments_are_one_line_errors(tmp_path):
    root = subprocess.run(
        [sys.executable, str(SWEEP), "--ethucy", str(tmp_path / "none")], capture_output=True, text=True
    )
    assert root.returncode != 0 and "none: not a folder" in root.stderr
    fold = subprocess.run(
        [sys.executable, str(SWEEP), "--ethucy", str(tmp_path), "--folds", "mars"],
        capture_output=True,
        text=True,
    )
    assert fold.returncode != 0 and "--folds: unknown ['mars']" in fold.stderr
    var = subprocess.run(
        [sys.executable, str(SWEEP), "--ethucy", str(tmp_path), "--variant", "a={"],
        capture_output=True,
        text=True,
    )
    assert var.returncode != 0 and "--variant a: overrides are not JSON" in var.stderr


def test_a_variant_trains_and_scores_one_fold(shared_dir, tmp_path):
    tiny = json.dumps({"epochs": 1, "ensemble": 1, "hidden": 8, "blocks": 1, "batch_size": 512})
    run = subprocess.run(
        [
            sys.executable,
            str(SWEEP),
            "--ethucy",
            str(shared_dir / "reference" / "ethucy"),
            "--folds",
            "hotel",
            "--variant",
            f"tiny={tiny}",
            "--workers",
            "1",
            "--out",
            str(tmp_path),
            "--json",
        ],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert run.returncode == 0, run.stderr[-2000:]
    report = json.loads(run.stdout)
    row = report["table"]["tiny"]
    assert not report["errors"] and row["cv_ade"] == pytest.approx(
        0.319, abs=0.002
    )  # constant velocity on hotel
    assert 0.1 < row["ade"] < 0.6 and row["folds"]["hotel"][0] == pytest.approx(row["ade"], abs=1e-4)
    assert (tmp_path / "tiny" / "hotel" / "hotel" / "train" / "model.pt").is_file()
