import json

import pytest

from foresight.cli.main import main


def test_predict_eval_cv_on_one_fold(shared_dir, capsys):
    rc = main(
        [
            "predict-eval",
            "--model",
            "cv",
            "--ethucy",
            str(shared_dir / "reference" / "ethucy"),
            "--fold",
            "zara1",
            "--json",
            "--local",
        ]
    )
    out = json.loads(capsys.readouterr().out)["result"]
    assert rc == 0 and set(out) >= {"folds", "average"}
    assert out["folds"]["zara1"]["ade"] == pytest.approx(0.43, abs=0.01)
    avg = out["average"]
    assert set(avg) >= {
        "ade",
        "fde",
        "best_of",
        "min_ade",
        "min_fde",
        "nll",
        "within_1sigma",
        "within_2sigma",
    }
    # one deterministic mode, no spread: best-of-1 is the best of all, and there is no likelihood to report
    assert avg["best_of"] == 1 and avg["min_ade"] == pytest.approx(avg["ade"]) and avg["nll"] is None


def test_train_then_eval_on_dataset(tmp_path, curving_dataset, capsys):
    (tmp_path / "t.yaml").write_text("train:\n  epochs: 2\n  hidden: 8\n  blocks: 1\n  batch_size: 64\n")
    rc = main(
        [
            "train",
            "--dataset",
            str(curving_dataset),
            "--config",
            str(tmp_path / "t.yaml"),
            "--out",
            str(tmp_path / "run"),
            "--json",
            "--local",
        ]
    )
    res = json.loads(capsys.readouterr().out)["result"]
    assert rc in (0, 2) and res["best_epoch"] in (1, 2)
    rc = main(
        [
            "predict-eval",
            "--model",
            res["checkpoint"],
            "--dataset",
            str(curving_dataset),
            "--json",
            "--out",
            str(tmp_path / "ev"),
            "--local",
        ]
    )
    out = json.loads(capsys.readouterr().out)["result"]
    assert rc == 0 and out["folds"]["arcs"]["split"] == "val"


def test_bad_input_is_one_line_error(tmp_path, capsys):
    rc = main(["predict-eval", "--model", "cv", "--ethucy", str(tmp_path), "--fold", "nowhere", "--local"])
    assert rc == 1 and "unknown fold" in capsys.readouterr().err


def test_import_ethucy_command(tmp_path, capsys):
    root = tmp_path / "ethucy"
    rows = "\n".join(f"{f * 10}\t1\t{0.4 * f:.2f}\t0.0" for f in range(25))
    for split, name in (
        ("train", "crowds_zara02_train.txt"),
        ("val", "crowds_zara02_val.txt"),
        ("test", "crowds_zara01.txt"),
    ):
        (root / "zara1" / split).mkdir(parents=True)
        (root / "zara1" / split / name).write_text(rows + "\n")
    rc = main(
        [
            "dataset",
            "import-ethucy",
            "--ethucy",
            str(root),
            "--fold",
            "zara1",
            "--output",
            str(tmp_path / "z.npz"),
            "--json",
            "--local",
        ]
    )
    job = json.loads(capsys.readouterr().out)
    assert job["kind"] == "import_dataset" and [a["name"] for a in job["artifacts"]] == ["z.npz"]
    summary = job["result"]["summary"]
    assert rc == 0 and summary["samples_per_split"] == {"train": 6, "val": 6, "test": 6}


def test_eval_all_samples_of_a_held_out_dataset(tmp_path, curving_dataset, capsys):
    from foresight.core.predict.dataset import load_dataset

    rc = main(
        [
            "predict-eval",
            "--model",
            "cv",
            "--dataset",
            str(curving_dataset),
            "--split",
            "all",
            "--json",
            "--out",
            str(tmp_path),
            "--local",
        ]
    )
    out = json.loads(capsys.readouterr().out)["result"]
    assert rc == 0 and out["folds"]["arcs"]["samples"] == len(load_dataset(curving_dataset))


def test_training_scenes_played_backwards_when_the_config_says_so(tmp_path, capsys):
    from foresight.core.predict.dataset import load_dataset

    root = tmp_path / "ethucy"
    walk = "\n".join(
        f"{f * 10}\t1\t{0.4 * f:.2f}\t{0.02 * f * f:.3f}" for f in range(25)
    )  # a curve, not a line
    for split, name in (
        ("train", "crowds_zara02_train.txt"),
        ("val", "crowds_zara02_val.txt"),
        ("test", "crowds_zara01.txt"),
    ):
        (root / "zara1" / split).mkdir(parents=True)
        (root / "zara1" / split / name).write_text(walk + "\n")
    datasets = {}
    for reverse in (False, True):
        cfg = tmp_path / f"t{reverse}.yaml"
        cfg.write_text(
            f"reverse_train: {str(reverse).lower()}\ntrain:\n  epochs: 1\n  hidden: 8\n  blocks: 1\n"
            "  allow_degenerate: true\n"
        )
        rc = main(
            [
                "predict-eval",
                "--train",
                "--config",
                str(cfg),
                "--ethucy",
                str(root),
                "--fold",
                "zara1",
                "--out",
                str(tmp_path / f"run{reverse}"),
                "--json",
                "--local",
            ]
        )
        out = json.loads(capsys.readouterr().out)["result"]
        assert (
            rc == 0 and out["folds"]["zara1"]["samples"] == 6
        )  # the test scene is scored as recorded either way
        datasets[reverse] = load_dataset(tmp_path / f"run{reverse}" / "zara1" / "dataset.npz")
    plain, both = datasets[False], datasets[True]
    assert [len(d.split_indices(s)) for d in (plain, both) for s in ("train", "val")] == [6, 6, 12, 6]
    assert [e.scenario for e in both.meta.episodes if e.split == "train"] == [
        "train/crowds_zara02_train",
        "train/crowds_zara02_train~reversed",
    ]
    # the curve played backwards turns the other way in each walker's own frame
    fwd, back = plain.split_indices("train"), both.split_indices("train")[6:]
    assert (plain.target[fwd, 0, -1, 1] > 0).all() and (both.target[back, 0, -1, 1] < 0).all()


@pytest.mark.parametrize(
    ("text", "named"),
    [
        ("train:\n  epochz: 1\n", "train.epochz"),
        ("reverse_train: true\nepochs: 1\n", "beside the train mapping"),
    ],
)
def test_a_bad_training_key_is_refused_before_any_fold_is_trained(tmp_path, capsys, text, named):
    (tmp_path / "t.yaml").write_text(text)
    rc = main(
        [
            "predict-eval",
            "--train",
            "--config",
            str(tmp_path / "t.yaml"),
            "--ethucy",
            str(tmp_path),
            "--fold",
            "zara1",
            "--out",
            str(tmp_path / "run"),
            "--local",
        ]
    )
    err = capsys.readouterr().err
    assert rc == 1 and named in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "run").exists()


def test_a_missing_local_dataset_names_the_file_and_the_folder(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    rc = main(["train", "--local", "--dataset", "missing.npz", "--epochs", "1", "--out", str(tmp_path / "t")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 1 and len(err) == 1, err
    assert f"no dataset file 'missing.npz' in {tmp_path}" in err[0] and "run without --local" in err[0]
