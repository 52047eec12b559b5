"""Bounds on untrusted structured input (YAML, JSON, SVG), kept in one place.

A document is refused before anything walks it when it nests deeper than :data:`MAX_NESTING` (recursive
readers and writers would hit Python's recursion limit) or, for YAML, when aliases expand it beyond
:data:`MAX_YAML_NODES` (a few hundred bytes of anchors can stand for billions of nodes).
"""

from __future__ import annotations

import math
from typing import Any

from foresight.core.errors import ConfigError

MAX_NESTING = 64  #: levels of mappings/lists (JSON, YAML) or elements (SVG); our deepest config uses 7
MAX_YAML_NODES = 200_000  #: scalars + collections of a YAML document after alias expansion
MAX_YAML_BYTES = 4 << 20  #: [bytes (characters of text)] one YAML document; our largest config is ~110 kB


def nesting_depth(value: Any) -> int:
    """Levels of dicts/lists/tuples in a JSON-like value (a scalar is 0), without recursion."""
    deepest, stack = 0, [(value, 1)]
    while stack:
        item, depth = stack.pop()
        children = (
            item.values() if isinstance(item, dict) else item if isinstance(item, list | tuple) else None
        )
        if children is None:
            continue
        deepest = max(deepest, depth)
        if deepest > MAX_NESTING:  # enough to refuse; the rest need not be walked
            return deepest
        stack.extend((child, depth + 1) for child in children)
    return deepest


def check_nesting(value: Any, *, source: str | None = None, item: str | None = None) -> None:
    """ConfigError when ``value`` nests deeper than :data:`MAX_NESTING`."""
    if nesting_depth(value) > MAX_NESTING:
        raise ConfigError(f"nested deeper than {MAX_NESTING} levels", source=source, item=item)


MAX_INT = 2**63 - 1  #: the largest integer every database column and numpy's int64 hold
MAX_NAME_BYTES = 255  #: a file or folder name, in UTF-8 bytes (what every file system takes)


def bad_text(text: str) -> str | None:
    """Why ``text`` cannot be stored or served (a NUL byte, which PostgreSQL text refuses; a lone UTF-16 surrogate,
    which no UTF-8 encoder writes), else None."""
    if "\x00" in text:
        return "a NUL character"
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        return "a lone UTF-16 surrogate"
    return None


def hostile_values(value: Any) -> list[tuple[tuple[Any, ...], str]]:
    """(location, why) of every value in a JSON document that cannot be stored and served back: text with NUL or
    a lone surrogate (keys included), NaN/Infinity, integers beyond 64 bits. Without recursion."""
    found: list[tuple[tuple[Any, ...], str]] = []
    stack: list[tuple[Any, tuple[Any, ...]]] = [(value, ())]
    while stack and len(found) < 20:
        item, loc = stack.pop()
        if isinstance(item, dict):
            for key, child in item.items():
                why = bad_text(key) if isinstance(key, str) else None
                if why:
                    found.append(((*loc, _printable(key)), f"a key holds {why}"))
                stack.append((child, (*loc, _printable(key) if isinstance(key, str) else key)))
        elif isinstance(item, list | tuple):
            stack.extend((child, (*loc, i)) for i, child in enumerate(item))
        elif isinstance(item, str):
            why = bad_text(item)
            if why:
                found.append((loc, f"text holds {why}"))
        elif isinstance(item, float) and not math.isfinite(item):
            found.append((loc, "NaN and Infinity are not numbers this service stores"))
        elif isinstance(item, int) and not isinstance(item, bool) and not -MAX_INT - 1 <= item <= MAX_INT:
            found.append((loc, f"an integer beyond 64 bits (at most {MAX_INT} in size)"))
    return found


def _printable(text: str) -> str:
    """``text`` with lone surrogates and NUL written as escapes, so that an error message can quote it."""
    return text.encode("utf-8", "backslashreplace").decode("utf-8").replace("\x00", "\\x00")


def printable(value: Any) -> Any:
    """A JSON-like value with every string made :func:`_printable` (an echoed input in an error body)."""
    if isinstance(value, str):
        return _printable(value)
    if isinstance(value, dict):
        return {printable(k): printable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [printable(v) for v in value]
    return value
