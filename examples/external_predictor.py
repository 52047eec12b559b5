"""A predictor in its own process, speaking Foresight's JSON-lines predictor protocol (plain Python, no imports
from Foresight): constant velocity from each pedestrian's last two observed positions, one mode, a spread growing
with the forecast's age.

The operator makes it available under a name, e.g.
    FORESIGHT_EXTERNAL_PREDICTORS='{"reference": "python examples/external_predictor.py"}'
and any model field then takes ``external:reference``. The protocol is documented in docs/predictor_protocol.md.
"""

import json
import math
import sys

TIMEBASE = {"dt": 0.2, "history": 5, "horizon": 12}


def forecast(msg):
    dt, T = msg["dt"], TIMEBASE["horizon"]
    times = [dt * (k + 1) for k in range(T)]
    spread = [[math.sqrt(0.02**2 + (0.16 * t) ** 2) for t in times]]  # the same for everyone: built once
    modes = []
    for track in msg["pedestrians"]["history"]:
        x, y = track[-1]
        prev = track[-2] if len(track) > 1 else None
        vx, vy = ((x - prev[0]) / dt, (y - prev[1]) / dt) if prev else (0.0, 0.0)
        modes.append([[[x + vx * t, y + vy * t] for t in times]])
    n = len(modes)
    return {"type": "forecast", "modes": modes, "weights": [[1.0]] * n, "sigma": [spread] * n}


def main():
    for line in sys.stdin:
        msg = json.loads(line)
        if msg["type"] == "hello":
            reply = {"type": "hello", "protocol": 1, "name": "reference_cv", "timebase": TIMEBASE,
                     "frame": "world", "modes": 1}  # fmt: skip
        elif msg["type"] == "observe":
            reply = forecast(msg)
        else:
            continue
        sys.stdout.buffer.write(
            (json.dumps(reply, separators=(",", ":")) + "\n").encode()
        )  # one write per line
        sys.stdout.buffer.flush()


if __name__ == "__main__":
    main()
