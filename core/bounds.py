"""Size and range limits every stage config obeys, checked once where the config models are defined.

A job spec is a few kilobytes of settings; no setting needs more than :data:`MAX_ITEMS` entries, a text longer
than :data:`MAX_TEXT` characters, nesting deeper than :data:`MAX_DEPTH` or a number beyond :data:`MAX_MAGNITUDE`.
Without these a 700-byte request could ask for work or memory without end (100,000 candidate speeds, a
planner horizon of 1e300 s). Settings that set how much work a job does carry their own, tighter ``Field``
bounds; these limits catch everything else, including free-form values (grid parameters, scenario overrides,
external planners' configs) and nested models that come from plugins.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from annotated_types import MaxLen
from pydantic import BaseModel, ConfigDict, model_validator
from pydantic.fields import FieldInfo

MAX_ITEMS = 256  #: entries of one list, tuple or mapping in a config
MAX_TEXT = 4096  #: characters of one string in a config
MAX_DEPTH = 12  #: nesting of plain lists and mappings inside one setting
MAX_MAGNITUDE = 1e9  #: largest |value| of a float setting (metres, seconds, weights, ratios)
MAX_INT = 2**63 - 1  #: largest |value| of an integer setting (what every database column holds)


def own_max_length(field: FieldInfo) -> int | None:
    """The ``max_length`` a field declares itself (it replaces :data:`MAX_ITEMS` / :data:`MAX_TEXT` there)."""
    return next((m.max_length for m in field.metadata if isinstance(m, MaxLen)), None)


def model_errors(model: BaseModel, where: str, depth: int) -> list[str]:
    """:func:`bound_errors` of every field of ``model``, each with the length limit it declares, if any."""
    out: list[str] = []
    for name, field in type(model).model_fields.items():
        path = f"{where}.{name}" if where else name
        out += bound_errors(getattr(model, name, None), path, depth, own_max_length(field))
    return out


def bound_errors(value: Any, where: str, depth: int = 0, max_length: int | None = None) -> list[str]:
    """Why ``value`` (named ``where``) breaks a limit: one line per offending setting, empty when it fits;
    ``max_length`` replaces the default limit of its length (not of what it holds).

    Nested models that are :class:`BoundedConfig` checked themselves when they were built and are skipped."""
    if isinstance(value, BoundedConfig) and depth > 0:
        return []
    if isinstance(value, BaseModel):
        return model_errors(value, where, depth + 1)
    if isinstance(value, bool) or value is None:
        return []
    if isinstance(value, float):
        if not math.isfinite(value):
            return [f"{where}: {value} is not a finite number"]
        if abs(value) > MAX_MAGNITUDE:
            return [f"{where}: {value:g} is beyond the limit of +-{MAX_MAGNITUDE:g}"]
        return []
    if isinstance(value, int):
        return [f"{where}: {value} is beyond the limit of +-{MAX_INT}"] if abs(value) > MAX_INT else []
    if isinstance(value, str):
        most = max_length or MAX_TEXT
        return [f"{where}: {len(value)} characters, at most {most}"] if len(value) > most else []
    if isinstance(value, Mapping | list | tuple | set | frozenset):
        most = max_length or MAX_ITEMS
        if len(value) > most:
            return [f"{where}: {len(value)} entries, at most {most}"]
        if depth > MAX_DEPTH:
            return [f"{where}: nested more than {MAX_DEPTH} levels deep"]
        pairs = value.items() if isinstance(value, Mapping) else enumerate(value)
        out: list[str] = []
        for key, item in pairs:
            if isinstance(key, str) and len(key) > MAX_TEXT:
                return [f"{where}: a key of {len(key)} characters, at most {MAX_TEXT}"]
            out += bound_errors(item, f"{where}.{key}" if where else str(key), depth + 1)
            if out:
                return out
        return out
    return []


class BoundedConfig(BaseModel):
    """Base of stage configs: no NaN or infinity, and every value within the limits above (a 422 naming the
    setting at submission, a ConfigError in a YAML file), checked once the model is built."""

    model_config = ConfigDict(allow_inf_nan=False)

    @model_validator(mode="after")
    def _within_bounds(self) -> Any:
        errors = model_errors(self, "", 1)
        if errors:
            raise ValueError("; ".join(errors[:5]))
        return self
