"""Reading a matrix's files: YAML whose errors name the file, and pydantic errors as one readable line.

Its own module so that the loader's helpers (routes, single pedestrians, seed manifests) use them without
importing the loader back.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml
from pydantic import ValidationError

from foresight.core.errors import ConfigError
from foresight.core.yamlio import load_yaml


def read_yaml(path: str | Path, *, referenced_from: str | Path | None = None, item: str | None = None) -> Any:
    """Parse one YAML file; a missing file or a syntax error is a ConfigError naming the file."""
    p = Path(path)
    if not p.is_file():
        where = referenced_from if referenced_from is not None else p
        raise ConfigError(f"file {str(p)!r} does not exist", source=where, item=item)
    try:
        with p.open(encoding="utf-8") as fh:
            return load_yaml(fh.read(), source=p)
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        at = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(err, "problem", None) or str(err)
        raise ConfigError(f"malformed YAML{at}: {problem}", source=p, item=item) from err


def validation_message(err: ValidationError, prefix: str = "") -> str:
    """One line per pydantic error: dotted field path, then what is wrong (unknown keys say so)."""
    lines = []
    for e in err.errors():
        loc = ".".join(str(x) for x in (*(prefix.split(".") if prefix else ()), *e["loc"]))
        if e["type"] == "extra_forbidden":
            msg = "unsupported key"
        else:
            msg = str(e["msg"]).removeprefix("Value error, ")
            if isinstance(e.get("input"), int | float | str | bool | None) and e["type"] != "missing":
                msg += f" (got {e['input']!r})"
        lines.append(f"{loc}: {msg}" if loc else msg)
    return "; ".join(lines)
