"""Training samples from a recorded simulator trace, by the simulator's true pedestrian ids.

A sample at simulator step t: features of the N nearest pedestrians present at t (the one
:func:`~core.predict.features.extract_features`), and their positions at t + k·stride,
k = 1..T, in the robot frame frozen at t. ``target_mask`` is 1 only where the same id is present
at that future step, so a pedestrian that respawns (new id) or leaves is masked, never matched to
someone else.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from foresight.core.predict.features import (
    Window,
    extract_features,
    feature_dim,
    gather_history,
    world_to_ego,
)
from foresight.core.predict.timebase import TimeBase


@dataclass(frozen=True)
class SampleArrays:
    state: np.ndarray  #: (S, N, F) float32
    target: np.ndarray  #: (S, N, T, 2) float32, ego frame at the sample's step [m]
    mask: np.ndarray  #: (S, N) float32
    target_mask: np.ndarray  #: (S, N, T) float32
    step: np.ndarray  #: (S,) int64 simulator step of each sample

    def __len__(self) -> int:
        return len(self.step)


def trace_window(trace, t: int, timebase: TimeBase, waypoints: np.ndarray | None) -> Window:
    """The situation at step ``t`` of a trace, as the planner would have seen it live.

    ``waypoints`` (T+1, 2): the robot's current waypoint per step (what ``Observation.waypoint``
    said); None = no goal channels.
    """
    stride = timebase.stride(trace.dt)
    ids = np.asarray(trace.ped_ids[t], dtype=np.int64)
    ids = ids[ids >= 0]
    hist, valid = gather_history(
        trace.ped_ids[: t + 1], trace.ped_pos[: t + 1], stride, timebase.history, ids
    )
    robot = np.asarray(trace.robot[t], dtype=float)
    return Window(
        ego_pose=robot[:3],
        ego_motion=robot[3:5],
        goal=None if waypoints is None else np.asarray(waypoints[t], float),
        ped_ids=ids,
        ped_hist=hist,
        hist_valid=valid,
    )


def future_targets(
    trace, t: int, timebase: TimeBase, slot_ids: np.ndarray, origin: np.ndarray, heading: float
) -> tuple[np.ndarray, np.ndarray]:
    """(N, T, 2) future positions of ``slot_ids`` in the ego frame at t, and the (N, T) mask."""
    stride = timebase.stride(trace.dt)
    n, T = len(slot_ids), timebase.horizon
    target = np.zeros((n, T, 2), dtype=np.float32)
    tmask = np.zeros((n, T), dtype=np.float32)
    last = len(trace.ped_ids) - 1
    for k in range(1, T + 1):
        j = t + k * stride
        if j > last:
            break
        fid = np.asarray(trace.ped_ids[j])
        match = (slot_ids[:, None] == fid[None, :]) & (slot_ids[:, None] >= 0)
        found = match.any(axis=1)
        world = np.asarray(trace.ped_pos[j])[match[found].argmax(axis=1)]
        target[found, k - 1] = world_to_ego(world, origin, heading)
        tmask[found, k - 1] = 1.0
    return target, tmask


def samples_from_trace(
    trace, timebase: TimeBase, max_agents: int, waypoints: np.ndarray | None, sample_every: int | None = None
) -> SampleArrays:
    """Samples at steps 0, e, 2e, ... whose full horizon lies inside the trace (e = stride by default)."""
    stride = timebase.stride(trace.dt)
    every = sample_every or stride
    last_t = len(trace.ped_ids) - 1 - timebase.horizon * stride
    steps = np.arange(0, max(last_t + 1, 0), every, dtype=np.int64)
    out = {k: [] for k in ("state", "target", "mask", "target_mask")}
    for t in steps:
        f = extract_features(trace_window(trace, int(t), timebase, waypoints), timebase, max_agents)
        target, tmask = future_targets(trace, int(t), timebase, f.ped_ids, f.origin, f.heading)
        out["state"].append(f.features)
        out["mask"].append(f.mask)
        out["target"].append(target)
        out["target_mask"].append(tmask * f.mask[:, None])
    if not len(steps):
        N, T = max_agents, timebase.horizon
        return SampleArrays(
            np.zeros((0, N, feature_dim(timebase.history)), np.float32),
            np.zeros((0, N, T, 2), np.float32),
            np.zeros((0, N), np.float32),
            np.zeros((0, N, T), np.float32),
            steps,
        )
    return SampleArrays(*(np.stack(out[k]).astype(np.float32) for k in out), steps)
