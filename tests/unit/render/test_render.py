"""Map previews and trace pictures are written as real images (PNG by default, SVG by suffix)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import matplotlib.image as mpimg
import numpy as np
import pytest

from foresight.core.errors import ConfigError
from foresight.core.maps.model import MapDef, Route, SinglePedestrian, Zone
from foresight.core.render.map_view import render_map
from foresight.core.render.trace import ped_segments, recorded_states, render_trace


@dataclass
class _Trace:
    robot: np.ndarray
    command: np.ndarray
    ped_ids: np.ndarray
    ped_pos: np.ndarray
    ped_vel: np.ndarray
    dt: float = 0.1


@pytest.fixture
def mapdef() -> MapDef:
    return MapDef(
        name="render_test",
        width=30,
        height=20,
        obstacles=(((12.0, 0.0), (18.0, 0.0), (18.0, 6.0), (12.0, 6.0)),),
        robot_spawn_zones=(Zone.from_rect(1, 9, 2, 2),),
        robot_goal_zones=(Zone.from_rect(27, 9, 2, 2),),
        robot_routes=(Route(spawn_id=0, goal_id=0, waypoints=((2, 10), (28, 10))),),
        ped_spawn_zones=(Zone.from_rect(14, 17, 2, 2),),
        ped_goal_zones=(Zone.from_rect(14, 7, 2, 2),),
        ped_routes=(Route(spawn_id=0, goal_id=0, waypoints=((15, 18), (15, 8))),),
        single_pedestrians=(SinglePedestrian(id="s1", start=(5, 15), goal=(25, 15)),),
    )


def _trace(steps: int = 60) -> _Trace:
    t = np.arange(steps + 1)
    robot = np.column_stack(
        [
            2 + 0.2 * t,
            np.full(steps + 1, 10.0),
            np.zeros(steps + 1),
            np.full(steps + 1, 2.0),
            np.zeros(steps + 1),
        ]
    )
    ids = np.tile(np.array([0, 1], dtype=np.int64), (steps + 1, 1))
    ids[30:, 1] = 2  # slot 1 respawns with a new id
    ids[:5, 0] = -1  # slot 0 empty at first
    pos = np.zeros((steps + 1, 2, 2))
    pos[:, 0] = np.column_stack([np.full(steps + 1, 15.0), 18 - 0.15 * t])
    pos[:, 1] = np.column_stack([25 - 0.1 * t, np.full(steps + 1, 12.0)])
    return _Trace(robot=robot, command=robot[:-1, 3:5], ped_ids=ids, ped_pos=pos, ped_vel=np.zeros_like(pos))


def _assert_picture(path: Path, min_width: int = 500) -> np.ndarray:
    img = mpimg.imread(path)
    assert img.ndim == 3 and img.shape[1] >= min_width and img.shape[0] >= 200
    rgb = img[..., :3]
    assert (rgb < 0.95).mean() > 0.02  # not a blank page
    return rgb


def test_render_map_png(tmp_path: Path, mapdef: MapDef) -> None:
    out = render_map(mapdef, tmp_path / "sub" / "map.png")
    assert out.exists() and out.stat().st_size > 5_000
    rgb = _assert_picture(out)
    assert np.ptp(rgb.reshape(-1, 3), axis=0).max() > 0.5  # zones and routes are in colour


def test_render_map_svg(tmp_path: Path, mapdef: MapDef) -> None:
    out = render_map(mapdef, tmp_path / "map.svg", title="preview")
    text = out.read_text()
    assert text.lstrip().startswith("<?xml") and "<svg" in text and "preview" in text


def test_render_trace_marks_collision(tmp_path: Path, mapdef: MapDef) -> None:
    tr = _trace()
    plain = _assert_picture(render_trace(tr, mapdef, tmp_path / "a.png", title="episode"))
    hit = _assert_picture(render_trace(tr, mapdef, tmp_path / "b.png", title="episode", collision_step=40))
    assert plain.shape == hit.shape
    red = (hit[..., 0] > 0.8) & (hit[..., 1] < 0.2) & (hit[..., 2] < 0.2)
    red_plain = (plain[..., 0] > 0.8) & (plain[..., 1] < 0.2) & (plain[..., 2] < 0.2)
    assert red.sum() > red_plain.sum() + 50  # the red X and circle were drawn


def test_render_trace_svg_and_explicit_point(tmp_path: Path, mapdef: MapDef) -> None:
    out = render_trace(_trace(), mapdef, tmp_path / "t.svg", collision_point=(10.0, 10.0), goal=(28, 10))
    assert "<svg" in out.read_text()


def test_unsupported_suffix(tmp_path: Path, mapdef: MapDef) -> None:
    with pytest.raises(ConfigError) as info:
        render_map(mapdef, tmp_path / "map.gif")
    assert info.value.item == "path"


def test_ped_segments_follow_ids_and_skip_respawns() -> None:
    tr = _trace(60)
    segs = ped_segments(tr.ped_ids, tr.ped_pos)
    # slot 0: id 0 from state 5 to 60 -> 55 pieces; slot 1: id 1 over 0..29 (29) and id 2 over 30..60 (30)
    assert len(segs) == 55 + 29 + 30
    jumps = np.linalg.norm(segs[:, 1] - segs[:, 0], axis=1)
    assert jumps.max() < 0.2


def test_recorded_states_honours_steps_and_nan_padding() -> None:
    tr = _trace(10)
    assert recorded_states(tr) == 11
    tr.robot[7:] = np.nan
    assert recorded_states(tr) == 7
    tr.steps = 3  # type: ignore[attr-defined]
    assert recorded_states(tr) == 4


def test_renders_a_simulator_trace_without_collision(tmp_path: Path, mapdef: MapDef) -> None:
    """foresight.core.sim.trace.Trace marks "no collision" with step -1 and a NaN point: no red mark at the start."""
    from foresight.core.sim.trace import Trace

    src = _trace(20)
    tr = Trace(50, 2, dt=0.1)
    for t in range(21):
        tr.record_state(t, src.robot[t], src.ped_ids[t], src.ped_pos[t], src.ped_vel[t])
    assert (tr.collision_step, np.isnan(tr.collision_point).all()) == (-1, True)
    none = _assert_picture(render_trace(tr, mapdef, tmp_path / "none.png"))
    tr.collision_step, tr.collision_point = 15, src.robot[15, :2].copy()
    hit = _assert_picture(render_trace(tr, mapdef, tmp_path / "hit.png"))

    def red(img: np.ndarray) -> int:
        return int(((img[..., 0] > 0.8) & (img[..., 1] < 0.2) & (img[..., 2] < 0.2)).sum())

    assert red(hit) > red(none) + 50


def test_map_shows_points_of_interest_and_single_pedestrian_roles() -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from foresight.core.maps.model import SinglePedestrian
    from foresight.core.render.map_view import draw_map

    mapdef = MapDef(
        name="m",
        width=10,
        height=8,
        pois={"poi_a": (3.0, 4.0)},
        poi_labels={"poi_a": "kiosk"},
        single_pedestrians=(SinglePedestrian(id="p1", start=(1.0, 1.0), role="lead"),),
    )
    fig, ax = plt.subplots()
    draw_map(ax, mapdef)
    texts = {t.get_text() for t in ax.texts}
    assert {"kiosk", "p1 (lead)"} <= texts
    stars = [ln for ln in ax.lines if ln.get_marker() == "*"]
    assert [tuple(ln.get_xydata()[0]) for ln in stars] == [(3.0, 4.0)]
    plt.close(fig)


def test_pictures_have_y_up_and_show_goal_tolerance_and_robot_body(tmp_path: Path, mapdef: MapDef) -> None:
    """y points up (the simulator's frame); the goal's tolerance disc and the robot's body are drawn."""
    from foresight.core.render.figure import map_axes

    _, ax = map_axes(mapdef)
    assert ax.get_ylim() == (0.0, mapdef.height)
    tr = _trace(20)
    bare = _assert_picture(render_trace(tr, mapdef, tmp_path / "bare.png", goal=(26, 4), goal_tolerance=0.0))
    disc = _assert_picture(render_trace(tr, mapdef, tmp_path / "disc.png", goal=(26, 4), goal_tolerance=2.0))

    def greenish(img: np.ndarray) -> int:
        return int(((img[..., 1] > img[..., 0] + 0.05) & (img[..., 1] > img[..., 2] + 0.05)).sum())

    assert greenish(disc) > greenish(bare) + 500  # a 2 m disc, not a point
    h = disc.shape[0]
    rows = np.nonzero(
        (disc[..., 1] > disc[..., 0] + 0.05)
        & (disc[..., 1] > disc[..., 2] + 0.05)
        & ~((bare[..., 1] > bare[..., 0] + 0.05) & (bare[..., 1] > bare[..., 2] + 0.05))
    )[0]
    assert rows.mean() > h / 2  # the goal at y = 4 of 20 is in the lower half: y points up
