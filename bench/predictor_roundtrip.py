"""External predictor round trip: ms per forecast through the JSON-lines predictor protocol (core.predict.external).

The reference client (examples/external_predictor.py: constant velocity in plain Python, one mode) answers an
observation window of N pedestrians with 0.2 s steps, 5 observed and 12 predicted. Timed per forecast: ``round_trip``
(window -> JSON line -> process -> JSON line back -> parsed) and ``checked`` (also turned into a Forecast and
checked against the contract, as the planner receives it). Windows are random walks, new every call. Target:
round-trip p50 <= 0.5 ms at 16 pedestrians. ``--json`` prints ONE JSON object.

``pipe_echo`` is what the OS leaves for the protocol's own work: the same write / select / read round trip with a
bare Python process that echoes each line (a line of the request's size, answered with one of the reply's size),
no JSON on either side.
"""

from __future__ import annotations

import argparse
import json
import os
import select
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from foresight.core.predict.external import ENV, ExternalPredictor  # noqa: E402
from foresight.core.predict.plugin import ObservationWindow, declaration, forecast_from  # noqa: E402


def windows(n: int, count: int, history: int = 5, dt: float = 0.2, seed: int = 0) -> list[ObservationWindow]:
    rng = np.random.default_rng(seed)
    out = []
    for i in range(count):
        start = rng.uniform(0, 20, (n, 1, 2))
        vel = rng.normal(0, 1.0, (n, 1, 2))
        hist = start + vel * dt * np.arange(history)[None, :, None]
        out.append(
            ObservationWindow(
                time=i * dt,
                dt=dt,
                ped_ids=np.arange(n, dtype=np.int64),
                history=hist,
                valid=np.ones((n, history), dtype=bool),
                robot_pose=np.zeros(3),
                robot_velocity=np.zeros(2),
                waypoint=np.array([10.0, 10.0]),
            )
        )
    return out


def measure(n: int, count: int) -> dict:
    predictor = ExternalPredictor("reference")
    decl = declaration(predictor, "external:reference")
    ws = windows(n, count + 20)
    for w in ws[:20]:  # warm-up: the process's first answers
        predictor.predict(w)
    raw, checked = [], []
    for w in ws[20:]:
        t0 = time.perf_counter()
        reply = predictor.predict(w)
        t1 = time.perf_counter()
        forecast_from(reply, w, decl, "external:reference", "bench")
        t2 = time.perf_counter()
        raw.append(t1 - t0)
        checked.append(t2 - t0)
    raw_ms, checked_ms = np.asarray(raw) * 1e3, np.asarray(checked) * 1e3
    request = ws[0].to_line()
    predictor.predict(ws[0])
    reply_bytes = predictor._process().reply_bytes
    echo_ms = pipe_echo(request, reply_bytes - 1, count) * 1e3
    return {
        "pedestrians": n,
        "round_trip_p50_ms": round(float(np.percentile(raw_ms, 50)), 3),
        "round_trip_p95_ms": round(float(np.percentile(raw_ms, 95)), 3),
        "checked_p50_ms": round(float(np.percentile(checked_ms, 50)), 3),
        "checked_p95_ms": round(float(np.percentile(checked_ms, 95)), 3),
        "pipe_echo_p50_ms": round(float(np.percentile(echo_ms, 50)), 3),
        "request_bytes": len(request),
        "reply_bytes": reply_bytes,
        "forecasts": count,
    }


ECHO = "import sys\nfor line in sys.stdin.buffer:\n    sys.stdout.buffer.write(b'x' * {n} + b'\\n')\n    sys.stdout.buffer.flush()\n"


def pipe_echo(request: bytes, reply_size: int, count: int) -> np.ndarray:
    """Seconds per round trip of ``request`` to a bare Python process answering ``reply_size`` bytes (no JSON)."""
    proc = subprocess.Popen(
        [sys.executable, "-c", ECHO.format(n=reply_size)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        bufsize=0,
    )
    fin, fout = proc.stdin.fileno(), proc.stdout.fileno()
    times = []
    try:
        for i in range(count + 20):
            t0 = time.perf_counter()
            os.write(fin, request)
            buf = b""
            while not buf.endswith(b"\n"):
                select.select([fout], [], [], 2.0)
                buf += os.read(fout, 1 << 20)
            if i >= 20:  # the first are warm-up
                times.append(time.perf_counter() - t0)
    finally:
        proc.stdin.close()
        proc.wait(timeout=5)
    return np.asarray(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--pedestrians", type=int, nargs="+", default=[4, 16, 50])
    ap.add_argument("--forecasts", type=int, default=1000)
    args = ap.parse_args()
    os.environ[ENV] = json.dumps(
        {"reference": [sys.executable, str(REPO / "examples" / "external_predictor.py")]}
    )
    entries = [measure(n, args.forecasts) for n in args.pedestrians]
    result = {"benchmark": "predictor_roundtrip", "targets": {"pedestrians": 16, "round_trip_p50_ms": 0.5}}
    result["entries"] = entries
    if args.json:
        print(json.dumps(result))
    else:
        for e in entries:
            print(
                f"{e['pedestrians']:>3} peds  round trip p50 {e['round_trip_p50_ms']:.3f} ms  "
                f"p95 {e['round_trip_p95_ms']:.3f} ms  (checked p50 {e['checked_p50_ms']:.3f} ms; bare pipe echo p50 "
                f"{e['pipe_echo_p50_ms']:.3f} ms; {e['request_bytes']} B out, {e['reply_bytes']} B back)"
            )


if __name__ == "__main__":
    main()
