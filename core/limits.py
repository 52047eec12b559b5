"""Bounds on untrusted structured input (YAML, JSON, SVG), kept in one place.

A document is refused before anything walks it when it nests deeper than :data:`MAX_NESTING` (recursive
readers and writers would hit Python's recursion limit) or, for YAML, when aliases expand it beyond
:data:`MAX_YAML_NODES` (a few hundred bytes of anchors can stand for billions of nodes).
"""

from __future__ import annotations

from typing import Any

from foresight.core.errors import ConfigError

MAX_NESTING = 64  #: levels of mappings/lists (JSON, YAML) or elements (SVG); our deepest config uses 7
MAX_YAML_NODES = 200_000  #: scalars + collections of a YAML document after alias expansion


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
