"""Shared report plumbing: reading a stage result as its model, number formatting, figure naming.

A report reads its stage's result model (defined once in core), validated on read from whatever holds it:
the model itself, its JSON dict (a job row's result) or the JSON file the stage wrote. A renamed or missing
field is a validation error naming the field, never a "?" in a report. Optional values show as "-", never as 0.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

from pydantic import BaseModel

from foresight.core.render.charts import Estimate
from foresight.core.reports.document import Document

if TYPE_CHECKING:
    from foresight.core.evaluation.gates import GateCheck
    from foresight.core.evaluation.stats import MeanEstimate, RateEstimate

FIGURES = "figures"  #: figure folder, relative to the report

M = TypeVar("M", bound=BaseModel)


def read(model: type[M], obj: Any) -> M:
    """``obj`` as a ``model``: the model itself, a JSON-like mapping, another model's dump, or a JSON file path."""
    if isinstance(obj, model):
        return obj
    if isinstance(obj, BaseModel):
        return model.model_validate(obj.model_dump(mode="json", by_alias=True))
    if isinstance(obj, Mapping):
        return model.model_validate(obj)
    if isinstance(obj, str | Path):
        return model.model_validate_json(Path(obj).read_text())
    raise TypeError(f"cannot read a {model.__name__} from {type(obj).__name__}")


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


def rate_text(r: RateEstimate | None) -> str:
    """A RateEstimate as ``62.5% [30.6, 86.3] (5/8)``."""
    if r is None or r.rate is None:
        return "-"
    return f"{pct(r.rate)} [{100 * (r.low or 0):.1f}, {100 * (r.high or 0):.1f}] ({r.count}/{r.n})"


def mean_text(m: MeanEstimate | None, digits: int = 2) -> str:
    """A MeanEstimate as ``0.41 [0.30, 0.52] (n=8)``."""
    if m is None or num(m.mean) is None:
        return "-"
    return f"{fmt(m.mean, digits)} [{fmt(m.low, digits)}, {fmt(m.high, digits)}] (n={m.n})"


def rate_est(r: RateEstimate | None) -> Estimate:
    return Estimate(None) if r is None else Estimate(num(r.rate), num(r.low), num(r.high))


def mean_est(m: MeanEstimate | None) -> Estimate:
    return Estimate(None) if m is None else Estimate(num(m.mean), num(m.low), num(m.high))


def figure_path(workdir: Path, name: str) -> tuple[Path, str]:
    """(absolute path, path relative to the report) of a figure called ``name``."""
    rel = f"{FIGURES}/{name}"
    path = Path(workdir) / rel
    path.parent.mkdir(parents=True, exist_ok=True)
    return path, rel


def verdict(passed: Any) -> str:
    return "PASSED" if passed else "FAILED"


def gate_rows(checks: list[GateCheck]) -> list[list[str]]:
    """Rows (check, verdict, value, threshold, detail) of a gate's checks."""
    return [
        [c.name, "ok" if c.passed else "FAIL", fmt(c.value, 3), fmt(c.threshold, 3), c.detail] for c in checks
    ]


def existing(workdir: Path, rel: str | None) -> bool:
    return bool(rel) and (Path(workdir) / str(rel)).is_file()


def publish(doc: Document, workdir: Path, stem: str = "report") -> list[Path]:
    """Write the document; returns the pictures it shows (those that exist) followed by the .md and .html."""
    pictures = [Path(workdir) / src for src in doc.images() if (Path(workdir) / src).is_file()]
    return pictures + doc.write(workdir, stem)
