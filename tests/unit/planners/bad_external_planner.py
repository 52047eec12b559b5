"""External planners that misbehave on purpose (argv[1]): crash, hang or malformed, after two good steps."""

import json
import sys
import time


def main(mode: str) -> None:
    for line in sys.stdin:
        msg = json.loads(line)
        if msg["type"] == "hello":
            reply = {"type": "hello", "protocol": 1, "name": mode, "capabilities": []}
        elif msg["type"] == "start":
            reply = {"type": "ready"}
        elif msg["type"] == "observation":
            if msg["step"] == 2:
                if mode == "crash":
                    print("planner crashed on purpose", file=sys.stderr)
                    sys.exit(3)
                if mode == "hang":
                    time.sleep(3600)
                if mode == "malformed":
                    sys.stdout.write("{not json\n")
                    sys.stdout.flush()
                    continue
            reply = {"type": "command", "v": 0.5, "omega": 0.0}
        else:
            continue
        sys.stdout.write(json.dumps(reply) + "\n")
        sys.stdout.flush()


if __name__ == "__main__":
    main(sys.argv[1])
