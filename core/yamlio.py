"""The one YAML reader for files a user may supply: ``yaml.safe_load`` with nesting and alias-expansion bounds.

Composition tracks nesting depth, so a document nested 20,000 deep is refused instead of overflowing the
recursion limit; before anything is constructed, the node graph's size after alias expansion is counted once
per distinct node, so an alias bomb is refused in microseconds instead of being expanded by a later walk.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from foresight.core.errors import ConfigError
from foresight.core.limits import MAX_NESTING, MAX_YAML_NODES


class _BoundedLoader(yaml.SafeLoader):
    def __init__(self, stream: str | bytes, source: str | None):
        super().__init__(stream)
        self.source, self.depth = source, 0

    def compose_node(self, parent: yaml.Node | None, index: Any) -> yaml.Node:
        if self.depth >= MAX_NESTING:
            line = self.peek_event().start_mark.line + 1
            raise ConfigError(
                f"nested deeper than {MAX_NESTING} levels", source=self.source, item=f"line {line}"
            )
        self.depth += 1
        try:
            return super().compose_node(parent, index)
        finally:
            self.depth -= 1


def _children(node: yaml.Node) -> list[yaml.Node]:
    if isinstance(node, yaml.MappingNode):
        return [n for pair in node.value for n in pair]
    if isinstance(node, yaml.SequenceNode):
        return list(node.value)
    return []


def expanded_size(root: yaml.Node, source: str | None = None) -> int:
    """Nodes of the document once every alias is expanded (each distinct node visited once); ConfigError when
    that exceeds :data:`MAX_YAML_NODES`, nests deeper than :data:`MAX_NESTING` through aliases, or is recursive."""
    size: dict[int, int] = {}
    depth: dict[int, int] = {}
    stack: list[tuple[yaml.Node, bool]] = [(root, False)]
    open_: set[int] = set()
    while stack:
        node, done = stack.pop()
        key = id(node)
        if done:
            kids = _children(node)
            size[key] = 1 + sum(size[id(k)] for k in kids)
            depth[key] = 1 + max((depth[id(k)] for k in kids), default=0)
            open_.discard(key)
            if size[key] > MAX_YAML_NODES:
                raise ConfigError(
                    f"aliases expand the document beyond {MAX_YAML_NODES} nodes",
                    source=source,
                    item=f"line {node.start_mark.line + 1}",
                )
            if depth[key] > MAX_NESTING:
                raise ConfigError(
                    f"aliases nest the document deeper than {MAX_NESTING} levels",
                    source=source,
                    item=f"line {node.start_mark.line + 1}",
                )
            continue
        if key in size:
            continue
        if key in open_:
            raise ConfigError(
                "a recursive alias (a node that contains itself)",
                source=source,
                item=f"line {node.start_mark.line + 1}",
            )
        open_.add(key)
        stack.append((node, True))
        stack.extend((k, False) for k in _children(node) if id(k) not in size)
    return size[id(root)]


def load_yaml(text: str | bytes, source: str | Path | None = None) -> Any:
    """One YAML document as Python values (like ``yaml.safe_load``), refusing bombs and deep nesting with a
    ConfigError naming ``source`` and the line; syntax errors stay ``yaml.YAMLError``."""
    where = str(source) if source is not None else None
    loader = _BoundedLoader(text, where)
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        expanded_size(node, where)
        return loader.construct_document(node)
    finally:
        loader.dispose()


def read_yaml(path: str | Path) -> Any:
    """:func:`load_yaml` of a file (UTF-8)."""
    return load_yaml(Path(path).read_text(encoding="utf-8"), source=path)
