"""The pedestrians of evaluated episodes as TrajNet++ ndjson, so other tools read what our crowds did.

Reads an evaluation's (or a campaign cell's) compact episode traces (``traces/*.json.gz``, the player's files) and
writes one ``.ndjson`` per episode: a scene record (the whole episode, ``fps`` of the kept frames) and a track per
pedestrian and kept frame (``f``: the simulator step, ``p``: the pedestrian's true id, ``x``/``y`` [m]). The robot is
not a pedestrian and is left out. Imported back with ``dataset import --format trajnet --frame-interval DT`` (DT: the
trace's step times its frame stride).
"""

from __future__ import annotations

import gzip
import json
from pathlib import Path

from foresight.core import files
from foresight.core.errors import ConfigError, NotFoundError

TRACE_FORMAT = "foresight.episode-trace/1"


def export_episodes(run_dir: Path, out_dir: Path) -> list[Path]:
    """One TrajNet++ file per episode trace of ``run_dir`` into ``out_dir``; returns the files written."""
    traces = sorted((Path(run_dir) / "traces").glob("*.json.gz"))
    if not traces:
        raise NotFoundError(f"no episode traces in {Path(run_dir) / 'traces'} (an evaluation's work folder?)")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for path in traces:
        with gzip.open(path, "rt", encoding="utf-8") as f:
            data = json.load(f)
        if data.get("format") != TRACE_FORMAT:
            raise ConfigError(
                f"not an episode trace ({data.get('format')!r}, expected {TRACE_FORMAT})", source=path
            )
        frames, dt, stride = data["frames"], float(data["dt"]), int(data.get("stride", 1))
        target = out_dir / (path.name[: -len(".json.gz")] + ".ndjson")
        scene = {
            "id": 0,
            "p": -1,
            "s": frames[0],
            "e": frames[-1],
            "fps": round(1.0 / (dt * stride), 6),
            "tag": [data["scenario"], data["seed"]],
        }
        with files.replacing(target) as tmp, tmp.open("w", encoding="utf-8") as out:
            out.write(json.dumps({"scene": scene}) + "\n")
            for t, peds in zip(frames, data["peds"], strict=True):
                if (
                    t % stride
                ):  # a long episode's last step, kept off the grid: dropped, frames stay evenly apart
                    continue
                for pid, x, y in peds:
                    out.write(json.dumps({"track": {"f": t, "p": pid, "x": x, "y": y}}) + "\n")
        written.append(target)
    return written
