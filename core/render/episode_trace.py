"""A compact, bounded trace of every evaluated episode, for the browser's episode player.

Written next to ``episodes.jsonl`` as ``traces/<scenario>__<seed>.json.gz``: the robot's pose and command per
frame, the pedestrians present (true ids), the goal with its tolerance, the radii, the map's walls, the collision,
and the planner's logged forecasts (every ``PREDICTION_STRIDE``-th decision) with their per-axis
standard deviation when the planner reports one. Positions are rounded to a
centimetre and at most ``MAX_FRAMES`` frames are kept (a longer episode keeps every k-th step and its last), so a
file stays around 100 KB whatever the horizon. The full-resolution ``.npz`` trace remains the diagnostics' job.
"""

from __future__ import annotations

import gzip
import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np

from foresight.core import files

FORMAT = "foresight.episode-trace/1"
MAX_FRAMES = 1200  #: frames kept per episode (every k-th step beyond it)
MAX_FORECASTS = 150  #: logged forecasts kept per episode (evenly thinned beyond it)
TRACES = "traces"  #: the folder of an evaluation's work directory that holds them


def safe_name(text: str) -> str:
    """``text`` as one file or folder name: characters other than letters, digits, '.', '_' and '-' become '_',
    and no name is '.' or '..'."""
    name = re.sub(r"[^A-Za-z0-9._-]", "_", text)
    return f"_{name}" if name in (".", "..") else name


def episode_stem(scenario: str, seed: int) -> str:
    """An episode's file name without its suffix: ``<scenario>__<seed>``."""
    return f"{safe_name(scenario)}__{int(seed)}"


def trace_name(scenario: str, seed: int) -> str:
    """The work-directory-relative file of an episode's compact trace."""
    return f"{TRACES}/{episode_stem(scenario, seed)}.json.gz"


def _r(a: Any, digits: int = 2) -> Any:
    return np.round(np.asarray(a, dtype=float), digits).tolist()


def compact_trace(run: Any, map_def: Any) -> dict[str, Any]:
    """The player's data of an :class:`~foresight.core.evaluation.episode.EpisodeRun` on map ``map_def``."""
    trace, geom, rec = run.trace, run.geometry, run.record
    steps = int(trace.steps)
    stride = max(1, math.ceil((steps + 1) / MAX_FRAMES))
    rows = list(range(0, steps + 1, stride))
    if rows[-1] != steps:
        rows.append(steps)
    ids, pos = trace.ped_ids, trace.ped_pos
    cmd = trace.command
    peds = []
    for t in rows:
        present = ids[t] >= 0
        peds.append(
            [[int(i), *p] for i, p in zip(ids[t][present].tolist(), _r(pos[t][present]), strict=True)]
        )
    forecasts = list(
        zip(run.log.predictions, run.log.spreads or [None] * len(run.log.predictions), strict=True)
    )
    if len(forecasts) > MAX_FORECASTS:
        keep = np.linspace(0, len(forecasts) - 1, MAX_FORECASTS).round().astype(int)
        forecasts = [forecasts[i] for i in keep]
    route = np.asarray(geom.route, dtype=float)
    return {
        "format": FORMAT,
        "scenario": rec.scenario,
        "seed": rec.seed,
        "planner": rec.planner,
        "outcome": rec.outcome,
        "label": rec.taxonomy.label,
        "dt": float(trace.dt),
        "steps": steps,
        "stride": stride,
        "frames": rows,
        "robot_radius": geom.robot_radius,
        "ped_radius": geom.ped_radius,
        "goal": _r(route[-1]),
        "goal_tolerance": float(geom.goal_tolerance),
        "route": _r(route),
        "map": {
            "width": float(map_def.width),
            "height": float(map_def.height),
            "obstacles": [_r(poly) for poly in map_def.obstacles],
        },
        "robot": [_r(trace.robot[t], 3) for t in rows],
        "command": [_r(cmd[min(t, len(cmd) - 1)], 3) if len(cmd) else [0.0, 0.0] for t in rows],
        "peds": peds,
        "collision": None
        if trace.collision_step < 0
        else {
            "step": int(trace.collision_step),
            "kind": trace.collision_kind,
            "point": _r(trace.collision_point) if np.isfinite(trace.collision_point).all() else None,
            "ped_id": rec.taxonomy.critical_ped_id,
        },
        "forecasts": [
            {
                "step": int(step),
                "ids": np.asarray(fids).astype(int).tolist(),
                "times": _r(times, 3),
                "positions": _r(fpos),
                "sigma": None if sigma is None else _r(sigma),
            }
            for (step, fids, fpos, times), sigma in forecasts
        ],
    }


def compact_bytes(data: dict[str, Any]) -> bytes:
    """A compact trace as the bytes of its file (gzipped JSON, reproducible: no timestamp)."""
    return gzip.compress(json.dumps(data, separators=(",", ":")).encode(), mtime=0)


def write_compact(path: Path, data: dict[str, Any] | bytes) -> Path:
    """Write a compact trace (or the :func:`compact_bytes` of one) to ``path``."""
    files.write_bytes(path, data if isinstance(data, bytes) else compact_bytes(data))
    return path


def read_compact(path: Path) -> dict[str, Any]:
    return json.loads(gzip.decompress(Path(path).read_bytes()))
