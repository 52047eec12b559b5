"""Animated replay of an episode as a GIF: robot, pedestrians, their recent tracks and predicted futures.

Frames are drawn on one Agg figure (the static map once, moving artists updated per frame) and encoded
with Pillow against one shared palette, so that the GIF writer only stores the pixels that changed.
Long episodes are subsampled to ``max_frames``; a file over ``max_bytes`` is re-encoded with fewer,
smaller frames, because a replay that a report page cannot load is worse than a coarser one.

Reads the Trace contract of docs/architecture.md (``robot``, ``ped_ids``, ``ped_pos``, ``dt``).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.collections import LineCollection, PatchCollection
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle
from PIL import Image

from foresight.core import files
from foresight.core.errors import ConfigError
from foresight.core.maps.model import MapDef
from foresight.core.render.figure import map_axes
from foresight.core.render.map_view import draw_map
from foresight.core.render.trace import COLLISION_COLOUR, PED_COLOUR, ped_segments, recorded_states

PREDICTION_COLOUR = "tab:pink"
ROBOT_COLOUR = "tab:green"
TRAIL_S = 2.0  #: pedestrian track shown behind each pedestrian [s]
MIN_FRAME_MS = 40  #: browsers play shorter GIF frame delays far slower than asked

#: one step's forecast: pedestrian ids (M,) and predicted positions (M, H, 2) [m]
Forecast = tuple[np.ndarray, np.ndarray]


def as_floats(x: Any) -> np.ndarray:
    """JSON lists with ``null`` for non-finite numbers -> float array with NaN."""
    if isinstance(x, np.ndarray):
        return x.astype(float)
    if isinstance(x, list | tuple):
        return np.array([as_floats(v) for v in x], dtype=float) if x else np.zeros((0,))
    return np.asarray(np.nan if x is None else x, dtype=float)


def _from_step_dicts(steps: Iterable[Mapping[str, Any]]) -> dict[int, Forecast]:
    out: dict[int, Forecast] = {}
    for s in steps:
        rows = s.get("predicted_vs_actual") or []
        rows = [r for r in rows if r.get("predicted")]
        if rows:
            ids = np.array([int(r["ped_id"]) for r in rows], dtype=np.int64)
            out[int(s["step"])] = ids, np.stack([as_floats(r["predicted"]).reshape(-1, 2) for r in rows])
    return out


def prediction_steps(source: Any) -> dict[int, Forecast]:
    """Normalise predictions to {step: (ids, positions (M, H, 2))}.

    Accepts the evaluation's ``StepLog.predictions`` (``(step, ids, positions, times)`` tuples), a mapping
    step -> ``(ids, positions)`` or -> ``{"ped_ids", "positions"}``, or the diagnostics trace JSON's
    ``steps`` list (``predicted_vs_actual`` of the nearest pedestrians).
    """
    if source is None:
        return {}
    if isinstance(source, Mapping):
        out = {}
        for step, v in source.items():
            ids, pos = (v["ped_ids"], v["positions"]) if isinstance(v, Mapping) else (v[0], v[1])
            out[int(step)] = (
                np.asarray(ids, dtype=np.int64).reshape(-1),
                as_floats(pos).reshape(-1, *as_floats(pos).shape[-2:]),
            )
        return out
    items = list(source)
    if items and isinstance(items[0], Mapping):
        return _from_step_dicts(items)
    return {int(it[0]): (np.asarray(it[1], dtype=np.int64).reshape(-1), as_floats(it[2])) for it in items}


def frame_steps(n_states: int, max_frames: int, keep: Iterable[int] = ()) -> np.ndarray:
    """States to draw: evenly spread over the episode (first and last included), plus ``keep`` (e.g. a collision)."""
    count = max(2, min(int(max_frames), n_states))
    picked = np.rint(np.linspace(0, n_states - 1, count)).astype(int)
    extra = [k for k in keep if 0 <= k < n_states]
    return np.unique(np.concatenate([picked, np.asarray(extra, dtype=int)]))


@dataclass
class _Artists:
    path: Line2D
    heading: Line2D
    body: Circle
    trails: LineCollection
    futures: LineCollection
    future_ends: Line2D
    hit: Line2D
    clock: Any
    peds: PatchCollection | None = None

    def moving(self) -> list[Any]:
        arts = [
            self.trails,
            self.futures,
            self.future_ends,
            self.path,
            self.peds,
            self.body,
            self.heading,
            self.hit,
            self.clock,
        ]
        return [a for a in arts if a is not None]


def _setup(ax: Axes, robot_radius: float) -> _Artists:
    (path,) = ax.plot([], [], "-", color=ROBOT_COLOUR, lw=2, zorder=6, label="robot")
    (heading,) = ax.plot([], [], "-", color="black", lw=1.5, zorder=9)
    body = Circle((0, 0), robot_radius, fc=ROBOT_COLOUR, ec="black", lw=0.8, alpha=0.9, zorder=8)
    ax.add_patch(body)
    trails = LineCollection([], colors=PED_COLOUR, linewidths=1.0, alpha=0.5, zorder=5)
    futures = LineCollection([], colors=PREDICTION_COLOUR, linewidths=1.6, linestyles="--", zorder=7)
    ax.add_collection(trails)
    ax.add_collection(futures)
    (ends,) = ax.plot([], [], "o", color=PREDICTION_COLOUR, ms=3, zorder=7)
    (hit,) = ax.plot([], [], "x", color=COLLISION_COLOUR, ms=14, mew=3, zorder=10)
    clock = ax.text(
        0.01,
        0.99,
        "",
        transform=ax.transAxes,
        va="top",
        fontsize=9,
        zorder=11,
        bbox={"fc": "white", "alpha": 0.8, "lw": 0},
    )
    ax.plot([], [], "o", color=PED_COLOUR, label="pedestrian")
    ax.plot([], [], "--", color=PREDICTION_COLOUR, label="predicted future")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7, frameon=False)
    return _Artists(path, heading, body, trails, futures, ends, hit, clock)


def _future_segments(
    t: int, ids: np.ndarray, pos: np.ndarray, forecasts: dict[int, Forecast]
) -> list[np.ndarray]:
    """Predicted polylines of the latest forecast made at or before state ``t``, starting at each ped's position."""
    made = [s for s in forecasts if s <= t]
    if not made:
        return []
    fids, fpos = forecasts[max(made)]
    lines = []
    for pid, future in zip(fids, fpos, strict=True):
        slot = np.flatnonzero(ids[t] == pid)
        start = pos[t, slot[0]][None] if slot.size else future[:1]
        line = np.concatenate([start, future])
        line = line[np.all(np.isfinite(line), axis=1)]
        if len(line) > 1:
            lines.append(line)
    return lines


def _update(
    a: _Artists,
    ax: Axes,
    trace: Any,
    t: int,
    forecasts: dict[int, Forecast],
    hit_step: int | None,
    hit_xy: np.ndarray | None,
    ped_radius: float,
) -> None:
    robot = np.asarray(trace.robot, dtype=float)
    ids, pos = np.asarray(trace.ped_ids), np.asarray(trace.ped_pos, dtype=float)
    x, y, th = robot[t, :3]
    a.path.set_data(robot[: t + 1, 0], robot[: t + 1, 1])
    a.body.center = (x, y)
    r = a.body.radius
    a.heading.set_data([x, x + 1.6 * r * np.cos(th)], [y, y + 1.6 * r * np.sin(th)])
    lo = max(0, t - int(round(TRAIL_S / float(trace.dt))))
    a.trails.set_segments(list(ped_segments(ids[lo : t + 1], pos[lo : t + 1])))
    if a.peds is not None:
        a.peds.remove()
    live = pos[t][ids[t] >= 0] if ids.shape[1] else np.zeros((0, 2))
    a.peds = PatchCollection(
        [Circle(tuple(p), ped_radius) for p in live],
        fc=PED_COLOUR,
        ec="black",
        lw=0.5,
        alpha=0.85,
        zorder=7,
        animated=True,
    )
    ax.add_collection(a.peds)
    lines = _future_segments(t, ids, pos, forecasts)
    a.futures.set_segments(lines)
    ends = np.array([ln[-1] for ln in lines]) if lines else np.zeros((0, 2))
    a.future_ends.set_data(ends[:, 0], ends[:, 1])
    shown = hit_step is not None and hit_xy is not None and t >= hit_step
    a.hit.set_data([hit_xy[0]] if shown else [], [hit_xy[1]] if shown else [])
    a.clock.set_text(f"t = {t * float(trace.dt):.1f} s (step {t})" + ("  COLLISION" if shown else ""))


class _Blitter:
    """Draws the static figure once, then per frame only the moving artists over a copy of it (fast)."""

    def __init__(self, fig: Figure, ax: Axes, artists: _Artists):
        self.fig, self.ax, self.artists = fig, ax, artists
        for art in artists.moving():
            art.set_animated(True)
        fig.canvas.draw()
        self.background = fig.canvas.copy_from_bbox(fig.bbox)

    def frame(self) -> Image.Image:
        canvas = self.fig.canvas
        canvas.restore_region(self.background)
        for art in self.artists.moving():
            self.ax.draw_artist(art)
        return Image.fromarray(np.asarray(canvas.buffer_rgba())[..., :3].copy())


def _hit(
    trace: Any, robot_xy: np.ndarray, step: int | None, point: Any
) -> tuple[int | None, np.ndarray | None]:
    step = step if step is not None else getattr(trace, "collision_step", None)
    point = point if point is not None else getattr(trace, "collision_point", None)
    if step is None or int(step) < 0:
        return None, None
    step = min(int(step), len(robot_xy) - 1)
    xy = None if point is None else np.asarray(point, dtype=float).reshape(-1)[:2]
    return step, xy if xy is not None and np.all(np.isfinite(xy)) else robot_xy[step]


def _encode(blit: _Blitter, steps: np.ndarray, draw: Any, path: Path, frame_ms: int) -> Path:
    samples = []
    for t in (int(steps[-1]), int(steps[0])):  # palette from the last (most cluttered) and first frames
        draw(t)
        samples.append(blit.frame())
    mosaic = Image.new("RGB", (samples[0].width, 2 * samples[0].height))
    for i, img in enumerate(samples):
        mosaic.paste(img, (0, i * img.height))
    palette = mosaic.quantize(colors=255, method=Image.Quantize.MEDIANCUT)
    frames = []
    for t in steps:
        draw(int(t))
        frames.append(blit.frame().quantize(palette=palette, dither=Image.Dither.NONE))
    with files.replacing(path) as tmp:
        frames[0].save(tmp, format="GIF", save_all=True, append_images=frames[1:], duration=frame_ms, loop=0)
    return path


def _encode_mp4(blit: _Blitter, steps: np.ndarray, draw: Any, path: Path, frame_ms: int) -> Path:
    """H.264 through imageio-ffmpeg (the ``video`` extra; it ships its own ffmpeg binary, none is assumed on the
    machine); frames padded to even sizes, as yuv420p needs."""
    try:
        import imageio_ffmpeg
    except ImportError:
        raise ConfigError(
            "MP4 needs the video extra: pip install 'foresight[video]' (imageio-ffmpeg)", source=str(path)
        ) from None
    draw(int(steps[0]))
    first = np.asarray(blit.frame())
    h, w = first.shape[0] + first.shape[0] % 2, first.shape[1] + first.shape[1] % 2
    with files.replacing(path) as tmp:
        writer = imageio_ffmpeg.write_frames(
            str(tmp),
            (w, h),
            fps=1000.0 / frame_ms,
            codec="libx264",
            pix_fmt_out="yuv420p",
            macro_block_size=1,
            output_params=["-f", "mp4"],
        )
        writer.send(None)
        try:
            for t in steps:
                draw(int(t))
                frame = np.zeros((h, w, 3), dtype=np.uint8)
                img = np.asarray(blit.frame())
                frame[: img.shape[0], : img.shape[1]] = img
                writer.send(frame)
        finally:
            writer.close()
    return path


def render_replay(
    trace: Any,
    mapdef: MapDef,
    path: str | Path,
    *,
    predictions: Any = None,
    title: str | None = None,
    collision_step: int | None = None,
    collision_point: Any = None,
    robot_radius: float = 1.0,
    ped_radius: float = 0.4,
    max_frames: int = 150,
    width_px: int = 560,
    speed: float = 1.0,
    max_bytes: int = 2_000_000,
) -> Path:
    """Write an animated GIF (or, for a ``.mp4`` path, an H.264 video) of the episode to ``path``; returns the path.

    ``predictions``: anything :func:`prediction_steps` accepts; each frame shows the latest forecast made
    at or before it. ``speed``: playback speed relative to simulated time (frame delays of at least
    40 ms). ``collision_step``/``collision_point`` default to the trace's attributes of those names.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    n = recorded_states(trace)
    robot_xy = np.asarray(trace.robot, dtype=float)[:n, :2]
    hit_step, hit_xy = _hit(trace, robot_xy, collision_step, collision_point)
    forecasts = prediction_steps(predictions)
    fig, ax = map_axes(mapdef, title=title, extra_width_in=1.8)
    fig.set_dpi(width_px / fig.get_figwidth())
    draw_map(ax, mapdef, routes=True, legend=False)
    a = _setup(ax, robot_radius)
    fig.tight_layout()

    def draw(t: int) -> None:
        _update(a, ax, trace, t, forecasts, hit_step, hit_xy, ped_radius)

    frames = max_frames
    if path.suffix.lower() == ".mp4":  # a video codec keeps every frame small: no re-encoding for size
        steps = frame_steps(n, frames, [] if hit_step is None else [hit_step])
        stride = (n - 1) / max(len(steps) - 1, 1)
        frame_ms = max(MIN_FRAME_MS, int(round(1000 * stride * float(trace.dt) / speed)))
        return _encode_mp4(_Blitter(fig, ax, a), steps, draw, path, frame_ms)
    for _ in range(4):
        steps = frame_steps(n, frames, [] if hit_step is None else [hit_step])
        stride = (n - 1) / max(len(steps) - 1, 1)
        frame_ms = max(MIN_FRAME_MS, int(round(1000 * stride * float(trace.dt) / speed)))
        _encode(_Blitter(fig, ax, a), steps, draw, path, frame_ms)
        if path.stat().st_size <= max_bytes:
            break
        frames = max(10, frames // 2)
        fig.set_dpi(fig.get_dpi() * 0.8)
    return path
