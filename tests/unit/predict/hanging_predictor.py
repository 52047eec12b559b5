"""An external predictor that says hello, then never answers an observation (killed at the deadline)."""

import json
import sys
import time

for line in sys.stdin:
    msg = json.loads(line)
    if msg["type"] == "hello":
        hello = {
            "type": "hello",
            "protocol": 1,
            "name": "hangs",
            "frame": "world",
            "modes": 1,
            "timebase": {"dt": 0.2, "history": 5, "horizon": 12},
        }
        sys.stdout.write(json.dumps(hello) + "\n")
        sys.stdout.flush()
    else:
        time.sleep(3600)
