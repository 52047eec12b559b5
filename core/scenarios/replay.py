"""Replay scenes: recorded ETH/UCY pedestrians as the crowd of an ordinary scenario.

A matrix entry with a ``replay`` block (``model.ReplayConfig``) names a scene file of a data root
(``<root>/raw/all_data/<scene>.txt``: frame, id, x, y every 10 frame units), the annotated frame
where the episode starts, and the robot's start and goal. The loader turns it into

- a map: the scene's walkable bounds, i.e. every recorded position of the whole scene plus a margin,
  shifted so that its lower-left corner is the origin; no obstacles (the recordings carry none);
  the robot's spawn and goal zones are 0.1 m squares around ``robot_start``/``robot_goal``;
- the window's tracks (``model.ReplayTracks``): every annotation from the start frame to the
  first frame at or after the end of the horizon, in the map frame, with its instant in simulator
  steps. ``core.sim.replay`` moves the pedestrians along them, ignoring the robot.

Every problem (unknown data root or scene, a start frame that is not annotated, a window running
past the scene's end, a robot start or goal outside the bounds) is a ConfigError naming the matrix
file, the scenario and the item, raised while the matrix loads, before any episode runs.

``select_episodes`` is the documented rule that picked the stress suite's replay episodes (see its
docstring): it reads the recordings only, never a planner's result.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from foresight.core.errors import ConfigError, NotFoundError
from foresight.core.maps.model import MapDef, Route, Zone
from foresight.core.scenarios.ethucy import read_scene
from foresight.core.scenarios.model import ReplayTracks, Scenario

FRAME_STEP = 10  #: frame-number units between two annotations (every ETH/UCY file)
SCENE_FOLDER = ("raw", "all_data")  #: where a data root keeps its whole scene files
ZONE_SIZE = 0.1  #: side of the robot's spawn and goal squares [m]


def scene_file(root: Path, scene: str) -> Path:
    return Path(root).joinpath(*SCENE_FOLDER, f"{scene}.txt")


class SceneFiles:
    """Scene files read once per matrix: path -> (rows (R, 4) frame, id, x, y; sha256 of the file)."""

    def __init__(self, data_roots: Callable[[str], Path]):
        self.data_roots = data_roots
        self._cache: dict[Path, tuple[np.ndarray, str]] = {}

    def rows(self, scenario: Scenario, source: Path) -> tuple[np.ndarray, str, Path]:
        cfg = scenario.replay
        assert cfg is not None
        item = f"{scenario.name}.replay"
        try:
            root = self.data_roots(cfg.data_root)
        except NotFoundError as err:
            raise ConfigError(str(err), source=source, item=f"{item}.data_root") from None
        path = scene_file(root, cfg.scene)
        if not path.is_file():
            have = ", ".join(sorted(p.stem for p in path.parent.glob("*.txt"))) or "none"
            raise ConfigError(
                f"no scene {cfg.scene!r} in data root {cfg.data_root!r} ({path} does not exist; "
                f"scenes: {have})",
                source=source,
                item=f"{item}.scene",
            )
        if path not in self._cache:
            self._cache[path] = (read_scene(path), hashlib.sha256(path.read_bytes()).hexdigest())
        rows, sha = self._cache[path]
        return rows, sha, path


def steps_per_frame(frame_dt: float, dt: float) -> float:
    """Simulator steps per annotation, exactly whole when dt divides frame_dt (so recorded instants fall on steps)."""
    ratio = frame_dt / dt
    return float(round(ratio)) if abs(ratio - round(ratio)) < 1e-9 else ratio


def window_end(start_frame: int, horizon_s: float, frame_dt: float) -> int:
    """The first annotated frame number at or after ``horizon_s`` seconds from ``start_frame``."""
    return int(start_frame + FRAME_STEP * math.ceil(horizon_s / frame_dt - 1e-9))


def replay_scene(scenario: Scenario, source: Path, scenes: SceneFiles) -> tuple[MapDef, ReplayTracks, str]:
    """(map, tracks, sha256 of the scene file) of a replay scenario; ConfigError naming file, scenario and item."""
    cfg, sim = scenario.replay, scenario.simulation_config
    assert cfg is not None
    item = f"{scenario.name}.replay"
    rows, sha, path = scenes.rows(scenario, source)
    frames = np.unique(rows[:, 0]).astype(np.int64)
    if cfg.start_frame not in set(frames.tolist()):
        raise ConfigError(
            f"frame {cfg.start_frame} is not annotated in scene {cfg.scene!r} (frames {frames[0]}.."
            f"{frames[-1]} every {FRAME_STEP})",
            source=source,
            item=f"{item}.start_frame",
        )
    end = window_end(cfg.start_frame, sim.max_episode_steps * sim.dt, cfg.frame_dt)
    if end > frames[-1]:
        raise ConfigError(
            f"the episode ({sim.max_episode_steps} steps of {sim.dt} s from frame {cfg.start_frame}) "
            f"runs past the scene's last frame {frames[-1]} (needs frame {end})",
            source=source,
            item=f"{item}.start_frame",
        )
    lo = rows[:, 2:4].min(axis=0) - cfg.margin
    hi = rows[:, 2:4].max(axis=0) + cfg.margin
    for key in ("robot_start", "robot_goal"):
        p = np.asarray(getattr(cfg, key), dtype=float)
        if not np.all((p > lo) & (p < hi)):
            raise ConfigError(
                f"{tuple(p)} lies outside the scene's walkable bounds x {lo[0]:.2f}..{hi[0]:.2f}, "
                f"y {lo[1]:.2f}..{hi[1]:.2f}",
                source=source,
                item=f"{item}.{key}",
            )
    win = rows[(rows[:, 0] >= cfg.start_frame) & (rows[:, 0] <= end)]
    win = win[np.lexsort((win[:, 0], win[:, 1]))]
    tracks = ReplayTracks(
        step=(win[:, 0] - cfg.start_frame) / FRAME_STEP * steps_per_frame(cfg.frame_dt, sim.dt),
        ids=win[:, 1].astype(np.int64),
        xy=win[:, 2:4] - lo,
        offset=(float(lo[0]), float(lo[1])),
    )
    start = tuple(float(v) for v in np.asarray(cfg.robot_start) - lo)
    goal = tuple(float(v) for v in np.asarray(cfg.robot_goal) - lo)
    h = ZONE_SIZE / 2
    mapdef = MapDef(
        name=f"replay_{cfg.scene}",
        width=float(hi[0] - lo[0]),
        height=float(hi[1] - lo[1]),
        robot_spawn_zones=(Zone.from_rect(start[0] - h, start[1] - h, ZONE_SIZE, ZONE_SIZE),),
        robot_goal_zones=(Zone.from_rect(goal[0] - h, goal[1] - h, ZONE_SIZE, ZONE_SIZE),),
        robot_routes=(Route(spawn_id=0, goal_id=0, waypoints=(start, goal)),),
        source=str(path),
    )
    return mapdef, tracks, sha


# ------------------------------------------------------------------------------ the selection rule


@dataclass(frozen=True)
class ReplayEpisode:
    """One replay episode chosen by ``select_episodes`` (scene coordinates) and the numbers that chose it."""

    scene: str
    start_frame: int
    robot_start: tuple[float, float]
    robot_goal: tuple[float, float]
    crossings: (
        int  #: distinct recorded pedestrians whose path crosses the robot's straight start-goal segment
    )
    pedestrians: int  #: distinct pedestrians annotated in the window


def _crosses(a: np.ndarray, b: np.ndarray, p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(K,) whether segments p[k]-q[k] properly cross the segment a-b."""

    def side(o, u, v):
        return (u[..., 0] - o[..., 0]) * (v[..., 1] - o[..., 1]) - (u[..., 1] - o[..., 1]) * (
            v[..., 0] - o[..., 0]
        )

    return (side(a, b, p) * side(a, b, q) < 0) & (side(p, q, a) * side(p, q, b) < 0)


def select_episodes(
    scene: str,
    rows: np.ndarray,
    frame_dt: float,
    *,
    horizon_s: float,
    count: int,
    every_frames: int = 50,
    length: tuple[float, float] = (5.0, 14.0),
    clear_radius: float = 2.5,
    clear_s: float = 2.0,
    margin: float = 0.5,
) -> list[ReplayEpisode]:
    """The replay episodes of one scene, by a rule that reads only the recordings.

    Candidate windows start at annotated frames every ``every_frames`` frame units and last
    ``horizon_s``. In each window the main flow direction is the principal axis of the
    pedestrians' steps (direction-agnostic: a two-way flow counts once); the robot crosses it at
    right angles, through the median recorded position, over the span that 90 % of the positions
    occupy across the flow plus 1 m each side (clipped to ``length`` and to the scene's extent less
    ``margin``). A candidate is dropped when a pedestrian comes within ``clear_radius`` of the
    robot's start in the window's first ``clear_s`` seconds (the robot would start in contact, or be
    walked into before it can move). Candidates are ranked by how many distinct pedestrians cross
    the robot's straight path (interaction density), ties by start frame, and the first ``count``
    that do not overlap in time are kept, in start-frame order.
    """
    frames = np.unique(rows[:, 0]).astype(np.int64)
    span = window_end(0, horizon_s, frame_dt)
    lo, hi = rows[:, 2:4].min(axis=0) + margin, rows[:, 2:4].max(axis=0) - margin
    found: list[ReplayEpisode] = []
    for start in frames[(frames <= frames[-1] - span) & ((frames - frames[0]) % every_frames == 0)]:
        win = rows[(rows[:, 0] >= start) & (rows[:, 0] <= start + span)]
        win = win[np.lexsort((win[:, 0], win[:, 1]))]
        same = (win[1:, 1] == win[:-1, 1]) & (np.diff(win[:, 0]) == FRAME_STEP)
        p, q = win[:-1, 2:4][same], win[1:, 2:4][same]
        d = q - p
        if len(d) < 2 or not np.any(d):
            continue
        _, vecs = np.linalg.eigh(d.T @ d)
        normal = np.array([-vecs[1, 1], vecs[0, 1]])  # across the principal axis
        normal *= 1.0 if normal[0] > 0 or (normal[0] == 0 and normal[1] > 0) else -1.0
        centre = np.median(win[:, 2:4], axis=0)
        across = (win[:, 2:4] - centre) @ normal
        a, b = np.percentile(across, [5, 95])
        half = float(np.clip(max(-a, b) + 1.0, length[0] / 2, length[1] / 2))
        s, g = np.clip(centre - half * normal, lo, hi), np.clip(centre + half * normal, lo, hi)
        if np.hypot(*(g - s)) < length[0]:
            continue
        first = win[win[:, 0] <= window_end(int(start), clear_s, frame_dt), 2:4]
        if len(first) and np.hypot(*(first - s).T).min() < clear_radius:
            continue
        hits = _crosses(s, g, p, q)
        found.append(
            ReplayEpisode(
                scene,
                int(start),
                (round(float(s[0]), 2), round(float(s[1]), 2)),
                (round(float(g[0]), 2), round(float(g[1]), 2)),
                int(len(np.unique(win[:-1, 1][same][hits]))),
                int(len(np.unique(win[:, 1]))),
            )
        )
    chosen: list[ReplayEpisode] = []
    for ep in sorted(found, key=lambda e: (-e.crossings, e.start_frame)):
        if all(abs(ep.start_frame - c.start_frame) > span for c in chosen):
            chosen.append(ep)
        if len(chosen) == count:
            break
    return sorted(chosen, key=lambda e: e.start_frame)
