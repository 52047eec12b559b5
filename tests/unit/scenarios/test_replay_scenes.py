"""Replay scenarios in a matrix: the map from the scene, clear errors before any episode, the selection rule."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from foresight.cli.main import main
from foresight.core.errors import ConfigError
from foresight.core.scenarios.loader import load_matrix
from foresight.core.scenarios.replay import select_episodes

from .matrices import write

ROWS = [
    (f, i, 1.0 + 0.5 * f / 10 if i % 2 else 11.0 - 0.5 * f / 10, 2.0 + i)
    for f in range(0, 210, 10)
    for i in (1, 2, 3)
]


@pytest.fixture
def root(tmp_path: Path) -> Path:
    write(
        tmp_path / "data" / "raw" / "all_data" / "mini.txt",
        "".join(f"{f}\t{i}\t{x}\t{y}\n" for f, i, x, y in ROWS),
    )
    return tmp_path / "data"


def _load(tmp_path: Path, root: Path, steps: int = 50, **replay):
    block = {
        "scene": "mini",
        "start_frame": 10,
        "robot_start": [6.0, 1.5],
        "robot_goal": [6.0, 6.5],
        **replay,
    }
    path = write(
        tmp_path / "m.yaml",
        {"scenarios": [{"name": "r1", "replay": block, "simulation_config": {"max_episode_steps": steps}}]},
    )
    return path, load_matrix(
        path, data_roots=lambda name: {"mine": root}[name] if name == "mine" else _unknown(name)
    )


def _unknown(name: str) -> Path:
    from foresight.core.errors import NotFoundError

    raise NotFoundError(f"unknown data root {name!r}; known: mine")


def test_the_map_is_the_scenes_walkable_bounds(tmp_path: Path, root: Path) -> None:
    _, m = _load(tmp_path, root, data_root="mine")
    s = m.scenarios[0]
    assert s.replay.offset == (-1.0, 1.0)  # min x 1 - margin 2, min y 3 - 2
    assert (s.map.width, s.map.height) == (14.0, 6.0) and s.map.obstacles == () and s.map.ped_routes == ()
    assert s.map.robot_routes[0].waypoints == ((7.0, 0.5), (7.0, 5.5))  # start and goal in the map frame
    assert len(s.map_sha256) == 64 and s.map.source.endswith("mini.txt")
    assert set(np.unique(s.replay.ids)) == {1, 2, 3} and s.replay.step.min() == 0
    # 50 steps of 0.1 s from frame 10 end at frame 135: the window runs to the next annotation, 140 (step 52)
    assert s.replay.step.max() == 52


@pytest.mark.parametrize(
    ("replay", "item", "words"),
    [
        ({"scene": "nowhere"}, "r1.replay.scene", ["no scene 'nowhere'", "mini"]),
        ({"data_root": "elsewhere"}, "r1.replay.data_root", ["unknown data root 'elsewhere'"]),
        ({"start_frame": 15}, "r1.replay.start_frame", ["frame 15 is not annotated"]),
        ({"start_frame": 180}, "r1.replay.start_frame", ["runs past the scene's last frame 200"]),
        ({"robot_goal": [6.0, 40.0]}, "r1.replay.robot_goal", ["outside the scene's walkable bounds"]),
    ],
)
def test_bad_replay_names_file_scenario_and_item(tmp_path: Path, root: Path, replay, item, words) -> None:
    with pytest.raises(ConfigError) as info:
        _load(tmp_path, root, **{"data_root": "mine", **replay})
    assert info.value.item == item and info.value.source == str(tmp_path / "m.yaml")
    assert all(w in str(info.value) for w in words)


def test_replay_scenario_may_not_name_a_map(tmp_path: Path, root: Path) -> None:
    path = write(
        tmp_path / "m.yaml",
        {
            "scenarios": [
                {
                    "name": "r1",
                    "map_file": "x.yaml",
                    "replay": {
                        "scene": "mini",
                        "start_frame": 0,
                        "robot_start": [1, 1],
                        "robot_goal": [2, 2],
                    },
                }
            ]
        },
    )
    with pytest.raises(ConfigError, match="r1.*no map_file, map_id"):
        load_matrix(path)


def test_cli_refuses_a_missing_scene_in_one_line_before_any_episode(
    tmp_path: Path, capsys, shared_dir: Path
) -> None:
    path = write(
        tmp_path / "m.yaml",
        {
            "scenarios": [
                {
                    "name": "bad_replay",
                    "replay": {
                        "scene": "crowds_zara99",
                        "start_frame": 0,
                        "robot_start": [5, 1],
                        "robot_goal": [5, 10],
                    },
                }
            ]
        },
    )
    code = main(["evaluate", "--matrix", str(path), "--planner", "goal", "--local", "--json"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 1 and len(err) == 1
    assert str(path) in err[0] and "bad_replay.replay.scene" in err[0] and "crowds_zara99" in err[0]


def _corridor() -> np.ndarray:
    """Walkers along x in both directions (y = 3, 4, 5), one entering every 8 s, and two bystanders far off."""
    rows = []
    for k in range(12):
        start, sign = 80 * k, 1 if k % 2 == 0 else -1
        for f in range(start, start + 250, 10):
            x = 8.0 + sign * (0.5 * (f - start) / 10 - 6.0)
            rows.append((f, k + 1, x, 3.0 + k % 3))
    rows += [(f, 100 + j, 30.0, y) for f in range(0, 1130, 10) for j, y in enumerate((0.0, 8.0))]
    return np.array(rows, dtype=float)


def test_selection_rule_crosses_the_main_flow_and_ranks_by_crossings() -> None:
    rows = _corridor()
    kw = {"horizon_s": 2.0, "every_frames": 50, "length": (3.0, 8.0), "clear_radius": 0.5}
    eps = select_episodes("mini", rows, 0.4, count=3, **kw)
    every = select_episodes("mini", rows, 0.4, count=1000, **kw)  # every non-overlapping candidate
    assert len(eps) == 3 and [e.start_frame for e in eps] == sorted(e.start_frame for e in eps)
    for e in eps:
        (sx, sy), (gx, gy) = e.robot_start, e.robot_goal
        assert abs(gx - sx) < 0.2 * abs(gy - sy)  # across the flow: the robot drives along y
        assert min(sy, gy) < 3.0 and max(sy, gy) > 5.0  # over the whole band of the flow
        assert e.crossings >= 1
    assert max(e.crossings for e in eps) == max(e.crossings for e in every)
    assert sorted(e.crossings for e in eps) == sorted(e.crossings for e in every)[-3:]
    starts = sorted(e.start_frame for e in eps)
    assert all(b - a > 50 for a, b in zip(starts, starts[1:], strict=False))  # windows do not overlap in time
    assert eps == select_episodes("mini", rows, 0.4, count=3, **kw)
