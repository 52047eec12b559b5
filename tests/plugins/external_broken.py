"""An external planner process that breaks the protocol's error paths: it ignores the end of its input (a leftover
process), or stops answering once an episode ended with an error."""

import json
import sys
import time

MODE = sys.argv[1]  # "lingers" or "no_second_episode"


def main():
    errored = False
    while True:
        line = sys.stdin.readline()
        if not line:
            if MODE == "lingers":
                time.sleep(60)
            return
        msg = json.loads(line)
        if msg["type"] == "hello":
            reply = {"type": "hello", "protocol": 1, "name": "broken", "capabilities": []}
        elif msg["type"] == "start":
            if errored and MODE == "no_second_episode":
                continue
            reply = {"type": "ready"}
        elif msg["type"] == "observation":
            reply = {"type": "command", "v": 0.5, "omega": 0.0}
        else:
            errored = errored or msg.get("outcome") == "error"
            continue
        sys.stdout.write(json.dumps(reply) + "\n")
        sys.stdout.flush()


if __name__ == "__main__":
    main()
