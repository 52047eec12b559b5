"""Helpers shared by the CLI's stage commands: output and common options (in-process runs: ``foresight.local``)."""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from typing import Any

from pydantic import BaseModel


def emit(obj: Any, as_json: bool, text: Callable[[Any], str]) -> None:
    """Print a result as JSON (for scripts) or as human text."""
    if as_json:
        data = obj.model_dump(mode="json") if isinstance(obj, BaseModel) else obj
        print(json.dumps(data, indent=2))
    else:
        print(text(obj))


def matrix_options(p: argparse.ArgumentParser, conditions: str = "") -> None:
    """--matrix and --override of the commands that look at a matrix's episodes under chosen conditions."""
    p.add_argument("--matrix", required=True, help="scenario matrix YAML")
    p.add_argument(
        "--override",
        action="append",
        metavar="KEY=VALUE",
        help=f"under other conditions, as foresight evaluate --override (repeatable{conditions})",
    )


def episode_options(p: argparse.ArgumentParser, episodes: str, conditions: str = "") -> None:
    """:func:`matrix_options` and which of its episodes: --scenarios, --seeds-per-scenario and an evaluation's
    --episodes (``episodes``: what the command does with them)."""
    matrix_options(p, conditions)
    p.add_argument("--scenarios", help="comma-separated scenario names (default: all)")
    p.add_argument(
        "--seeds-per-scenario",
        type=int,
        help="N seeds per scenario, as foresight evaluate's (default: the matrix's own)",
    )
    p.add_argument(
        "--episodes", help=f"an evaluation's episodes.jsonl (evaluate --local --out DIR): {episodes}"
    )
