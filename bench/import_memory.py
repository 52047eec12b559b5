"""Peak memory of importing a large TrajNet++ file: ``foresight dataset import --format trajnet`` in a child process.

A synthetic recording of ``--mb`` megabytes (pedestrians walking straight across a square, about ten at a time, each
annotated for ``--track-frames`` frames at 0.4 s) is written to a temporary folder and imported as one scene; the
child's peak resident set (ru_maxrss) and wall time are reported, with the file's size, its track lines and the
windows written. The reader streams (rows, 32 bytes each, gathered in chunks); the windows (about 3.4 kB each at
12 slots) go to the dataset file piece by piece (``core.predict.dataset_writer``), so only the rows grow with the
file. Target: peak RSS <= 500 MB for a 100 MB file (``--mb 100``; a few minutes). ``--json`` prints ONE JSON
object.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent


def write_trajnet(path: Path, mb: float, track_frames: int, seed: int = 0) -> int:
    """A synthetic TrajNet++ file of about ``mb`` megabytes; returns its track lines."""
    rng = np.random.default_rng(seed)
    lines = 0
    with path.open("w") as f:
        f.write(json.dumps({"scene": {"id": 0, "p": 0, "s": 0, "e": 19, "fps": 2.5}}) + "\n")
        ped, start = 0, 0
        while f.tell() < mb * 1e6:
            x0, y0 = rng.uniform(0, 20, 2)
            vx, vy = rng.normal(0, 1.0, 2)
            for k in range(track_frames):
                t = 0.4 * k
                rec = {
                    "f": (start + k) * 10,
                    "p": ped,
                    "x": round(x0 + vx * t, 2),
                    "y": round(y0 + vy * t, 2),
                }
                f.write(json.dumps({"track": rec}) + "\n")
            lines += track_frames
            ped += 1
            start += track_frames // 10 if ped % 10 == 0 else 0  # about ten pedestrians at a time
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mb", type=float, default=10.0)
    ap.add_argument("--track-frames", type=int, default=22)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        src = Path(tmp) / "big.ndjson"
        lines = write_trajnet(src, args.mb, args.track_frames)
        out = Path(tmp) / "big.npz"
        cmd = [
            str(Path(sys.executable).with_name("foresight")),
            "dataset",
            "import",
            str(src),
            "--format",
            "trajnet",
            "--frame-interval",
            "0.4",
            "--output",
            str(out),
            "--local",
            "--json",
        ]
        t0 = time.perf_counter()
        proc = subprocess.run(cmd, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        if proc.returncode:
            sys.exit(proc.stderr.strip())
        peak_mb = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024
        samples = json.loads(proc.stdout)["summary"]["samples"]
        result = {
            "benchmark": "import_memory",
            "targets": {"file_mb": 100, "peak_rss_mb": 500},
            "file_mb": round(src.stat().st_size / 1e6, 1),
            "track_lines": lines,
            "windows": samples,
            "peak_rss_mb": round(peak_mb, 1),
            "wall_s": round(wall, 1),
        }
    if args.json:
        print(json.dumps(result))
    else:
        print(
            f"{result['file_mb']} MB, {lines} track lines -> {samples} windows: peak RSS {result['peak_rss_mb']} MB, "
            f"{result['wall_s']} s"
        )


if __name__ == "__main__":
    main()
