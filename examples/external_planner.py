"""A planner in its own process, speaking Foresight's JSON-lines planner protocol (plain Python, no imports
from Foresight): head for the current waypoint, slow down when a pedestrian is close ahead.

The operator makes it available to the server under a name, e.g.
    FORESIGHT_EXTERNAL_PLANNERS='{"reference": "python examples/external_planner.py"}'
and a spec runs it with ``planner: {name: external, config: {command: reference, params: {speed: 1.2}}}``.
The protocol is documented in docs/planner_protocol.md.
"""

import json
import math
import sys


def command(obs, params):
    x, y, heading = obs["robot"]["pose"]
    wx, wy = obs["waypoint"]
    error = (math.atan2(wy - y, wx - x) - heading + math.pi) % (2 * math.pi) - math.pi
    speed = params.get("speed", 1.0) * max(0.0, 1.0 - abs(error) / (math.pi / 2))
    for px, py in obs["pedestrians"]["positions"]:
        dx, dy = px - x, py - y
        ahead = dx * math.cos(heading) + dy * math.sin(heading)
        if ahead > 0 and math.hypot(dx, dy) < params.get("caution_distance", 2.5):
            speed = min(speed, params.get("cautious_speed", 0.3))
    return {"type": "command", "v": speed, "omega": max(-1.0, min(1.0, 1.5 * error))}


def main():
    params = {}
    for line in sys.stdin:
        msg = json.loads(line)
        if msg["type"] == "hello":
            reply = {"type": "hello", "protocol": 1, "name": "reference", "capabilities": []}
        elif msg["type"] == "start":
            params, reply = msg["params"], {"type": "ready"}
        elif msg["type"] == "observation":
            reply = command(msg, params)
        else:  # "end": nothing to answer
            continue
        sys.stdout.write(json.dumps(reply) + "\n")
        sys.stdout.flush()


if __name__ == "__main__":
    main()
