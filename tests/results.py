"""Comparing results of two runs that should agree: drop the keys that legitimately differ (wall-clock timing,
the code version, ...) at any depth."""

from __future__ import annotations

from typing import Any


def without(data: Any, keys: set[str]) -> Any:
    """``data`` (nested dicts and lists) with every dict entry named in ``keys`` removed, at any depth."""
    if isinstance(data, dict):
        return {k: without(v, keys) for k, v in data.items() if k not in keys}
    if isinstance(data, list):
        return [without(v, keys) for v in data]
    return data
