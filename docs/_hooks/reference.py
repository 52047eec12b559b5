"""MkDocs hook: the reference pages, generated from the code at every build so that they cannot drift.

- ``reference/cli.md``: every ``foresight`` command, walked from the CLI's argparse tree;
- ``reference/http-api.md``: every HTTP endpoint, from the app's OpenAPI schema (an app built on a throwaway,
  migrated SQLite file: nothing is read from or written to the user's data folder);
- ``reference/config-formats.md``: the config files' keys, from the pydantic models that validate them.

``mkdocs build`` (``make docs``) runs it, and so does tests/unit/test_docs_site.py; ``python docs/_hooks/reference.py
OUT`` writes the three pages into OUT to read them without a build.
"""

from __future__ import annotations

import argparse
import functools
import importlib
import inspect
import json
import os
import re
import sys
import tempfile
import types
import typing
from pathlib import Path
from typing import Any

from pydantic import BaseModel
from pydantic_core import PydanticUndefined

PAGES = ("reference/cli.md", "reference/http-api.md", "reference/config-formats.md")

#: (title, "module:Class", what the file is) of every config file format; the first module that imports wins,
#: so a model that moves between packages is still found where it went
CONFIG_FORMATS: tuple[tuple[str, tuple[str, ...], str], ...] = (
    (
        "Scenario matrix",
        ("foresight.core.scenarios.loader:_FileSpec",),
        "A YAML file of scenarios (`configs/scenarios/*.yaml`); `foresight scenarios list --matrix FILE` reads one.",
    ),
    ("Scenario", ("foresight.core.scenarios.model:Scenario",), "One entry of a matrix's `scenarios` list."),
    (
        "Map",
        ("foresight.core.maps.model:MapDef",),
        "Our YAML map format (`configs/maps/*.yaml`; docs: [maps](../maps.md)).",
    ),
    (
        "Seed manifest",
        ("foresight.core.scenarios.seeds:SeedManifest",),
        "Scenario name -> seeds (`configs/seeds/*.yaml`); a plain mapping is read as `seeds`.",
    ),
    (
        "Predictive planner config",
        ("foresight.core.planners.predictive.config:PredictivePlannerConfig",),
        "`--planner-config` of the `predictive` planner, and the `config` of its grid variants.",
    ),
    (
        "Planner grid variant",
        ("foresight.core.evaluation.config:GridVariant",),
        "One entry of a planner grid's `variants` (`configs/planners/*_grid_*.yaml`).",
    ),
    ("Evaluation", ("foresight.core.evaluation.config:EvaluationConfig",), "An `evaluate` job's spec."),
    ("Campaign", ("foresight.core.evaluation.config:CampaignConfig",), "A `campaign` job's spec."),
    ("Collection", ("foresight.core.training.collect:CollectConfig",), "A `collect` job's spec."),
    (
        "Training",
        ("foresight.core.training.config:TrainConfig",),
        "A training config (`configs/training/*.yaml`, `foresight train --config FILE`).",
    ),
    (
        "Pipeline",
        ("foresight.core.jobs.pipeline.config:PipelineConfig",),
        "The runbook as one file (`configs/pipelines/*.yaml`, `foresight pipeline run -f FILE`).",
    ),
)


# ---------------------------------------------------------------- the CLI


def _cell(text: str | None) -> str:
    return " ".join((text or "").split()).replace("|", "\\|")


def _subcommands(parser: argparse.ArgumentParser) -> list[tuple[str, str, argparse.ArgumentParser]]:
    out = []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helps = {a.dest: a.help for a in action._choices_actions}
            out += [(name, helps.get(name) or "", sub) for name, sub in action.choices.items()]
    return out


def _cli(parser: argparse.ArgumentParser, path: list[str], summary: str, out: list[str]) -> None:
    subs = _subcommands(parser)
    out += [f"{'#' * min(len(path) + 1, 4)} `{' '.join(path)}`", ""]
    if summary or parser.description:
        out += [_cell(parser.description or summary), ""]
    usage = parser.format_usage().strip().removeprefix("usage: ")
    out += ["```text", re.sub(r"\s+", " ", usage), "```", ""]
    rows = [
        a for a in parser._actions if not isinstance(a, (argparse._SubParsersAction, argparse._HelpAction))
    ]
    if rows:
        out += ["| argument | meaning | default |", "|---|---|---|"]
        for a in rows:
            name = ", ".join(f"`{o}`" for o in a.option_strings) or f"`{a.dest}`"
            default = (
                ""
                if a.default in (None, False, argparse.SUPPRESS) or not a.option_strings
                else f"`{a.default}`"
            )
            choices = f" (one of {', '.join(map(str, a.choices))})" if a.choices else ""
            out.append(
                f"| {name} | {_cell(a.help if a.help != argparse.SUPPRESS else '')}{choices} | {default} |"
            )
        out.append("")
    for name, help_, sub in subs:
        _cli(sub, [*path, name], help_, out)


def cli_page() -> str:
    from foresight.cli.main import build_parser

    parser = build_parser()
    out = [
        "# The command line",
        "",
        "Every `foresight` command with its arguments, generated from the CLI's parser at each build of this site. "
        "Stage commands submit a job to the server and follow it; `--local` runs them in-process. Their `--json` "
        "prints the finished job in both modes, as `GET /v1/jobs/ID` returns it (`id`, `kind`, `status`, "
        "`verdict`, `spec`, `result`, `artifacts`, ...); an in-process run's `id` is null and its artifacts are "
        "`file://` URLs.",
        "",
    ]
    commands = [f"[`{n}`](#foresight-{n.replace(' ', '-')}): {_cell(h)}" for n, h, _ in _subcommands(parser)]
    out += [f"- {c}" for c in commands] + [""]
    _cli(parser, ["foresight"], "", out)
    return "\n".join(out)


# ---------------------------------------------------------------- the HTTP API


@functools.cache
def openapi_schema() -> dict[str, Any]:
    """The app's OpenAPI document, from an app built on a throwaway migrated SQLite database."""
    with tempfile.TemporaryDirectory() as tmp:
        saved = {
            k: os.environ.get(k) for k in ("FORESIGHT_DATA_DIR", "FORESIGHT_DATABASE_URL", "FORESIGHT_STORE")
        }
        os.environ["FORESIGHT_DATA_DIR"] = tmp
        for key in ("FORESIGHT_DATABASE_URL", "FORESIGHT_STORE"):
            os.environ.pop(key, None)
        try:
            from foresight.api.main import create_app
            from foresight.store.session import upgrade
            from foresight.store.settings import Settings

            settings = Settings()
            upgrade(settings.resolved_database_url)
            app = create_app(settings)
            schema = app.openapi()
            app.state.engine.dispose()
            return schema
        finally:
            for key, value in saved.items():
                if value is None:
                    os.environ.pop(key, None)
                else:
                    os.environ[key] = value


def _schema_name(schema: dict[str, Any]) -> str:
    if "$ref" in schema:
        name = schema["$ref"].rsplit("/", 1)[-1]
        return f"[`{name}`](#{name.lower()})"
    if "anyOf" in schema or "oneOf" in schema:
        return " or ".join(_schema_name(s) for s in schema.get("anyOf", schema.get("oneOf", [])))
    if schema.get("type") == "array":
        return f"array of {_schema_name(schema.get('items', {}))}"
    return f"`{schema.get('type', 'any')}`"


def http_api_page() -> str:
    doc = openapi_schema()
    out = [
        "# The HTTP API",
        "",
        f"Every endpoint of the API server (version `{doc['info']['version'].split('+')[0]}`), generated from its "
        "OpenAPI schema at each build of this site; a running server serves the same schema at `/openapi.json` "
        "and an interactive page at `/docs`. Write endpoints need the bearer token "
        "(`Authorization: Bearer TOKEN`); reads are open unless `FORESIGHT_READ_REQUIRES_TOKEN` is set. Errors "
        "are JSON bodies naming the field or id and what was expected.",
        "",
        "| method | path | what it does |",
        "|---|---|---|",
    ]
    ops = [(path, method, op) for path, item in doc["paths"].items() for method, op in item.items()]
    for path, method, op in ops:
        anchor = op["operationId"].lower().replace("_", "-")
        first = re.split(r"(?<=[.)])\s", " ".join((op.get("description") or "").split()), maxsplit=1)[0]
        out.append(f"| {method.upper()} | [`{path}`](#{anchor}) | {_cell(first or op.get('summary'))} |")
    out.append("")
    for path, method, op in ops:
        out += [f"## {method.upper()} `{path}` {{#{op['operationId'].lower().replace('_', '-')}}}", ""]
        if op.get("description"):
            out += [_cell(op["description"]), ""]
        params = op.get("parameters", [])
        if params:
            out += ["| parameter | in | type | required | meaning |", "|---|---|---|---|---|"]
            out += [
                f"| `{p['name']}` | {p['in']} | {_schema_name(p.get('schema', {}))} | "
                f"{'yes' if p.get('required') else ''} | {_cell(p.get('description'))} |"
                for p in params
            ]
            out.append("")
        body = op.get("requestBody", {}).get("content", {})
        for media, content in body.items():
            out += [f"Body ({media}): {_schema_name(content.get('schema', {}))}", ""]
        responses = [f"`{code}` {_cell(r.get('description'))}" for code, r in op.get("responses", {}).items()]
        out += ["Responses: " + "; ".join(responses), ""]
    out += ["## Schemas", ""]
    for name, schema in doc.get("components", {}).get("schemas", {}).items():
        out += [f"### {name}", ""]
        if schema.get("description"):
            out += [_cell(schema["description"]), ""]
        props = schema.get("properties", {})
        if props:
            required = set(schema.get("required", []))
            out += ["| field | type | required | meaning |", "|---|---|---|---|"]
            out += [
                f"| `{k}` | {_schema_name(v)} | {'yes' if k in required else ''} | "
                f"{_cell(v.get('description'))} |"
                for k, v in props.items()
            ]
            out.append("")
        elif "enum" in schema:
            out += ["One of " + ", ".join(f"`{v}`" for v in schema["enum"]), ""]
    return "\n".join(out)


# ---------------------------------------------------------------- config file formats


def _model(paths: tuple[str, ...]) -> type[BaseModel]:
    errors = []
    for path in paths:
        module, _, name = path.partition(":")
        try:
            return getattr(importlib.import_module(module), name)
        except (ImportError, AttributeError) as exc:
            errors.append(f"{path}: {exc}")
    raise ImportError("; ".join(errors))


def _type(annotation: Any) -> str:
    if isinstance(annotation, type) and not isinstance(annotation, types.GenericAlias):
        return annotation.__name__
    text = repr(annotation)
    text = re.sub(r"<class '([\w.]+)'>", lambda m: m.group(1).rsplit(".", 1)[-1], text)
    text = re.sub(r"\b(?:[a-z_]\w*\.)+([A-Za-z_]\w*)", r"\1", text)  # module paths off
    return text.replace("NoneType", "None").replace(" | ", " or ")


def _comments(model: type[BaseModel]) -> dict[str, str]:
    """The ``#:`` comments of a model's fields, beside a field or in the lines just above it (the project documents
    fields so where it sets no description)."""
    found: dict[str, str] = {}
    for cls in reversed(model.__mro__):
        if not (isinstance(cls, type) and issubclass(cls, BaseModel)) or cls is BaseModel:
            continue
        try:
            source = inspect.getsource(cls)
        except (OSError, TypeError):
            continue
        above: list[str] = []
        for line in source.splitlines():
            comment = re.match(r"^\s+#:\s*(.*)$", line)
            if comment:
                above.append(comment.group(1).strip())
                continue
            field = re.match(r"^\s+(\w+)\s*:[^\n]*?(?:#:\s*(.+))?$", line)
            if field and (field.group(2) or above):
                found[field.group(1)] = " ".join([*above, (field.group(2) or "").strip()]).strip()
            above = []
    return found


def _links(text: str) -> str:
    """Code comments cite documentation pages by path (``docs/history.md#2026-11-25``): links from the reference."""
    return re.sub(
        r"\bdocs/([\w/-]+\.md)(#[\w-]+)?",
        lambda m: f"[{m.group(0)}](../{m.group(1)}{m.group(2) or ''})",
        text,
    )


def _summary(annotation: Any) -> str:
    """A nested section's own first sentence, as the meaning of the key that holds it."""
    if not (isinstance(annotation, type) and issubclass(annotation, BaseModel)) or not annotation.__doc__:
        return ""
    return re.split(r"(?<=\.)\s", " ".join(annotation.__doc__.split()), maxsplit=1)[0]


def _nested(annotation: Any) -> list[type[BaseModel]]:
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    return [m for arg in typing.get_args(annotation) for m in _nested(arg)]


def _fields(model: type[BaseModel], out: list[str], seen: set[type], level: int) -> None:
    seen.add(model)
    doc = inspect.cleandoc(model.__doc__ or "") if model.__doc__ != BaseModel.__doc__ else ""
    if doc:
        out += [_links(_cell(doc)), ""]
    comments = _comments(model)
    nested: list[type[BaseModel]] = []
    rows = []
    for name, field in model.model_fields.items():
        if field.exclude:
            continue
        key = field.alias or name
        if field.is_required():
            default = "required"
        elif field.default_factory is not None or field.default is PydanticUndefined:
            default = ""
        elif isinstance(field.default, BaseModel):
            default = "(its defaults)"
        else:
            default = f"`{json.dumps(field.default, default=str)}`"
        meaning = _links(field.description or comments.get(name, "") or _summary(field.annotation))
        rows.append(
            f"| `{key}` | `{' '.join(_type(field.annotation).split())}` | {_cell(default)} | {_cell(meaning)} |"
        )
        nested += [m for m in _nested(field.annotation) if m not in seen and m not in nested]
    if rows:
        out += ["| key | type | default | meaning |", "|---|---|---|---|", *rows, ""]
    for sub in nested:
        if sub in seen:
            continue
        out += [f"{'#' * min(level + 1, 6)} `{sub.__name__}`", ""]
        _fields(sub, out, seen, level + 1)


def config_formats_page() -> str:
    out = [
        "# Config file formats",
        "",
        "The keys of every config file, generated from the pydantic models that validate them at each build of "
        "this site. Unknown keys are errors naming the file and the key. Units are in brackets where a "
        "description gives them.",
        "",
    ]
    for title, paths, what in CONFIG_FORMATS:
        model = _model(paths)
        out += [f"## {title}", "", f"{what} Model: `{model.__module__}.{model.__qualname__}`.", ""]
        _fields(model, out, set(), 2)
    return "\n".join(out)


GENERATORS = {PAGES[0]: cli_page, PAGES[1]: http_api_page, PAGES[2]: config_formats_page}


def on_files(files: Any, config: Any) -> Any:
    """MkDocs event: add the generated pages to the site."""
    from mkdocs.structure.files import File

    for uri, make in GENERATORS.items():
        files.append(File.generated(config, uri, content=make()))
    return files


if __name__ == "__main__":
    target = Path(sys.argv[1] if len(sys.argv) > 1 else "reference")
    for uri, make in GENERATORS.items():
        (target / Path(uri).name).parent.mkdir(parents=True, exist_ok=True)
        (target / Path(uri).name).write_text(make())
