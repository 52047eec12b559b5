"""One base exception for the core library; every error names the file and the item at fault."""

from __future__ import annotations

from pathlib import Path


class CoreError(Exception):
    """A core library error."""


class ConfigError(CoreError, ValueError):
    """Invalid input: a config, map, scenario or manifest that cannot be used as given.

    The message always names where (file, and item/field inside it) and what was expected,
    so that a CLI can print it as one readable line and an API can return it as a 422 body.
    """

    def __init__(self, message: str, *, source: str | Path | None = None, item: str | None = None):
        self.source = str(source) if source is not None else None
        self.item = item
        where = ", ".join(p for p in (self.source, f"item {item!r}" if item else None) if p)
        super().__init__(f"{where}: {message}" if where else message)
        self.detail = message


class NotFoundError(CoreError, LookupError):
    """A named thing (scenario, map id, model id, file) does not exist."""
