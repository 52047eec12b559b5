"""The one YAML reader for files a user may supply: ``yaml.safe_load`` with size, nesting and alias-expansion bounds.

Three steps, each bounded before the next costs anything: a document over :data:`MAX_YAML_BYTES` is refused
unread (one 49 MB string took 65 s to scan); the parser's events (libyaml's where installed: ~1 µs each) are
counted with their nesting depth and stopped at :data:`MAX_YAML_NODES` or :data:`MAX_NESTING` (a flat
1-million-key file was composed whole, 84 s and 1.5 GB, before its size was checked); only then is the node
graph composed, its size after alias expansion counted once per distinct node (an alias bomb is refused in
microseconds instead of being expanded by a later walk), and the values constructed.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from foresight.core.errors import ConfigError
from foresight.core.limits import MAX_NESTING, MAX_YAML_BYTES, MAX_YAML_NODES

_FAST = getattr(yaml, "CSafeLoader", None)  #: libyaml's parser and composer, when PyYAML was built with it
_NODE_EVENTS = (yaml.ScalarEvent, yaml.SequenceStartEvent, yaml.MappingStartEvent, yaml.AliasEvent)


def _check_events(text: str | bytes, source: str | None) -> None:
    """ConfigError at the first event past :data:`MAX_YAML_NODES` nodes (aliases counted once here, expanded
    later) or :data:`MAX_NESTING` levels, naming the line; syntax errors stay ``yaml.YAMLError``."""
    try:
        _count_events(text, source)
    except yaml.MarkedYAMLError as exc:  # libyaml's own bound on flow nesting (1,000 levels) met first
        if "nesting depth" not in str(exc.problem) or exc.problem_mark is None:
            raise
        line = exc.problem_mark.line + 1
        raise ConfigError(
            f"nested deeper than {MAX_NESTING} levels", source=source, item=f"line {line}"
        ) from None


def _count_events(text: str | bytes, source: str | None) -> None:
    nodes = depth = 0
    for event in yaml.parse(text, Loader=_FAST or yaml.SafeLoader):
        if isinstance(event, _NODE_EVENTS):
            nodes += 1
            if nodes > MAX_YAML_NODES:
                line = event.start_mark.line + 1
                raise ConfigError(f"more than {MAX_YAML_NODES} nodes", source=source, item=f"line {line}")
        if isinstance(event, yaml.SequenceStartEvent | yaml.MappingStartEvent):
            depth += 1
            if depth > MAX_NESTING:
                line = event.start_mark.line + 1
                raise ConfigError(
                    f"nested deeper than {MAX_NESTING} levels", source=source, item=f"line {line}"
                )
        elif isinstance(event, yaml.SequenceEndEvent | yaml.MappingEndEvent):
            depth -= 1


class _BoundedLoader(yaml.SafeLoader):
    """The pure-Python loader, composing with a depth bound (used where libyaml is missing)."""

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
    """One YAML document as Python values (like ``yaml.safe_load``), refusing large documents, bombs and deep
    nesting with a ConfigError naming ``source`` and the line; syntax errors stay ``yaml.YAMLError``."""
    where = str(source) if source is not None else None
    if len(text) > MAX_YAML_BYTES:
        raise ConfigError(f"over {MAX_YAML_BYTES} bytes (a YAML file here is at most that)", source=where)
    _check_events(text, where)
    loader = _FAST(text) if _FAST is not None else _BoundedLoader(text, where)  # depth bounded by the events
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
