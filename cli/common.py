"""Helpers shared by the CLI's stage commands: local (in-process) execution, output, spec building."""

from __future__ import annotations

import argparse
import json
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ValidationError

from foresight.core.errors import ConfigError
from foresight.core.stages.context import StageContext
from foresight.core.stages.refs import BUILTIN_BUNDLE, BUILTIN_CONFIG_ROOT

LOCAL_BUNDLE = "local"


def matrix_ref(path: str) -> tuple[str, str, dict[str, Path]]:
    """Turn a user's matrix path into (bundle id, bundle-relative path, local bundle roots).

    A matrix inside the project's configs/ is the builtin bundle; any other file is a local bundle
    rooted at its folder (runs in-process; the service needs it uploaded as a bundle).
    """
    from foresight.cli.paths import builtin_name, user_file

    p = user_file(path, "--matrix")
    name = builtin_name(p)
    if name is not None:
        return BUILTIN_BUNDLE, name, {BUILTIN_BUNDLE: BUILTIN_CONFIG_ROOT}
    return LOCAL_BUNDLE, p.name, {LOCAL_BUNDLE: p.parent, BUILTIN_BUNDLE: BUILTIN_CONFIG_ROOT}


def build_config(model: type[BaseModel], values: dict[str, Any]) -> Any:
    """Validate CLI values into the stage's config model; errors become one readable ConfigError."""
    try:
        return model.model_validate({k: v for k, v in values.items() if v is not None})
    except ValidationError as exc:
        first = exc.errors()[0]
        field = ".".join(str(x) for x in first["loc"]) or "spec"
        raise ConfigError(first["msg"], source="command line", item=field) from None


def local_workdir(out: str | Path | None, name: str) -> Path:
    """A ``--local`` run's work folder: ``--out``, else a new ``<data dir>/runs/NAME-<time>-<hex>`` (the per-user data
    folder, so runs are found again from any terminal; delete old ones freely)."""
    if out:
        return Path(out)
    import secrets
    import time

    from foresight.store.settings import Settings

    folder = Settings().local_runs / f"{name}-{time.strftime('%Y%m%d-%H%M%S')}-{secrets.token_hex(3)}"
    folder.mkdir(parents=True)
    return folder


def local_context(workdir: Path | None, bundles: dict[str, Path], *, quiet: bool) -> StageContext:
    """A StageContext for in-process runs, with a progress line on stderr unless quiet."""
    from foresight.core.errors import NotFoundError

    def resolve_bundle(ident: str) -> Path:
        if ident not in bundles:
            raise NotFoundError(f"unknown bundle id {ident!r} (in-process runs know {sorted(bundles)})")
        return bundles[ident]

    def resolve_data_root(name: str) -> Path:
        """A named data root: FORESIGHT_DATA_ROOTS, or ``ethucy`` from the shared folder."""
        from foresight.store.settings import Settings

        return Settings().data_root(name)

    from foresight.store.settings import Settings
    from foresight.worker.mlflow_export import settings_target

    settings_target(Settings())  # a tracking URI that cannot work is refused before the run, not after it
    bar = progress_bar(quiet=quiet)
    task: list[Any] = []

    def progress(fraction: float, message: str) -> None:
        if not task:  # started by the first report, so nothing is drawn for a run that fails before it
            bar.start()
            task.append(bar.add_task("local", total=1.0, message=""))
        bar.update(task[0], completed=fraction, message=message[:60])
        if fraction >= 1.0:
            bar.stop()

    root = workdir or Path(tempfile.mkdtemp(prefix="foresight-"))
    root.mkdir(parents=True, exist_ok=True)
    return StageContext(
        workdir=root, progress=progress, resolve_bundle=resolve_bundle, resolve_data_root=resolve_data_root
    )


def finish_local(kind: str, result: Any, workdir: Path) -> list[Path]:
    """What a worker does after a stage, for an in-process run: the report page (its paths returned) and, with
    FORESIGHT_MLFLOW_TRACKING_URI set, the copy to MLflow (a failure is a warning line on stderr)."""
    import sys

    from foresight.core.reports.stage import write_report
    from foresight.store.settings import Settings
    from foresight.worker import mlflow_export

    def log(message: str) -> None:
        print(message, file=sys.stderr)

    pages = write_report(kind, result, workdir, log)
    if kind == "evaluate":
        failed_players(result, workdir)
    settings = Settings()
    mlflow_export.export_run(
        mlflow_export.settings_target(settings),
        kind,
        result,
        workdir,
        log,
    )
    return pages


def failed_players(result: Any, workdir: Path) -> list[Path]:
    """Standalone player pages of an in-process evaluation's failed episodes, where its report links them
    (``player/<scenario>__<seed>.html``; on the server the dashboard's player answers those links)."""
    from foresight.core.evaluation.episode_trace import read_compact, trace_name
    from foresight.core.render.player import write_player
    from foresight.core.reports.evaluation import player_path

    failed = [f for g in result.aggregates.per_scenario for f in g.failed] or result.aggregates.overall.failed
    written = []
    for f in failed:
        trace = workdir / trace_name(f.scenario, f.seed)
        if trace.is_file():
            title = f"{f.scenario} seed {f.seed}: {f.outcome}"
            written.append(
                write_player(workdir / player_path(f.scenario, f.seed), [(title, read_compact(trace))], title)
            )
    return written


def progress_bar(*, quiet: bool) -> Any:
    """The CLI's one progress-bar style (rich, on stderr): in-process runs and followed server jobs alike."""
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    return Progress(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.percentage:>5.1f}%"),
                    TimeElapsedColumn(), TextColumn("{task.fields[message]}"), console=Console(stderr=True),
                    disable=quiet, transient=False)  # fmt: skip


def emit(obj: Any, as_json: bool, text: Callable[[Any], str]) -> None:
    """Print a result as JSON (for scripts) or as human text."""
    if as_json:
        data = obj.model_dump(mode="json") if isinstance(obj, BaseModel) else obj
        print(json.dumps(data, indent=2))
    else:
        print(text(obj))


def matrix_options(p: argparse.ArgumentParser, conditions: str = "") -> None:
    """--matrix and --override of the commands that look at a matrix's episodes under chosen conditions."""
    p.add_argument("--matrix", required=True, help="scenario matrix YAML")
    p.add_argument(
        "--override",
        action="append",
        metavar="KEY=VALUE",
        help=f"under other conditions, as foresight evaluate --override (repeatable{conditions})",
    )


def episode_options(p: argparse.ArgumentParser, episodes: str, conditions: str = "") -> None:
    """:func:`matrix_options` and which of its episodes: --scenarios, --seeds-per-scenario and an evaluation's
    --episodes (``episodes``: what the command does with them)."""
    matrix_options(p, conditions)
    p.add_argument("--scenarios", help="comma-separated scenario names (default: all)")
    p.add_argument(
        "--seeds-per-scenario",
        type=int,
        help="N seeds per scenario, as foresight evaluate's (default: the matrix's own)",
    )
    p.add_argument(
        "--episodes", help=f"an evaluation's episodes.jsonl (evaluate --local --out DIR): {episodes}"
    )
