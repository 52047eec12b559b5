"""Shared report plumbing: reading a stage result in any form, number formatting, figure naming.

Reports read results as plain JSON-like dicts (a pydantic result, its ``model_dump``, or the JSON file a
stage wrote) so that a report can be rebuilt from stored artifacts, and so that a field added to a
result model does not break the report. Missing optional fields show as "-", never as 0.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from pydantic import BaseModel

from foresight.core.render.charts import Estimate
from foresight.core.reports.document import Document

FIGURES = "figures"  #: figure folder, relative to the report


def as_dict(obj: Any) -> dict[str, Any]:
    """A result as a JSON-like dict: pydantic model (by alias, e.g. ``global``), mapping, or JSON file path."""
    if isinstance(obj, BaseModel):
        return obj.model_dump(mode="json", by_alias=True)
    if isinstance(obj, Mapping):
        return dict(obj)
    if isinstance(obj, str | Path):
        return json.loads(Path(obj).read_text())
    raise TypeError(f"cannot read a result from {type(obj).__name__}")


def num(x: Any) -> float | None:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def pct(x: Any) -> str:
    v = num(x)
    return "-" if v is None else f"{100 * v:.1f}%"


def fmt(x: Any, digits: int = 2, unit: str = "") -> str:
    v = num(x)
    return "-" if v is None else f"{v:.{digits}f}{unit}"


def rate_text(r: Mapping[str, Any] | None) -> str:
    """A serialised RateEstimate as ``62.5% [30.6, 86.3] (5/8)``."""
    if not r or num(r.get("rate")) is None:
        return "-"
    return f"{pct(r['rate'])} [{100 * num(r.get('low') or 0):.1f}, {100 * num(r.get('high') or 0):.1f}] " \
           f"({r.get('count', '?')}/{r.get('n', '?')})"


def mean_text(m: Mapping[str, Any] | None, digits: int = 2) -> str:
    """A serialised MeanEstimate as ``0.41 [0.30, 0.52] (n=8)``."""
    if not m or num(m.get("mean")) is None:
        return "-"
    return f"{fmt(m['mean'], digits)} [{fmt(m.get('low'), digits)}, {fmt(m.get('high'), digits)}] (n={m.get('n', '?')})"


def rate_est(r: Mapping[str, Any] | None) -> Estimate:
    return Estimate.of(r, "rate")


def mean_est(m: Mapping[str, Any] | None) -> Estimate:
    return Estimate.of(m, "mean")


def figure_path(workdir: Path, name: str) -> tuple[Path, str]:
    """(absolute path, path relative to the report) of a figure called ``name``."""
    rel = f"{FIGURES}/{name}"
    path = Path(workdir) / rel
    path.parent.mkdir(parents=True, exist_ok=True)
    return path, rel


def verdict(passed: Any) -> str:
    return "PASSED" if passed else "FAILED"


def gate_rows(checks: list[Mapping[str, Any]]) -> list[list[str]]:
    """Rows (check, verdict, value, threshold, detail) of a gate's checks."""
    return [[c.get("name", "?"), "ok" if c.get("passed") else "FAIL", fmt(c.get("value"), 3),
             fmt(c.get("threshold"), 3), c.get("detail") or ""] for c in checks]


def existing(workdir: Path, rel: str | None) -> bool:
    return bool(rel) and (Path(workdir) / str(rel)).is_file()


def publish(doc: Document, workdir: Path, stem: str = "report") -> list[Path]:
    """Write the document; returns the pictures it shows (those that exist) followed by the .md and .html."""
    pictures = [Path(workdir) / src for src in doc.images() if (Path(workdir) / src).is_file()]
    return pictures + doc.write(workdir, stem)
