"""Operator-configured external commands: a JSON object of name -> command line, read from an environment variable.

External planners and external predictors are both configured this way; one reader keeps their rules the same."""

from __future__ import annotations

import json
import os
import shlex

from foresight.core.errors import ConfigError


def operator_commands(env: str, value: str | None = None) -> dict[str, list[str]]:
    """Name -> argv from ``$env`` (or ``value``): ``{"name": "command line" | ["argv", ...]}``."""
    text = os.environ.get(env, "") if value is None else value
    if not text.strip():
        return {}
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ConfigError(f"not JSON: {exc}", source=env) from None
    if not isinstance(data, dict):
        raise ConfigError('expected a JSON object {"name": "command line"}', source=env)
    out = {}
    for name, cmd in data.items():
        argv = shlex.split(cmd) if isinstance(cmd, str) else cmd
        if not (isinstance(argv, list) and argv and all(isinstance(a, str) for a in argv)):
            raise ConfigError("expected a command line or a non-empty list of strings", source=env, item=name)
        out[str(name)] = argv
    return out
