"""Replayed pedestrians: recorded tracks on the simulator's time grid (``Scenario.replay``).

Each recorded pedestrian is present from its first to its last annotation in the window (its slot
holds id -1 before and after, as the trace convention has it), moves linearly between annotations
(gaps included), and ignores the robot and everyone else: its path is the recording's. When dt
divides the annotation interval, the recorded instants fall on steps and the positions there are
the recorded ones exactly. Velocity is the slope of the segment the step lies in (the last
segment's at the final annotation). Everything is computed once at reset: a step is an index.

One exception to the recording: nobody walks out of thin air into a robot. A pedestrian whose track would
begin within collision distance + margin of the robot (where the recording's person was in fact walking
before the annotation began, or came out of a door the robot now blocks) is left out of the episode
(:meth:`ReplayCrowd.admit`), as the synthetic crowd never spawns there either.
"""

from __future__ import annotations

import numpy as np

from foresight.core.scenarios.model import ReplayTracks


class ReplayCrowd:
    """ids (T+1, N), pos/vel (T+1, N, 2) and presence (T+1, N) of the recorded pedestrians, per step."""

    def __init__(self, tracks: ReplayTracks, horizon: int, dt: float):
        grid = np.arange(horizon + 1, dtype=float)  # step numbers: recorded instants are whole numbers
        track_ids, first = np.unique(tracks.ids, return_index=True)
        bounds = [*first[1:], len(tracks.ids)]
        n = len(track_ids)
        self.track_ids = track_ids.astype(np.int64)
        self.pos = np.zeros((horizon + 1, n, 2))
        self.vel = np.zeros((horizon + 1, n, 2))
        self.present = np.zeros((horizon + 1, n), dtype=bool)
        for k, (a, b) in enumerate(zip(first, bounds, strict=True)):
            t, xy = tracks.step[a:b], tracks.xy[a:b]
            self.present[:, k] = (grid >= t[0]) & (grid <= t[-1])
            self.pos[:, k, 0] = np.interp(grid, t, xy[:, 0])
            self.pos[:, k, 1] = np.interp(grid, t, xy[:, 1])
            if len(t) >= 2:
                seg = np.clip(np.searchsorted(t, grid, side="right") - 1, 0, len(t) - 2)
                slope = (xy[seg + 1] - xy[seg]) / ((t[seg + 1] - t[seg]) * dt)[:, None]
                self.vel[:, k] = np.where(self.present[:, k, None], slope, 0.0)
        self.ids = np.where(self.present, self.track_ids[None, :], -1)
        self.n = n
        self.withheld: list[int] = []  #: track ids left out (``admit``)

    def admit(self, t: int, robot_xy: np.ndarray, clear: float) -> None:
        """Leaves out every track appearing at step t within ``clear`` [m] (centre distance) of the robot."""
        new = self.present[t] if t == 0 else self.present[t] & ~self.present[t - 1]
        if not new.any():
            return
        near = new & (np.hypot(*(self.pos[t] - robot_xy).T) <= clear)
        if near.any():
            self.present[t:, near] = False
            self.ids[t:, near] = -1
            self.withheld.extend(self.track_ids[near].tolist())

    def present_pos(self, t: int) -> np.ndarray:
        """(M, 2) positions of the pedestrians present at step t."""
        return self.pos[t][self.present[t]]
