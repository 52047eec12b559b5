"""Jinja2 environment of the dashboard: templates, filters, and ``page()`` to render one."""

from __future__ import annotations

import json
import math
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from fastapi import Request
from fastapi.templating import Jinja2Templates
from starlette.responses import HTMLResponse

HERE = Path(__file__).resolve().parent
FINAL = ("succeeded", "failed", "cancelled")
templates = Jinja2Templates(directory=str(HERE / "templates"))


def _ts(value: Any) -> str:
    """Epoch seconds or a datetime as ``YYYY-MM-DD HH:MM:SS`` UTC; '' for None."""
    if value is None:
        return ""
    if isinstance(value, int | float):
        value = datetime.fromtimestamp(value, UTC)
    return value.strftime("%Y-%m-%d %H:%M:%S")


def _duration(start: Any, end: Any) -> str:
    if start is None:
        return ""
    end = end if end is not None else datetime.now(UTC).timestamp()
    seconds = max(0.0, float(end) - float(start))
    return f"{seconds:.1f} s" if seconds < 120 else f"{seconds / 60:.1f} min"


def _num(value: Any, digits: int = 3) -> str:
    """A metric for a table cell: numbers rounded, ``{value, ci_low, ci_high}`` with its interval."""
    if isinstance(value, dict) and "value" in value:
        low, high = value.get("ci_low"), value.get("ci_high")
        interval = (
            f" [{_num(low, digits)}, {_num(high, digits)}]" if low is not None and high is not None else ""
        )
        return _num(value["value"], digits) + interval
    if value is None:  # no value (e.g. path efficiency of a run that never reached its goal)
        return "–"
    if isinstance(value, bool):
        return str(value)
    if isinstance(value, float):
        return f"{value:.{digits}g}" if math.isfinite(value) else str(value)
    return str(value)


def _pretty(value: Any) -> str:
    return json.dumps(value, indent=2, sort_keys=True, default=str)


def _size(n: int) -> str:
    for unit in ("B", "KiB", "MiB", "GiB"):
        if n < 1024 or unit == "GiB":
            return f"{n} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1024
    return str(n)


def _spec_summary(spec: Any) -> str:
    """A few words on what a job runs (planner, model, inputs), for the jobs table."""
    if not isinstance(spec, dict):
        return ""
    parts = []
    planner = spec.get("planner")
    if isinstance(planner, dict) and planner.get("name"):
        parts.append(str(planner["name"]) + (f" ({planner['model']})" if planner.get("model") else ""))
    for key in ("model", "matrix", "seed_manifest", "dataset", "config", "pipeline"):
        if isinstance(spec.get(key), str):
            parts.append(spec[key].rsplit("/", 1)[-1])
    for key in ("scenarios", "checkpoints", "datasets"):
        if isinstance(spec.get(key), list):
            parts.append(f"{len(spec[key])} {key}")
    if isinstance(spec.get("seconds"), int | float):
        parts.append(f"{spec['seconds']} s")
    return " · ".join(parts[:4])


def _shown(value: Any) -> str:
    """A config value as a reader writes it: nothing set is "(none)", not Python's None; lists and dicts as JSON."""
    import json

    if value is None:
        return "(none)"
    if isinstance(value, str):
        return value
    return json.dumps(value)


ts = _ts  #: the timestamp format of every page, for code that builds labels

templates.env.filters.update(
    ts=_ts, num=_num, pretty=_pretty, size=_size, spec_summary=_spec_summary, shown=_shown
)
templates.env.globals.update(duration=_duration, FINAL=FINAL)


def page(request: Request, name: str, status_code: int = 200, **context: Any) -> HTMLResponse:
    """Render template ``name`` with ``context`` (the token-gate flag is always available)."""
    context.setdefault("read_requires_token", request.app.state.settings.read_requires_token)
    return templates.TemplateResponse(request, name, context, status_code=status_code)
