"""The episode trace: preallocated per-step arrays, always recorded, saved as one .npz with metadata.

Rows are written once and never changed, so observations hand out read-only views of them
instead of copies. Arrays are allocated for the full horizon (untouched pages cost no memory)
and trimmed to the steps actually taken by the accessors and on save.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from foresight.core import files
from foresight.core.errors import ConfigError

FORMAT = "foresight.trace/1"
#: [bytes] most memory one episode's trace may take; a horizon x crowd above it is refused before it runs
#: (a robot that cannot move fills every row, so "untouched pages are free" is no bound)
MAX_TRACE_BYTES = 256 * 2**20


def trace_bytes(horizon: int, n_peds: int) -> int:
    """Bytes of a trace's arrays: per row robot (5) + ids + pos (2) + vel (2) as 8-byte values, plus commands."""
    return (horizon + 1) * 8 * (5 + 5 * n_peds) + horizon * 16


class Trace:
    """robot (T+1, 5), command (T, 2), ped_ids (T+1, N) (-1 = empty), ped_pos/ped_vel (T+1, N, 2), events."""

    def __init__(
        self,
        horizon: int,
        n_peds: int,
        *,
        dt: float,
        scenario: str = "",
        seed: int = 0,
        meta: dict | None = None,
    ):
        need = trace_bytes(horizon, n_peds)
        if need > MAX_TRACE_BYTES:
            raise ConfigError(
                f"an episode of {horizon} steps with {n_peds} pedestrians needs a {need / 2**20:.0f} MiB "
                f"trace; the limit is {MAX_TRACE_BYTES / 2**20:.0f} MiB: lower max_steps or the crowd",
                source=scenario or None,
                item="max_steps",
            )
        self.dt = float(dt)
        self.scenario = scenario
        self.seed = int(seed)
        self.meta = dict(meta or {})
        self._robot = np.empty((horizon + 1, 5))
        self._command = np.empty((horizon, 2))
        self._ped_ids = np.empty((horizon + 1, n_peds), dtype=np.int64)
        self._ped_pos = np.empty((horizon + 1, n_peds, 2))
        self._ped_vel = np.empty((horizon + 1, n_peds, 2))
        self.steps = 0  #: steps recorded (rows 0..steps of the state arrays are valid)
        self.collision_step = -1  #: step at which a collision was detected, -1 = none
        self.collision_kind = ""  #: pedestrian | static | out_of_bounds | ""
        self.collision_point = np.full(2, np.nan)  #: (2,) [m]
        self.outcome = ""  #: success | collision_pedestrian | collision_static | timeout | "" (running)

    def record_state(
        self, t: int, robot: np.ndarray, ids: np.ndarray, pos: np.ndarray, vel: np.ndarray
    ) -> None:
        """Write the state after t steps (row t)."""
        self._robot[t] = robot
        self._ped_ids[t] = ids
        self._ped_pos[t] = pos
        self._ped_vel[t] = vel
        self.steps = t

    def record_command(self, t: int, cmd: np.ndarray) -> None:
        """Write the command applied in step t -> t + 1."""
        self._command[t] = cmd

    def row(self, t: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Read-only views (robot (5,), ids (N,), pos (N, 2), vel (N, 2)) of row t."""
        views = (self._robot[t], self._ped_ids[t], self._ped_pos[t], self._ped_vel[t])
        for v in views:
            v.flags.writeable = False
        return views

    @property
    def robot(self) -> np.ndarray:
        return self._robot[: self.steps + 1]

    @property
    def command(self) -> np.ndarray:
        return self._command[: self.steps]

    @property
    def ped_ids(self) -> np.ndarray:
        return self._ped_ids[: self.steps + 1]

    @property
    def ped_pos(self) -> np.ndarray:
        return self._ped_pos[: self.steps + 1]

    @property
    def ped_vel(self) -> np.ndarray:
        return self._ped_vel[: self.steps + 1]

    def metadata(self) -> dict:
        return {
            "format": FORMAT,
            "scenario": self.scenario,
            "seed": self.seed,
            "dt": self.dt,
            "steps": self.steps,
            "collision_step": self.collision_step,
            "collision_kind": self.collision_kind,
            "outcome": self.outcome,
            **self.meta,
        }

    def save(self, path: str | Path) -> Path:
        """Write the trimmed arrays and the metadata (JSON) to one compressed .npz."""
        path = Path(path)
        path = path if path.suffix == ".npz" else path.with_name(path.name + ".npz")  # np.savez's naming
        with files.replacing(path) as tmp, tmp.open("wb") as fh:
            np.savez_compressed(
                fh,
                robot=self.robot,
                command=self.command,
                ped_ids=self.ped_ids,
                ped_pos=self.ped_pos,
                ped_vel=self.ped_vel,
                collision_point=self.collision_point,
                meta=np.array(json.dumps(self.metadata())),
            )
        return path

    @classmethod
    def load(cls, path: str | Path) -> Trace:
        with np.load(Path(path), allow_pickle=False) as z:
            if "meta" not in z.files:
                raise ConfigError("not a trace file (no metadata)", source=path)
            meta = json.loads(str(z["meta"]))
            if meta.get("format") != FORMAT:
                raise ConfigError(f"unsupported trace format {meta.get('format')!r}", source=path)
            steps = int(meta["steps"])
            n = z["ped_ids"].shape[1]
            known = {
                "format",
                "scenario",
                "seed",
                "dt",
                "steps",
                "collision_step",
                "collision_kind",
                "outcome",
            }
            tr = cls(
                steps,
                n,
                dt=meta["dt"],
                scenario=meta["scenario"],
                seed=meta["seed"],
                meta={k: v for k, v in meta.items() if k not in known},
            )
            tr._robot[:], tr._command[:] = z["robot"], z["command"]
            tr._ped_ids[:], tr._ped_pos[:], tr._ped_vel[:] = z["ped_ids"], z["ped_pos"], z["ped_vel"]
            tr.collision_point = z["collision_point"]
        tr.steps = steps
        tr.collision_step, tr.collision_kind, tr.outcome = (
            meta["collision_step"],
            meta["collision_kind"],
            meta["outcome"],
        )
        return tr
