"""The architecture's import rules, checked on the source: core is pure; torch and matplotlib stay in their corners."""

from __future__ import annotations

import ast
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
SERVICE_ONLY = {"fastapi", "starlette", "sqlalchemy", "alembic", "httpx", "uvicorn", "psycopg", "api", "worker", "cli"}


def _top(module: str) -> str:
    """The first component of a module name, our own packages by their folder (``foresight.core.x`` -> core)."""
    parts = module.split(".")
    return parts[1] if parts[0] == "foresight" and len(parts) > 1 else parts[0]


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(), filename=str(path))
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(_top(a.name) for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(_top(node.module))
    return names


def _core_files() -> list[Path]:
    files = sorted((REPO / "core").rglob("*.py"))
    assert files, "core/ has no modules"
    return files


def test_core_imports_no_service_code() -> None:
    bad = {str(p.relative_to(REPO)): sorted(_imports(p) & SERVICE_ONLY) for p in _core_files()}
    assert {k: v for k, v in bad.items() if v} == {}


def test_torch_only_in_predict_nn() -> None:
    nn = REPO / "core" / "predict" / "nn"
    offenders = [str(p.relative_to(REPO)) for p in _core_files() if "torch" in _imports(p) and nn not in p.parents]
    assert offenders == []


def test_matplotlib_only_in_render() -> None:
    render = REPO / "core" / "render"
    offenders = [
        str(p.relative_to(REPO)) for p in _core_files() if "matplotlib" in _imports(p) and render not in p.parents
    ]
    assert offenders == []


def test_nothing_imports_cli_or_bench() -> None:
    offenders = []
    for pkg in ("core", "api", "worker"):
        for p in (REPO / pkg).rglob("*.py"):
            if _imports(p) & {"cli", "bench"}:
                offenders.append(str(p.relative_to(REPO)))
    assert offenders == []
