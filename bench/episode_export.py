"""Episode table export benchmark: an evaluation of N episodes (default 10,000) exported to Parquet, CSV and JSON
lines as `foresight evaluations episodes RUN --out FILE` does it (read episodes.jsonl, flatten, encode, write).

The evaluation is real: a few episodes are simulated and evaluated, then their records are repeated with new
seeds up to N lines (an export's cost is the records', not the simulation's). Target: Parquet in <= 10 s.

    python bench/episode_export.py --json [--episodes 10000]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
TARGET_S = 10.0


def synthetic_run(folder: Path, episodes: int) -> Path:
    """A run folder whose episodes.jsonl holds ``episodes`` records, grown from a small real evaluation."""
    subprocess.run(
        [
            sys.executable,
            "-m",
            "foresight.cli.main",
            "evaluate",
            "--local",
            "--planner",
            "social_force",
            "--matrix",
            "configs/scenarios/classic_interactions.yaml",
            "--seeds-per-scenario",
            "1",
            "--max-steps",
            "60",
            "--out",
            str(folder),
            "--json",
        ],
        cwd=REPO,
        check=False,
        capture_output=True,
        timeout=600,
    )
    lines = (folder / "episodes.jsonl").read_text().splitlines()
    base = [json.loads(line) for line in lines if line.strip()]
    with (folder / "episodes.jsonl").open("w") as fh:
        for i in range(episodes):
            record = dict(base[i % len(base)], seed=100_000 + i)
            fh.write(json.dumps(record) + "\n")
    return folder


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=10_000)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    sys.path.insert(0, str(REPO))
    from foresight.core.evaluation.episode_table import export_jsonl

    out: dict = {"episodes": args.episodes, "target_parquet_s": TARGET_S}
    with tempfile.TemporaryDirectory() as tmp:
        run = synthetic_run(Path(tmp) / "run", args.episodes)
        for fmt in ("parquet", "csv", "jsonl"):
            start = time.perf_counter()
            data = export_jsonl(run / "episodes.jsonl", fmt)
            (Path(tmp) / f"episodes.{fmt}").write_bytes(data)
            out[f"{fmt}_s"] = round(time.perf_counter() - start, 3)
            out[f"{fmt}_bytes"] = len(data)
    out["parquet_ok"] = out["parquet_s"] <= TARGET_S
    print(json.dumps(out, indent=2) if args.json else out)


if __name__ == "__main__":
    main()
