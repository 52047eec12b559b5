"""Your own recordings: text/CSV in any column order and units, TrajNet++ ndjson, folds by scene, export, and one
error naming file and line for a malformed file (nothing written)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from foresight.cli.main import main
from foresight.core.errors import ConfigError
from foresight.core.predict.dataset import load_dataset
from foresight.core.predict.ethucy import read_scene, scene_samples
from foresight.core.predict.scene_import import (
    ImportScenesConfig,
    import_scenes,
    read_scenes,
    scene_folds,
)
from foresight.core.predict.timebase import ETHUCY_TIMEBASE

ETHUCY = Path(__file__).resolve().parents[3].parent / "shared" / "reference" / "ethucy"
HOTEL = ETHUCY / "hotel" / "test" / "biwi_hotel.txt"
ZARA = ETHUCY / "zara1" / "test" / "crowds_zara01.txt"


def _as_csv(src: Path, dst: Path) -> Path:
    """The file as CSV with columns x, y (in cm), a skipped one, frame, id, and a header line."""
    rows = read_scene(src)
    with dst.open("w") as f:
        f.write("x,y,note,frame,id\n")
        for fr, pid, x, y in rows.tolist():
            f.write(f"{x * 100:.2f},{y * 100:.2f},0,{fr:g},{pid:g}\n")
    return dst


def _as_trajnet(src: Path, dst: Path, fps: float = 2.5) -> Path:
    rows = read_scene(src)
    with dst.open("w") as f:
        f.write(json.dumps({"scene": {"id": 0, "p": 1, "s": 0, "e": 100, "fps": fps}}) + "\n")
        for fr, pid, x, y in rows.tolist():
            f.write(json.dumps({"track": {"f": int(fr), "p": int(pid), "x": x, "y": y}}) + "\n")
    return dst


def _order(state: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Windows by content (a long scene is cut in pieces, which changes their order, not the set)."""
    return np.lexsort(
        (np.round(state[:, 0, -6], 3), np.round(target[:, 0, -1, 1], 3), np.round(target[:, 0, -1, 0], 3))
    )


def _same_windows(ds, src: Path, atol=1e-4):
    ref = scene_samples(read_scene(src), ETHUCY_TIMEBASE, 12)
    assert len(ds) == len(ref.state) > 100
    a, b = _order(ds.state, ds.target), _order(ref.state, ref.target)
    np.testing.assert_allclose(ds.state[a], ref.state[b], atol=atol)
    np.testing.assert_allclose(ds.target[a], ref.target[b], atol=atol)
    np.testing.assert_array_equal(ds.target_mask[a], ref.target_mask[b])


def test_a_long_scene_is_cut_in_pieces_without_losing_or_repeating_a_window():
    from foresight.core.predict.scene_import import segments

    rows = np.array([[f, p, f * 0.1, p] for f in range(50) for p in range(3)], dtype=float)
    pieces = list(segments(rows, span=20, length=7))
    starts = [s for piece in pieces for s in range(int(piece[0, 0]), int(piece[-1, 0]) - 18)]
    assert sorted(starts) == list(range(31))  # every window start once


def test_text_in_any_column_order_and_units_gives_the_eth_windows(tmp_path):
    path = _as_csv(HOTEL, tmp_path / "hotel.csv")
    cfg = ImportScenesConfig(path=str(path), columns="x,y,note,frame,id", frame_interval=0.4, units="cm")
    ds = import_scenes(cfg)
    _same_windows(ds, HOTEL)
    assert ds.meta.timebase == ETHUCY_TIMEBASE and ds.meta.generator["kind"] == "scenes"
    assert [e.split for e in ds.meta.episodes] == ["test"]


def test_trajnet_gives_the_same_windows_and_its_fps_must_agree(tmp_path):
    path = _as_trajnet(HOTEL, tmp_path / "hotel.ndjson")
    ds = import_scenes(ImportScenesConfig(path=str(path), format="trajnet", frame_interval=0.4))
    _same_windows(ds, HOTEL)
    with pytest.raises(ConfigError, match=r"hotel.ndjson.*fps 2.5.*frame interval of 0.2"):
        import_scenes(
            ImportScenesConfig(
                path=str(path),
                format="trajnet",
                frame_interval=0.2,
                timebase={"dt": 0.4, "history": 8, "horizon": 12},
            )
        )


def test_folds_leave_one_scene_out(tmp_path):
    folder = tmp_path / "mine"
    folder.mkdir()
    _as_trajnet(HOTEL, folder / "hotel.ndjson")
    _as_trajnet(ZARA, folder / "zara.ndjson")
    cfg = ImportScenesConfig(path=str(folder), format="trajnet", frame_interval=0.4)
    folds = dict(scene_folds(read_scenes(cfg), cfg))
    assert list(folds) == ["hotel", "zara"]
    for held_out, ds in folds.items():
        splits = {e.scenario: e.split for e in ds.meta.episodes}
        assert splits[held_out] == "test" and all(s == "train" for n, s in splits.items() if n != held_out)
        # the held-out scene's windows are exactly the test split: no window of it is trained on
        test = ds.split_indices("test")
        assert len(test) == len(
            scene_samples(read_scene(HOTEL if held_out == "hotel" else ZARA), ETHUCY_TIMEBASE, 12).state
        )


@pytest.mark.parametrize(
    "fmt, body, expected",
    [
        (
            "text",
            "0 1 1.0 2.0\n10 1 1.5 oops\n",
            r"bad.txt.*line 2: expected numbers in columns frame, id, x, y",
        ),
        ("text", "0 1 1.0 2.0\n10 1 1.5\n", r"bad.txt.*line 2: 3 columns, expected 4"),
        (
            "trajnet",
            '{"track": {"f": 0, "p": 1, "x": 1, "y": 2}}\n{"track": {"f": 10}}\n',
            r"bad.ndjson.*line 2: a track needs numeric f, p, x, y",
        ),
        (
            "trajnet",
            '{"track": {"f": 0, "p": 1, "x": 1, "y": 2}}\nnot json\n',
            r"bad.ndjson.*line 2: not JSON",
        ),
    ],
)
def test_a_malformed_file_is_one_error_naming_file_and_line_and_nothing_is_written(
    fmt, body, expected, tmp_path, capsys
):
    folder = tmp_path / "scenes"
    folder.mkdir()
    _as_trajnet(HOTEL, folder / "good.ndjson") if fmt == "trajnet" else _as_csv(HOTEL, folder / "good.csv")
    (folder / ("bad.txt" if fmt == "text" else "bad.ndjson")).write_text(body)
    columns = "x,y,note,frame,id"
    if fmt == "text":
        (folder / "good.csv").unlink()
        (folder / "good.txt").write_text(HOTEL.read_text())
        columns = "frame,id,x,y"
    with pytest.raises(ConfigError, match=expected):
        import_scenes(ImportScenesConfig(path=str(folder), format=fmt, columns=columns, frame_interval=0.4))
    out = tmp_path / "out.npz"
    rc = main(
        [
            "dataset",
            "import",
            str(folder),
            "--format",
            fmt,
            "--frame-interval",
            "0.4",
            "--output",
            str(out),
            "--local",
        ]
    )
    assert rc != 0 and not out.exists() and not out.with_suffix(".json").exists()
    err = capsys.readouterr().err
    assert "line 2" in err and len(err.strip().splitlines()) == 1


def test_cli_import_ls_export_and_reimport(tmp_path, capsys):
    folder = tmp_path / "mine"
    folder.mkdir()
    _as_trajnet(HOTEL, folder / "hotel.ndjson")
    _as_trajnet(ZARA, folder / "zara.ndjson")
    out = tmp_path / "data" / "mine.npz"
    out.parent.mkdir()
    assert (
        main(
            [
                "dataset",
                "import",
                str(folder),
                "--format",
                "trajnet",
                "--frame-interval",
                "0.4",
                "--test-scene",
                "hotel",
                "--output",
                str(out),
                "--local",
            ]
        )
        == 0
    )
    ds = load_dataset(out)
    assert {e.scenario: e.split for e in ds.meta.episodes} == {"hotel": "test", "zara": "train"}
    capsys.readouterr()
    assert main(["dataset", "ls", "--dir", str(out.parent), "--json"]) == 0
    (row,) = json.loads(capsys.readouterr().out)
    assert row["samples"] == len(ds) and row["timebase"]["dt"] == 0.4 and row["kind"] == "scenes"
    nd = tmp_path / "export.ndjson"
    assert main(["dataset", "export", str(out), "--split", "test", "--output", str(nd)]) == 0
    test = ds.subset(ds.split_indices("test"))
    again = import_scenes(ImportScenesConfig(path=str(nd), format="trajnet", frame_interval=0.4))
    # every exported sample is a scene of H + T frames whose focal pedestrian gives exactly one window back
    assert len(again) == len(test)
    focal = again.target_mask[:, 0].sum() == test.target_mask[:, 0].sum()
    assert focal and np.allclose(
        np.sort(again.target[:, 0, -1, 0]), np.sort(test.target[:, 0, -1, 0]), atol=1e-3
    )


def test_an_evaluations_pedestrians_export_as_trajnet_and_import_back(tmp_path):
    import foresight

    foresight.evaluate("goal", scenarios=["crossing_low"], seeds=1, max_steps=60, out=tmp_path / "run")
    out = tmp_path / "peds"
    assert main(["dataset", "export-episodes", str(tmp_path / "run"), "--output", str(out)]) == 0
    (nd,) = sorted(out.glob("*.ndjson"))
    lines = [json.loads(x) for x in nd.read_text().splitlines()]
    assert "scene" in lines[0] and lines[0]["scene"]["fps"] == 10.0 and all("track" in x for x in lines[1:])
    cfg = ImportScenesConfig(
        path=str(nd), format="trajnet", frame_interval=0.1, timebase={"dt": 0.2, "history": 5, "horizon": 12}
    )
    ds = import_scenes(cfg)
    assert len(ds) > 0 and ds.meta.timebase.dt == 0.2


def test_the_streamed_import_writes_the_file_the_in_memory_one_does_and_leaves_no_temporary(
    tmp_path, monkeypatch
):
    from foresight.core.predict import scene_import
    from foresight.core.predict.dataset import save_dataset

    monkeypatch.setattr(scene_import, "SEGMENT_FRAMES", 40)  # many pieces: many chunks
    folder = tmp_path / "mine"
    folder.mkdir()
    _as_trajnet(HOTEL, folder / "hotel.ndjson")
    _as_trajnet(ZARA, folder / "zara.ndjson")
    cfg = ImportScenesConfig(path=str(folder), format="trajnet", frame_interval=0.4, test_scene="hotel")
    out = tmp_path / "data"
    streamed = scene_import.import_scenes_to(cfg, out / "streamed.npz")
    whole = save_dataset(scene_import.import_scenes(cfg), out / "whole.npz")
    a, b = load_dataset(out / "streamed.npz"), load_dataset(out / "whole.npz")
    for name in ("state", "target", "mask", "target_mask", "episode"):
        x, y = getattr(a, name), getattr(b, name)
        assert x.dtype == y.dtype and x.shape == y.shape
        np.testing.assert_array_equal(x, y)
    assert a.meta == b.meta and streamed["meta"] == whole["meta"]
    s, w = streamed["summary"], whole["summary"]
    assert s["samples_per_split"] == w["samples_per_split"] and s["samples_per_split"]["test"] > 0
    for key in ("active_agent_ratio", "active_target_ratio", "target_std_m"):
        assert s[key] == pytest.approx(w[key], rel=1e-6)
    assert s["final_displacement_m"] == pytest.approx(w["final_displacement_m"], rel=1e-6)
    assert sorted(p.name for p in out.iterdir()) == [
        "streamed.json",
        "streamed.npz",
        "whole.json",
        "whole.npz",
    ]


def test_a_streamed_import_that_fails_after_reading_leaves_nothing(tmp_path):
    from foresight.core.predict.scene_import import import_scenes_to

    short = tmp_path / "short.txt"
    short.write_text("".join(f"{f * 10} 1 {f * 0.4:.2f} 0\n" for f in range(5)))  # too short for one window
    out = tmp_path / "out" / "short.npz"
    with pytest.raises(ConfigError, match="no window of 20 consecutive annotations"):
        import_scenes_to(ImportScenesConfig(path=str(short), frame_interval=0.4), out)
    assert list(out.parent.iterdir()) == []
