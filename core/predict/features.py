"""The ONE feature extraction, shared by data collection (from traces) and the planner (from live
observations), so training and serving can never see differently built inputs.

Both paths first build a :class:`Window` with :func:`gather_history` (pedestrian positions by true
id, sampled every ``stride`` simulator steps back from the current one), then call
:func:`extract_features`.

Frame conventions (stored in every dataset and checkpoint):
- ``robot``: simulator data and the planner. Origin = robot position at the current step, x axis
  = robot heading (x forward, y left); frozen at the current step for the targets too.
- ``focal_pedestrian``: robot-less real data (ETH/UCY). Origin = the predicted (focal)
  pedestrian's current position, x axis = its last observed displacement (backward difference,
  world x when it stood still); the ego channels (robot motion, goal) are zero. Only observed
  steps are used to place the frame.

Per slot (N nearest pedestrians to the ego origin, closest first), per history step h = 0..H-1
(oldest first, h = H-1 the current step): position [m] and velocity [m/s] in the ego frame, and a
valid flag. Velocity = backward difference (p_h - p_{h-1}) / dt, zero unless both steps are
observed: never a central difference, which would read the future. Unobserved steps are zero with
valid 0. Then five ego channels copied into every active slot: robot v [m/s], omega [rad/s], unit
direction to the current waypoint in the ego frame, and the waypoint distance clipped to
GOAL_DIST_CLIP [m]. Inactive slots are all zero.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from foresight.core.predict.timebase import TimeBase

STEP_CHANNELS = ("px", "py", "vx", "vy", "valid")
EGO_CHANNELS = ("ego_v", "ego_w", "goal_ux", "goal_uy", "goal_dist")
GOAL_DIST_CLIP = 10.0  #: [m] farther waypoints only matter by direction
FRAME_CONVENTIONS = ("robot", "focal_pedestrian")


def feature_names(history: int) -> list[str]:
    """Names of the F = 5 H + 5 per-slot channels, e.g. ``px[-4]`` .. ``valid[0]``, ``ego_v``."""
    names = [f"{c}[{h - history + 1}]" for h in range(history) for c in STEP_CHANNELS]
    return names + list(EGO_CHANNELS)


def feature_dim(history: int) -> int:
    return len(STEP_CHANNELS) * history + len(EGO_CHANNELS)


def current_index(history: int, channel: str) -> int:
    """Column of ``channel`` (one of STEP_CHANNELS) at the current step."""
    return len(STEP_CHANNELS) * (history - 1) + STEP_CHANNELS.index(channel)


def mirror_signs(history: int) -> np.ndarray:
    """(F,) +-1 per channel that mirrors a feature row across the ego x axis (y -> -y).

    The frames are left/right symmetric, so a mirrored sample (targets' y negated too) is as valid
    as the original: a free data augmentation. Flipped: py, vy, goal_uy and the turn rate ego_w.
    """
    flip = ("py[", "vy[", "goal_uy", "ego_w")
    return np.array([-1.0 if n.startswith(flip) else 1.0 for n in feature_names(history)], dtype=np.float32)


def length_channels(history: int) -> np.ndarray:
    """(F,) 1.0 for channels measured in metres or m/s (positions, velocities, robot v, goal distance), else 0.

    Scaling these and the targets by one factor is the same scene walked faster or slower (a scale
    augmentation; ETH/UCY's eth scene runs about 1.6x faster than the others).
    """
    lengths = ("px[", "py[", "vx[", "vy[", "ego_v", "goal_dist")
    return np.array([1.0 if n.startswith(lengths) else 0.0 for n in feature_names(history)], dtype=np.float32)


@dataclass(frozen=True)
class Window:
    """What is known at one instant, in the world frame, on a time base's grid."""

    ego_pose: np.ndarray  #: (3,) x, y, heading [m, m, rad] of the frame origin/axis
    ego_motion: np.ndarray  #: (2,) robot v [m/s], omega [rad/s]; zeros for robot-less data
    goal: np.ndarray | None  #: (2,) current waypoint [m], None when there is none
    ped_ids: np.ndarray  #: (M,) int64 true ids of the pedestrians present now
    ped_hist: np.ndarray  #: (M, H, 2) world positions [m], oldest first; current = [:, -1]
    hist_valid: np.ndarray  #: (M, H) bool, True where observed (current step always True)


@dataclass(frozen=True)
class Features:
    features: np.ndarray  #: (N, F) float32
    mask: np.ndarray  #: (N,) float32 {0, 1}
    ped_ids: np.ndarray  #: (N,) int64, -1 for empty slots
    origin: np.ndarray  #: (2,) world position of the ego frame origin [m]
    heading: float  #: ego frame x axis in the world [rad]


def gather_history(
    frame_ids: Sequence[np.ndarray],
    frame_pos: Sequence[np.ndarray],
    stride: int,
    history: int,
    ids: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Positions of ``ids`` (M,) at H grid points ending at the last frame, by true id.

    ``frame_ids[k]`` (N_k,) / ``frame_pos[k]`` (N_k, 2) are simulator frames, oldest first; grid
    point h reads frame ``len - 1 - (H - 1 - h) * stride``. Returns (M, H, 2) and (M, H) bool.
    """
    ids = np.asarray(ids, dtype=np.int64)
    pos = np.zeros((len(ids), history, 2))
    valid = np.zeros((len(ids), history), dtype=bool)
    last = len(frame_ids) - 1
    # frames holding exactly ``ids`` in order (a pedestrian set that did not change) are copied whole: with
    # distinct non-negative ids that is what the matching below selects
    # ufunc reductions: the tests of np.all / np.diff without their Python wrappers (~20 us per decision)
    srt = np.sort(ids)
    plain = len(ids) > 0 and bool(srt[0] >= 0) and not bool(np.logical_or.reduce(srt[1:] == srt[:-1]))
    for h in range(history):
        k = last - (history - 1 - h) * stride
        if k < 0 or len(ids) == 0:
            continue
        fid = np.asarray(frame_ids[k])
        if plain and fid.shape == ids.shape and bool(np.logical_and.reduce(fid == ids)):
            pos[:, h] = frame_pos[k]
            valid[:, h] = True
            continue
        match = (ids[:, None] == fid[None, :]) & (fid[None, :] >= 0)
        found = match.any(axis=1)
        if not found.any():  # e.g. a frame with nobody in it: argmax over an empty row would raise
            continue
        pos[found, h] = np.asarray(frame_pos[k])[match[found].argmax(axis=1)]
        valid[found, h] = True
    return pos, valid


def world_to_ego(points: np.ndarray, origin: np.ndarray, heading: float) -> np.ndarray:
    """(..., 2) world points -> ego frame: x' = c dx + s dy, y' = -s dx + c dy."""
    c, s = np.cos(heading), np.sin(heading)
    d = np.asarray(points, dtype=np.float64) - origin
    out = np.empty(d.shape)  # both columns written in place: np.stack's copies cost more than the arithmetic
    out[..., 0] = c * d[..., 0] + s * d[..., 1]
    out[..., 1] = -s * d[..., 0] + c * d[..., 1]
    return out


def ego_to_world(points: np.ndarray, origin: np.ndarray, heading: float) -> np.ndarray:
    """Inverse of :func:`world_to_ego` for (..., 2) points."""
    c, s = np.cos(heading), np.sin(heading)
    p = np.asarray(points, dtype=np.float64)
    out = np.empty(p.shape)
    out[..., 0] = c * p[..., 0] - s * p[..., 1]
    out[..., 1] = s * p[..., 0] + c * p[..., 1]
    out += origin
    return out


def rotate_to_ego(vectors: np.ndarray, heading: float) -> np.ndarray:
    """(..., 2) world vectors (velocities) -> ego frame: rotation only, no translation."""
    return world_to_ego(vectors, np.zeros(2), heading)


def select_nearest(window: Window, max_agents: int | None) -> np.ndarray:
    """Indices into the window's pedestrians: the ``max_agents`` nearest the ego origin, closest first."""
    d = window.ped_hist[:, -1] - window.ego_pose[:2]
    d = np.sqrt(np.add.reduce(d * d, axis=1))  # np.linalg.norm(d, axis=1) without its Python wrapper
    order = np.argsort(d, kind="stable")
    return order if max_agents is None else order[:max_agents]


def extract_features(window: Window, timebase: TimeBase, max_agents: int | None) -> Features:
    """(N, F) features of the N = ``max_agents`` nearest pedestrians (all when None) of a window."""
    H = timebase.history
    if window.ped_hist.shape[1:] != (H, 2):
        raise ValueError(f"window history {window.ped_hist.shape} does not match H={H}")
    origin, heading = np.asarray(window.ego_pose[:2], float), float(window.ego_pose[2])
    sel = select_nearest(window, max_agents)
    n_slots = len(sel) if max_agents is None else max_agents
    hist, valid = window.ped_hist[sel], window.hist_valid[sel]
    pos = world_to_ego(hist, origin, heading) * valid[..., None]
    vel = np.zeros_like(pos)
    both = valid[:, 1:] & valid[:, :-1]
    vel[:, 1:] = (pos[:, 1:] - pos[:, :-1]) / timebase.dt * both[..., None]
    steps = np.concatenate([pos, vel, valid[..., None].astype(float)], axis=-1)  # (M, H, 5)
    out = np.zeros((n_slots, feature_dim(H)), dtype=np.float32)
    out[: len(sel), : 5 * H] = steps.reshape(len(sel), 5 * H)
    out[: len(sel), 5 * H :] = _ego_channels(window, origin, heading)
    mask = np.zeros(n_slots, dtype=np.float32)
    mask[: len(sel)] = 1.0
    ids = np.full(n_slots, -1, dtype=np.int64)
    ids[: len(sel)] = window.ped_ids[sel]
    return Features(out, mask, ids, origin, heading)


def _ego_channels(window: Window, origin: np.ndarray, heading: float) -> np.ndarray:
    """(5,) robot v, omega, goal unit vector (ego frame), clipped goal distance; zero goal if none."""
    goal = [0.0, 0.0, 0.0]  # Python floats: the same IEEE operations as on 0-d arrays, without their overhead
    if window.goal is not None:
        gx, gy = world_to_ego(np.asarray(window.goal, float), origin, heading).tolist()
        dist = float(np.hypot(gx, gy))
        if dist > 1e-9:
            goal = [gx / dist, gy / dist, min(dist, GOAL_DIST_CLIP)]
    return np.array([*np.asarray(window.ego_motion, float).tolist(), *goal])
