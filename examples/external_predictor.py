"""A predictor in its own process, speaking Foresight's JSON-lines predictor protocol (plain Python, no imports
from Foresight): constant velocity from each pedestrian's last two observed positions, one mode, a spread growing
with the forecast's age.

The operator makes it available under a name, e.g.
    FORESIGHT_EXTERNAL_PREDICTORS='{"reference": "python examples/external_predictor.py"}'
and any model field then takes ``external:reference``. The protocol is documented in docs/predictor_protocol.md.

The forecast goes back in the protocol's compact form: ``modes`` as one flat list (N K T 2 numbers, C order),
``sigma`` as one (T,) spread shared by every pedestrian, numbers to 0.1 mm, the line written as text directly.
Nested lists of full-precision floats were four times the bytes, and building and parsing them was most of the
round trip.
"""

import json
import math
import sys

TIMEBASE = {"dt": 0.2, "history": 5, "horizon": 12}


def forecast(msg):
    """The forecast message as one JSON line (bytes)."""
    dt, T = msg["dt"], TIMEBASE["horizon"]
    times = [dt * (k + 1) for k in range(T)]
    spread = ",".join(f"{math.sqrt(0.02**2 + (0.16 * t) ** 2):.4f}" for t in times)  # the same for everyone
    points = []
    for track in msg["pedestrians"]["history"]:
        x, y = track[-1]
        prev = track[-2] if len(track) > 1 else None
        vx, vy = ((x - prev[0]) / dt, (y - prev[1]) / dt) if prev else (0.0, 0.0)
        points.extend(f"{x + vx * t:.4f},{y + vy * t:.4f}" for t in times)
    modes = ",".join(points)
    n = len(msg["pedestrians"]["history"])
    weights = ",".join(["1"] * n)
    return f'{{"type":"forecast","modes":[{modes}],"weights":[{weights}],"sigma":[{spread}]}}\n'.encode()


def main():
    out = sys.stdout.buffer
    for line in sys.stdin.buffer:
        msg = json.loads(line)
        if msg["type"] == "hello":
            reply = {
                "type": "hello",
                "protocol": 1,
                "name": "reference_cv",
                "timebase": TIMEBASE,
                "frame": "world",
                "modes": 1,
            }
            out.write((json.dumps(reply, separators=(",", ":")) + "\n").encode())
        elif msg["type"] == "observe":
            out.write(forecast(msg))  # one write per line
        else:
            continue
        out.flush()


if __name__ == "__main__":
    main()
