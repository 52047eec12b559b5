"""The dashboard's job form: its fields are built from the job kind's spec model, the schema the API validates a
submission against, so the form offers exactly what ``POST /v1/jobs`` takes (and the API's 422 names a bad field).

Scalar fields become inputs (numbers, text, a select for an enum), a list of names a comma-separated input, every
nested mapping (planner, gate, overrides...) a JSON box prefilled with its default. The page's script parses each
field by its ``data-parse`` and posts the spec; fields left empty are left out (the spec's defaults apply).
"""

from __future__ import annotations

import json
from typing import Annotated, Any

from fastapi import APIRouter, Depends, Query, Request
from fastapi.responses import HTMLResponse

from foresight.api.web.auth import PageNotFound, read_access
from foresight.api.web.render import page
from foresight.core.jobs.kinds import KINDS

router = APIRouter(prefix="/ui", include_in_schema=False, dependencies=[Depends(read_access)])
FORM_KINDS = ("evaluate",)  #: the kinds the dashboard offers a form for
#: a starting value for fields whose default means "fill me in" (the planner has none a newcomer can run as is)
STARTERS = {"planner": {"name": "social_force"}}
FIRST = ("matrix", "planner", "scenarios", "seeds_per_scenario", "max_steps")  #: shown first; the rest folded


def _variants(prop: dict[str, Any]) -> list[dict[str, Any]]:
    return [v for v in prop.get("anyOf", [prop]) if v.get("type") != "null"]


def field_of(name: str, prop: dict[str, Any]) -> dict[str, Any]:
    """How the form shows one property: input kind, how the script parses it, its default as text."""
    variants = _variants(prop)
    one = variants[0] if len(variants) == 1 else {}
    default = STARTERS.get(name, prop.get("default"))
    base = {
        "name": name,
        "title": prop.get("title", name),
        "description": prop.get("description", ""),
        "optional": len(variants) < len(prop.get("anyOf", [prop])) or "default" in prop,
    }
    if "enum" in one:
        return base | {"input": "select", "parse": "str", "options": one["enum"], "value": default}
    if one.get("type") in ("integer", "number"):
        parse = "int" if one["type"] == "integer" else "float"
        return base | {
            "input": "number",
            "parse": parse,
            "value": "" if default is None else default,
            "step": "1" if parse == "int" else "any",
            "min": one.get("minimum"),
            "max": one.get("maximum"),
        }
    if one.get("type") == "string":
        return base | {"input": "text", "parse": "str", "value": default or ""}
    if one.get("type") == "boolean":
        return base | {
            "input": "select",
            "parse": "bool",
            "options": ["true", "false"],
            "value": "true" if default else "false",
        }
    if one.get("type") == "array" and one.get("items", {}).get("type") == "string":
        return base | {
            "input": "text",
            "parse": "list",
            "value": ", ".join(default or []),
            "placeholder": "comma-separated (empty: all)",
        }
    text = "" if default is None else json.dumps(default, indent=1)
    return base | {"input": "json", "parse": "json", "value": text}


def form_fields(kind: str) -> list[dict[str, Any]]:
    schema = KINDS[kind].spec.model_json_schema()
    props = {k: v for k, v in schema["properties"].items() if k != "kind"}
    order = [k for k in FIRST if k in props] + [k for k in props if k not in FIRST]
    return [field_of(name, props[name]) | {"advanced": name not in FIRST} for name in order]


@router.get("/jobs/new")
def new_job_page(request: Request, kind: Annotated[str, Query(max_length=50)] = "evaluate") -> HTMLResponse:
    """A form that submits a ``kind`` job (fields from the kind's spec schema)."""
    if kind not in FORM_KINDS:
        raise PageNotFound(f"no form for job kind {kind!r} (forms: {', '.join(FORM_KINDS)})")
    return page(
        request, "new_job.html", title=f"New {kind} job", nav="jobs", kind=kind, fields=form_fields(kind)
    )
