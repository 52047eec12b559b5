"""The GIF replay: bounded frame count and size, real motion between frames, predictions in every format."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image

from foresight.core.render.animation import frame_steps, prediction_steps, render_replay

from .scenes import predictions, small_map, trace


def test_frame_steps_cover_the_episode_and_keep_the_collision() -> None:
    steps = frame_steps(601, 150, keep=[333])
    assert steps[0] == 0 and steps[-1] == 600 and 333 in steps and len(steps) <= 151
    assert list(frame_steps(5, 150)) == [0, 1, 2, 3, 4]


def test_prediction_formats_agree() -> None:
    log = predictions()
    a = prediction_steps(log)
    b = prediction_steps({s: (ids, pos) for s, ids, pos, _ in log})
    json_steps = [
        {
            "step": s,
            "predicted_vs_actual": [
                {"ped_id": int(i), "predicted": p.tolist()} for i, p in zip(ids, pos, strict=True)
            ],
        }
        for s, ids, pos, _ in log
    ]
    c = prediction_steps(json_steps)
    assert a.keys() == b.keys() == c.keys() == {s for s, *_ in log}
    for s in a:
        np.testing.assert_allclose(a[s][1], c[s][1])
        assert list(a[s][0]) == list(b[s][0]) == list(c[s][0])
    assert prediction_steps(None) == {}


def test_replay_gif(tmp_path: Path) -> None:
    path = render_replay(
        trace(),
        small_map(),
        tmp_path / "replay.gif",
        predictions=predictions(),
        max_frames=20,
        collision_step=40,
        title="test replay",
        width_px=400,
    )
    assert path.is_file() and 1000 < path.stat().st_size < 2_000_000
    with Image.open(path) as im:
        assert im.n_frames <= 21 and im.size[0] == 400
        im.seek(0)
        first = np.asarray(im.convert("RGB"), dtype=int)
        im.seek(im.n_frames - 1)
        last = np.asarray(im.convert("RGB"), dtype=int)
    assert first.std() > 5 and np.abs(first - last).sum() > 0  # the robot moved


def test_replay_shrinks_to_the_size_limit(tmp_path: Path) -> None:
    path = render_replay(
        trace(), small_map(), tmp_path / "small.gif", max_frames=40, max_bytes=60_000, width_px=500
    )
    with Image.open(path) as im:
        frames = im.n_frames
    assert path.stat().st_size <= 60_000 or frames <= 11
