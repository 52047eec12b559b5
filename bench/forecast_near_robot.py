"""Where the planner's forecast is right: its error by how near the robot a walker is, for one or more evaluations.

Reads the episode traces of finished evaluations (``foresight evaluate --local ... --out DIR``, given as
``LABEL=DIR``, e.g. the same matrix with the learned model and with ``--model cv``): every logged forecast (the
planner's, whatever model made it) against where each pedestrian then was. Groups: the scenario's condition (stress
suite: ``nonreactive_0.3`` / ``nonreactive_1``; else ``all``) x the walker's gap to the robot when the forecast was
made (surface distance: near < 2 m, mid < 5 m, far). Only pedestrians seen one forecast step before (with a velocity
to go on: a walker that just appeared is a matter of history, not of the robot) and over the whole horizon count. Each
run is scored on its own closed loop (the same seeds, so far from the robot the same crowd; near it, the situations
each planner got into). Constant velocity is not rebuilt from the trace: its positions are rounded to 1 cm, which
over a 0.2 s difference adds ~0.02 m to a 2.4 s forecast's error. Prints ONE JSON object (``--json``) or a table:
samples, ADE and FDE [m] per run.

Why: a learned forecast that expects people to make room for the robot is right where they do and wrong where they
do not see it, and that shows near the robot, where it matters, not in an average over the whole crowd.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from foresight.core.render.episode_trace import TRACES, read_compact  # noqa: E402

BANDS = (
    (2.0, "near"),
    (5.0, "mid"),
    (float("inf"), "far"),
)  #: gap to the robot [m] below which a band starts


def condition_of(scenario: str) -> str:
    """The stress suite's condition from its scenario name (``*_nr30``, ``*_nr100``), else ``all``."""
    return {"nr30": "nonreactive_0.3", "nr100": "nonreactive_1"}.get(scenario.rsplit("_", 1)[-1], "all")


def band_of(gap: float) -> str:
    return next(name for limit, name in BANDS if gap < limit)


def trace_errors(trace: dict) -> list[tuple[str, float, float]]:
    """(band, ADE, FDE) of every logged forecast of a pedestrian seen one forecast step before and over its horizon."""
    stride, dt = int(trace["stride"]), float(trace["dt"])
    frames = {i * stride: {int(p[0]): (p[1], p[2]) for p in row} for i, row in enumerate(trace["peds"])}
    contact = float(trace["robot_radius"]) + float(trace["ped_radius"])
    out = []
    for fc in trace["forecasts"]:
        t0, times = int(fc["step"]), np.asarray(fc["times"], dtype=float)
        before = t0 - int(round(times[0] / dt))
        steps = [t0 + int(round(t / dt)) for t in times]
        if any(s not in frames for s in (before, t0, *steps)):
            continue
        robot = np.asarray(trace["robot"][t0 // stride][:2], dtype=float)
        for pid, path in zip(fc["ids"], fc["positions"], strict=True):
            if any(pid not in frames[s] for s in (before, t0, *steps)):
                continue
            truth = np.asarray([frames[s][pid] for s in steps])
            err = np.hypot(*(np.asarray(path) - truth).T)
            gap = float(np.hypot(*(np.asarray(frames[t0][pid]) - robot))) - contact
            out.append((band_of(gap), float(err.mean()), float(err[-1])))
    return out


def summary(folder: Path) -> dict:
    groups: dict[tuple[str, str], list] = defaultdict(list)
    paths = sorted((folder / TRACES).glob("*.json.gz"))
    if not paths:
        raise SystemExit(
            f"{folder}: no episode traces under {TRACES}/ (a finished `foresight evaluate --out` folder?)"
        )
    for path in paths:
        trace = read_compact(path)
        for band, *errors in trace_errors(trace):
            groups[(condition_of(trace["scenario"]), band)].append(errors)
    rows = []
    for (condition, band), errs in sorted(groups.items()):
        e = np.asarray(errs)
        rows.append(
            {
                "condition": condition,
                "band": band,
                "samples": len(e),
                "ade": round(float(e[:, 0].mean()), 4),
                "fde": round(float(e[:, 1].mean()), 4),
            }
        )
    return {"folder": str(folder), "episodes": len(paths), "rows": rows}


def labelled(arg: str) -> tuple[str, Path]:
    label, sep, folder = arg.partition("=")
    if not sep or not label or not folder:
        raise argparse.ArgumentTypeError(f"{arg!r}: expected LABEL=DIR (e.g. learned=runs/stress)")
    return label, Path(folder)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "runs",
        nargs="+",
        type=labelled,
        metavar="LABEL=DIR",
        help="work folder of a finished `foresight evaluate --local --out` run, with a label",
    )
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    result = {
        # upper limits; the last band has none (null: JSON has no Infinity)
        "bands_m": {name: limit if limit != float("inf") else None for limit, name in BANDS},
        "runs": {label: summary(f) for label, f in args.runs},
    }
    if args.json:
        print(json.dumps(result, indent=2))
        return 0
    labels = list(result["runs"])
    cells = {
        label: {(r["condition"], r["band"]): r for r in run["rows"]} for label, run in result["runs"].items()
    }
    print("| condition | gap to robot | " + " | ".join(f"{x}: samples, ADE / FDE [m]" for x in labels) + " |")
    print("|---|---|" + "---|" * len(labels))
    for key in sorted({k for c in cells.values() for k in c}):
        vals = [
            f"{c[key]['samples']}, {c[key]['ade']:.3f} / {c[key]['fde']:.3f}" if key in c else "–"
            for c in (cells[x] for x in labels)
        ]
        print(f"| {key[0]} | {key[1]} | " + " | ".join(vals) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
