"""Episodes as files, through the CLI in subprocesses: `sim run --render` writes what the file's suffix says (PNG,
SVG, GIF, MP4) and refuses another suffix; `evaluations episodes RUN --out` exports every metric of a local
evaluation, flat, as CSV, Parquet and JSON lines."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import pyarrow.parquet as pq
import pytest

REPO = Path(__file__).resolve().parents[3]
MATRIX = "configs/scenarios/classic_interactions.yaml"
MAGIC = {"png": b"\x89PNG", "gif": b"GIF89a", "svg": b"<?xml"}


def _cli(cwd: Path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "foresight.cli.main", *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=300,
        env={**__import__("os").environ, "FORESIGHT_DATA_DIR": str(cwd / "data")},
    )


@pytest.mark.parametrize("suffix", ["png", "svg", "gif", "mp4"])
def test_render_writes_what_the_suffix_says(tmp_path: Path, suffix: str) -> None:
    out = tmp_path / f"ep.{suffix}"
    done = _cli(
        tmp_path,
        "sim",
        "run",
        "--local",
        "--matrix",
        MATRIX,
        "--scenario",
        "crossing_low",
        "--seed",
        "1",
        "--render",
        str(out),
    )
    assert done.returncode == 0, done.stderr
    head = out.read_bytes()[:16]
    if suffix == "mp4":
        assert head[4:8] == b"ftyp", head  # an ISO media file
        import imageio_ffmpeg

        frames = imageio_ffmpeg.read_frames(str(out))
        meta = next(frames)
        assert meta["size"][0] > 100 and sum(1 for _ in frames) > 10
    else:
        assert head.startswith(MAGIC[suffix]), head


def test_render_refuses_an_unknown_suffix_before_running(tmp_path: Path) -> None:
    done = _cli(
        tmp_path,
        "sim",
        "run",
        "--local",
        "--matrix",
        MATRIX,
        "--scenario",
        "crossing_low",
        "--seed",
        "1",
        "--render",
        str(tmp_path / "ep.jpg"),
    )
    assert (
        done.returncode == 1
        and done.stderr.count("\n") == 1
        and "ep.jpg" in done.stderr
        and ".mp4" in done.stderr
    )
    assert not (tmp_path / "ep.jpg").exists()


def test_episodes_export_every_metric_flat(tmp_path: Path) -> None:
    run = tmp_path / "run"
    done = _cli(
        tmp_path,
        "evaluate",
        "--local",
        "--matrix",
        MATRIX,
        "--planner",
        "social_force",
        "--scenarios",
        "crossing_low,head_on_corridor_high",
        "--seeds-per-scenario",
        "2",
        "--max-steps",
        "40",
        "--out",
        str(run),
        "--json",
    )
    assert done.returncode in (0, 2), done.stderr
    records = [json.loads(line) for line in (run / "episodes.jsonl").read_text().splitlines()]
    for fmt in ("csv", "parquet", "jsonl"):
        done = _cli(tmp_path, "evaluations", "episodes", str(run), "--out", str(tmp_path / f"t.{fmt}"))
        assert done.returncode == 0, done.stderr
    with (tmp_path / "t.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    table = pq.read_table(tmp_path / "t.parquet").to_pylist()
    lines = [json.loads(line) for line in (tmp_path / "t.jsonl").read_text().splitlines()]
    assert len(rows) == len(table) == len(lines) == len(records) == 4
    for rec, row, par, line in zip(records, rows, table, lines, strict=True):
        for key in (
            "safety.min_clearance",
            "efficiency.path_length",
            "smoothness.jerk_mean",
            "timing.plan_ms_p95",
        ):
            group, name = key.split(".")
            assert par[key] == line[key] == rec[group][name] and float(row[key]) == pytest.approx(
                rec[group][name]
            )
        assert row["outcome"] == par["outcome"] == rec["outcome"] and par["provenance.seed"] == rec["seed"]
        assert par["taxonomy.label"] == rec["taxonomy"]["label"]
    assert "safety.min_ttc" in table[0] and "prediction.ade" in rows[0]

    done = _cli(tmp_path, "evaluations", "episodes", str(run), "--format", "parquet")  # binary: needs a file
    assert done.returncode == 1 and "--out" in done.stderr


def test_a_local_reports_failed_episodes_link_to_their_players(tmp_path: Path) -> None:
    run = tmp_path / "run"
    done = _cli(
        tmp_path,
        "evaluate",
        "--local",
        "--matrix",
        MATRIX,
        "--planner",
        "goal",
        "--scenarios",
        "head_on_corridor_high",
        "--seeds-per-scenario",
        "1",
        "--max-steps",
        "120",
        "--out",
        str(run),
    )
    assert done.returncode == 2, done.stderr  # the goal-seeking robot fails here: a failed gate
    record = json.loads((run / "episodes.jsonl").read_text().splitlines()[0])
    link = f"player/{record['scenario']}__{record['seed']}.html"
    assert f'<a href="{link}">watch</a>' in (run / "report.html").read_text()
    page = (run / link).read_text()
    assert "<canvas" in page and "data-trace-script" in page
