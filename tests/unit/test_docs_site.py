"""The documentation site builds with ``mkdocs build --strict`` (as ``make docs`` does; offline: the Material theme
and the hook need no network), and its generated reference pages cover the code they are generated from: every CLI
command of the argparse tree, every path and method of the app's OpenAPI schema, every config format's model."""

from __future__ import annotations

import argparse
import functools
import importlib.util
import os
import subprocess
import sys
import types
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
HOOK = REPO / "docs" / "_hooks" / "reference.py"


@functools.cache
def _hook() -> types.ModuleType:
    """The hook module, loaded once (its OpenAPI schema is cached)."""
    spec = importlib.util.spec_from_file_location("docs_reference_hook", HOOK)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("site")
    mkdocs = Path(sys.executable).parent / "mkdocs"
    assert mkdocs.is_file(), "mkdocs is not installed: pip install -e '.[dev]' (it holds mkdocs-material)"
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1", "HOME": str(out.parent)}  # no network, no user state
    proc = subprocess.run(
        [str(mkdocs), "build", "--strict", "--site-dir", str(out)],
        cwd=REPO,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr[-4000:]
    return out


def test_site_builds_strict_with_every_page(site: Path) -> None:
    for page in (
        "index.html",
        "getting-started/index.html",
        "reference/cli/index.html",
        "reference/http-api/index.html",
        "reference/config-formats/index.html",
        "history/index.html",
        "benchmarks/index.html",
        "tutorials/own-planner/index.html",
        "images/episode.png",
    ):
        assert (site / page).is_file(), page
    assert not (site / "_hooks").exists(), "the hook's source must not be published"


def _commands(
    parser: argparse.ArgumentParser, path: tuple[str, ...] = ("foresight",)
) -> list[tuple[str, ...]]:
    found = [path]
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                found += _commands(sub, (*path, name))
    return found


def test_cli_reference_lists_every_command_and_option() -> None:
    from foresight.cli.main import build_parser

    page = _hook().cli_page()
    parser = build_parser()
    commands = _commands(parser)
    assert len(commands) > 40, commands
    for path in commands:
        assert f"`{' '.join(path)}`" in page, f"the CLI reference lacks {' '.join(path)}"
    evaluate = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices[
        "evaluate"
    ]
    for action in evaluate._actions:
        for option in [] if isinstance(action, argparse._HelpAction) else action.option_strings:
            assert f"`{option}`" in page, option


def test_http_reference_lists_every_endpoint() -> None:
    hook = _hook()
    schema = hook.openapi_schema()
    page = hook.http_api_page()
    assert len(schema["paths"]) > 30
    for path, item in schema["paths"].items():
        for method in item:
            assert f"## {method.upper()} `{path}`" in page, (method, path)
    assert "### JobCreate" in page


def test_config_reference_covers_every_format() -> None:
    hook = _hook()
    page = hook.config_formats_page()
    for title, paths, _ in hook.CONFIG_FORMATS:
        assert f"## {title}" in page
        model = hook._model(paths)
        for name, field in model.model_fields.items():
            assert f"`{field.alias or name}`" in page, (title, name)
    assert "`collision_margin`" in page  # a nested model's keys (the predictive planner's safety section)
