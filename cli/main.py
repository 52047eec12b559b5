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


#: the help of options many commands share, where a command gives none of its own
COMMON_HELP = {
    "json": "print JSON (for scripts) instead of text",
    "job_id": "job id (or a unique prefix of 8+ characters, as the CLI prints)",
    "model_id": "model id (`foresight models ls`)",
    "limit": "at most this many (default %(default)s)",
    "offset": "skip this many first (paging)",
}

EPILOG = """examples:
  foresight up                                   # server + worker, dashboard at http://127.0.0.1:8000/ui
  foresight scenarios ls --matrix configs/scenarios/classic_interactions.yaml
  foresight sim run --local --matrix configs/scenarios/classic_interactions.yaml --scenario crossing_low \\
      --seed 1 --render ep.gif
  foresight evaluate --matrix configs/scenarios/classic_interactions.yaml --planner social_force \\
      --scenarios crossing_low --seeds-per-scenario 5
  foresight jobs ls
  foresight evaluations episodes JOB_ID --out episodes.parquet
"""


def _fill_help(parser: argparse.ArgumentParser) -> None:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                _fill_help(sub)
        elif action.help is None and action.dest in COMMON_HELP:
            action.help = COMMON_HELP[action.dest]


class _Version(argparse.Action):
    """``--version``: the package version and the commit it runs from (asked of git only when printed)."""

    def __call__(self, parser: argparse.ArgumentParser, *_: object) -> None:
        from foresight.core.version import code_version

        print(f"foresight {code_version()}")
        parser.exit()


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="foresight",
        description="Predictive local planners in crowds.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action=_Version, nargs=0, help="print the version and exit")
    sub = parser.add_subparsers(dest="command", required=True)
    for name in COMMAND_MODULES:
        importlib.import_module(name).register(sub)
    _fill_help(parser)
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
