"""The architecture's import rules, checked on the source: core is pure; torch, matplotlib and mlflow stay in their
corners; only the store talks to the database; api and worker never import each other; no import cycles (imports
inside functions count: a cycle held together by a lazy import is still a cycle)."""

from __future__ import annotations

import ast
from collections import defaultdict
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
SERVICE_ONLY = {
    "fastapi",
    "starlette",
    "sqlalchemy",
    "alembic",
    "httpx",
    "uvicorn",
    "psycopg",
    "api",
    "worker",
    "cli",
    "store",
}
PACKAGES = ("core", "store", "api", "worker", "cli")


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


def test_torch_only_in_predict_nn_and_training() -> None:
    """torch is an optional extra: the model and checkpoints (``predict/nn``) and training itself import it."""
    nn, train = REPO / "core" / "predict" / "nn", REPO / "core" / "training" / "train.py"
    offenders = [
        str(p.relative_to(REPO))
        for p in _core_files()
        if "torch" in _imports(p) and nn not in p.parents and p != train
    ]
    assert offenders == []


def test_matplotlib_only_in_render() -> None:
    render = REPO / "core" / "render"
    offenders = [
        str(p.relative_to(REPO))
        for p in _core_files()
        if "matplotlib" in _imports(p) and render not in p.parents
    ]
    assert offenders == []


def test_nothing_imports_cli_or_bench() -> None:
    """The Python API and the benches run stages through ``foresight.local``, as the CLI's ``--local`` does."""
    offenders = []
    for pkg in ("core", "store", "api", "worker", "foresight", "bench"):
        for p in (REPO / pkg).rglob("*.py"):
            if _imports(p) & ({"cli", "bench"} - {pkg}):  # the benches may share their own helpers
                offenders.append(str(p.relative_to(REPO)))
    assert offenders == []


def _modules() -> dict[str, Path]:
    """``foresight.<folder>.<module>`` -> file, for every module of our packages."""
    out = {}
    for pkg in PACKAGES:
        for p in sorted((REPO / pkg).rglob("*.py")):
            parts = p.relative_to(REPO).with_suffix("").parts
            out[".".join(("foresight", *(parts[:-1] if parts[-1] == "__init__" else parts)))] = p
    return out


def _module_graph() -> dict[str, set[str]]:
    """Module -> the modules of ours it imports (anywhere in the file; a package's ``__init__`` counts as a module)."""
    modules = _modules()

    def owner(name: str) -> str | None:
        while name and name not in modules:
            name = name.rpartition(".")[0]
        return name or None

    graph: dict[str, set[str]] = defaultdict(set)
    for name, path in modules.items():
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            targets: list[str] = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                targets = [f"{node.module}.{a.name}" for a in node.names]
            for target in targets:
                found = owner(target) if target.startswith("foresight.") else None
                if found and found != name and not name.startswith(found + "."):  # a package's own __init__
                    graph[name].add(found)
        graph.setdefault(name, set())
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one node (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph.get(child, ())))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    out.append(sorted(component))
    return out


def _package_graph() -> dict[str, set[str]]:
    packages: dict[str, set[str]] = defaultdict(set)
    for source, targets in _module_graph().items():
        for target in targets:
            a, b = _top(source), _top(target)
            if a != b:
                packages[a].add(b)
    return packages


def test_cycle_finder_finds_a_cycle() -> None:
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_no_import_cycle_between_modules() -> None:
    assert _cycles(_module_graph()) == []


def test_no_import_cycle_between_packages() -> None:
    assert _cycles(_package_graph()) == []


def test_the_cli_reads_answers_through_models_that_need_no_server() -> None:
    """The CLI's install has no web framework and no database: the response models (``foresight/schemas.py``,
    ``foresight/result_schemas.py``) import neither, nor our service packages; of the CLI only the commands that
    start the service (``cli/server.py``: serve, worker, up) import the API or the worker."""
    for name in ("schemas.py", "result_schemas.py"):
        assert _imports(REPO / "foresight" / name) & SERVICE_ONLY == set(), name
    offenders = [
        p.name
        for p in (REPO / "cli").glob("*.py")
        if p.name != "server.py" and _imports(p) & {"api", "worker"}
    ]
    assert offenders == []


def test_api_and_worker_never_import_each_other() -> None:
    packages = _package_graph()
    assert "worker" not in packages["api"] and "api" not in packages["worker"]
    assert packages["store"] <= {"core"}  # the store serves api and worker; it knows only core


def test_only_the_store_imports_sqlalchemy_or_alembic() -> None:
    files = [*_modules().values(), *sorted((REPO / "migrations").rglob("*.py"))]
    offenders = [
        str(p.relative_to(REPO))
        for p in files
        if _imports(p) & {"sqlalchemy", "alembic"}
        and REPO / "store" not in p.parents
        and REPO / "migrations" not in p.parents
    ]
    assert offenders == []


def test_only_the_exporter_imports_mlflow() -> None:
    """The MLflow client (network I/O, an optional extra) lives in one worker-side module."""
    offenders = [str(p.relative_to(REPO)) for p in _modules().values() if "mlflow" in _imports(p)]
    assert offenders == ["worker/mlflow_export.py"]


#: core's sub-packages from bottom to top (``""``: the modules directly in core/, such as errors and files): a
#: module imports only from its own level or below, inside functions too. A new sub-package takes its place here.
CORE_ORDER = (
    "",
    "runtime",  # the stage contract: context, typed refs, execution record, the Ray cluster
    "maps",
    "scenarios",
    "sim",  # the simulator and the planner protocol it calls
    "predict",
    "planners",
    "render",  # pictures, and the compact episode trace they draw
    "evaluation",
    "training",  # collection, training, the closed-loop proxy (it runs evaluations)
    "reports",
    "gym",
    "jobs",  # the job table: kinds, results, budgets, the pipeline
)


def _core_level(module: str) -> str:
    """``foresight.core.sim.episode`` -> ``sim``; a module directly in core/ -> ``""``."""
    parts = module.split(".")
    return parts[2] if len(parts) > 3 or (len(parts) == 3 and (REPO / "core" / parts[2]).is_dir()) else ""


def _core_package_graph() -> dict[str, set[str]]:
    graph: dict[str, set[str]] = defaultdict(set)
    for source, targets in _module_graph().items():
        if _top(source) != "core":
            continue
        graph.setdefault(_core_level(source), set())
        for target in targets:
            if _top(target) == "core" and _core_level(target) != _core_level(source):
                graph[_core_level(source)].add(_core_level(target))
    return graph


def test_core_order_names_every_sub_package() -> None:
    assert set(_core_package_graph()) == set(CORE_ORDER)


def test_no_import_cycle_between_core_sub_packages() -> None:
    assert _cycles(_core_package_graph()) == []


def test_core_imports_only_run_down_its_declared_order() -> None:
    rank = {name: i for i, name in enumerate(CORE_ORDER)}
    upward = sorted(
        f"{source} -> {target}"
        for source, targets in _module_graph().items()
        if _top(source) == "core"
        for target in targets
        if _top(target) == "core" and rank[_core_level(target)] > rank[_core_level(source)]
    )
    assert upward == []


def test_core_graph_counts_imports_inside_functions() -> None:
    """The job table imports training (torch) only inside the function that runs it; the graph still sees it."""
    assert "foresight.core.training.train" in _module_graph()["foresight.core.jobs.kinds"]
    assert _core_level("foresight.core.jobs.kinds") == "jobs" and _core_level("foresight.core.errors") == ""
