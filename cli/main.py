"""`foresight` command line: one argparse tree; each command group lives in its own module.

Stage commands build the same spec the service accepts; they run in-process (``--local``) or
submit to the server. Errors print one readable line on stderr and exit with a non-zero code.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys

from foresight.core.errors import CoreError

#: Command-group modules; each defines ``register(subparsers)`` adding its commands, and every
#: command sets ``func(args) -> int`` as its handler.
COMMAND_MODULES = [
    "foresight.cli.sim",
    "foresight.cli.server",
    "foresight.cli.jobs",
    "foresight.cli.models",
    "foresight.cli.maps",
    "foresight.cli.evaluate",
    "foresight.cli.planners",
    "foresight.cli.predict",
    "foresight.cli.pipeline",
    "foresight.cli.report",
    "foresight.cli.results",
]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="foresight", description="Predictive local planners in crowds.")
    sub = parser.add_subparsers(dest="command", required=True)
    for name in COMMAND_MODULES:
        importlib.import_module(name).register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        code = int(args.func(args) or 0)
        sys.stdout.flush()
        return code
    except BrokenPipeError:  # `foresight jobs ls | head`: the reader has what it wanted
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except (CoreError, OSError) as exc:
        print(f"foresight: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("foresight: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
