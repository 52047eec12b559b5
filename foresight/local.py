"""In-process runs of stages, as ``foresight ... --local``, the Python API (``foresight.library``) and the
benches do them: command-line files as a local config bundle, model ids from model/registry.yaml or checkpoint
paths, the job kind's spec and config, a StageContext on a local folder, and what a worker does after a stage.

It lives beside the library rather than in ``cli/`` because all three call it (nothing imports the CLI); it may
use the store's settings and shipped-model rule, which ``core`` may not.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ValidationError

from foresight.core.errors import ConfigError
from foresight.core.runtime.context import StageContext
from foresight.core.runtime.refs import BUILTIN_BUNDLE, BUILTIN_CONFIG_ROOT

LOCAL_BUNDLE = "local"


def matrix_ref(path: str) -> tuple[str, str, dict[str, Path]]:
    """Turn a user's matrix path into (bundle id, bundle-relative path, local bundle roots).

    A matrix inside the project's configs/ is the builtin bundle; any other file is a local bundle
    rooted at its folder (runs in-process; the service needs it uploaded as a bundle).
    """
    from foresight.paths import builtin_name, user_file

    p = user_file(path, "--matrix")
    name = builtin_name(p)
    if name is not None:
        return BUILTIN_BUNDLE, name, {BUILTIN_BUNDLE: BUILTIN_CONFIG_ROOT}
    return LOCAL_BUNDLE, p.name, {LOCAL_BUNDLE: p.parent, BUILTIN_BUNDLE: BUILTIN_CONFIG_ROOT}


def bundle_of(*files: str | None) -> tuple[str, list[str], dict[str, Path]]:
    """(bundle id, bundle-relative paths, bundle roots) for command-line files."""
    from foresight.paths import builtin_name, user_file

    paths = [None if f is None else user_file(f, "file") for f in files]
    real = [p for p in paths if p is not None]
    roots = {BUILTIN_BUNDLE: BUILTIN_CONFIG_ROOT}
    builtin = [builtin_name(p) for p in real]
    if all(name is not None for name in builtin):
        names = iter(builtin)
        return BUILTIN_BUNDLE, [None if p is None else next(names) for p in paths], roots
    root = Path(os.path.commonpath([str(p.parent) for p in real]))
    roots[LOCAL_BUNDLE] = root
    return LOCAL_BUNDLE, [p.relative_to(root).as_posix() if p else None for p in paths], roots


MODEL_REGISTRY = BUILTIN_CONFIG_ROOT.parent / "model" / "registry.yaml"


class ModelArgs:
    """Maps --model/--checkpoints values to model ids for in-process runs.

    A checkpoint path becomes id ``file:<name>``; other ids are looked up in model/registry.yaml
    (checksum verified); no --model for the predictive planner means the registry's default predictor.
    """

    def __init__(self) -> None:
        self.files: dict[str, Path] = {}

    def ident(self, value: str | None) -> str | None:
        from foresight.core.predict import plugins

        if (
            value is None or value in ("cv", "static") or plugins.kind(value)
        ):  # a predictor plug-in is its own name
            return value
        p = Path(value).expanduser()
        if p.is_file():
            ident = f"file:{p.name}"
            self.files[ident] = p.resolve()
            return ident
        return value

    def default(self) -> str:
        """The default model of the shipped registry, by the server's own rule (store.shipped.default_model)."""
        from foresight.store.shipped import default_model, read_shipped

        entry = default_model(read_shipped(MODEL_REGISTRY))
        if entry is None:
            raise ConfigError(
                "no default predictor in model/registry.yaml: pass --model ID|PATH|cv",
                source="command line",
                item="model",
            )
        return str(entry["id"])

    def resolve(self, ident: str) -> Path:
        from foresight.store.shipped import resolve_shipped

        if ident in self.files:
            return self.files[ident]
        return resolve_shipped(MODEL_REGISTRY, ident)

    @staticmethod
    def describe(ident: str) -> dict[str, Any] | None:
        """A shipped model's registry entry (id, status, sha256; ``default``: the default model, by the server's
        rule), for an in-process pipeline's incumbent; None if unknown."""
        from foresight.store.shipped import DEFAULT_MODEL, default_model, read_shipped

        entries = read_shipped(MODEL_REGISTRY)
        entry = next((m for m in entries if m["id"] == ident), None)
        if entry is None and ident == DEFAULT_MODEL:
            entry = default_model(entries)
        return None if entry is None else {**entry, "lineage": entry.get("lineage", {}), "created_at": 0.0}


def planner_spec(
    value: str,
    model: str | None,
    models: ModelArgs,
    *,
    default: bool = True,
    config: str | None = None,
    local: bool = True,
) -> dict[str, Any]:
    """The planner part of a spec from ``--planner`` (a name or a YAML file), ``--planner-config`` and ``--model``.

    ``module:attr`` names in-process planners: registered here for ``--local`` runs, refused for the server.
    """
    from foresight.core.planners.registry import entry, names, register

    if value.startswith("sb3:"):  # a trained policy: a local file (--local), else a name in the job's bundle
        policy = value.removeprefix("sb3:")
        if local and Path(policy).expanduser().is_file():
            policy = str(Path(policy).expanduser().resolve())
        spec: dict[str, Any] = {"name": "sb3", "config": {"policy": policy}}
        if config is not None:
            spec["config"] |= _inline_config(config)
        return spec
    if ":" in value and not Path(value).is_file():
        if not local:
            raise ConfigError(
                f"{value!r}: module:attr planners run in-process only (--local); the server runs "
                f"installed plugins and operator-configured external planners",
                source="command line",
                item="--planner",
            )
        spec = {"name": register(value)}
    elif value in names() or not value.endswith((".yaml", ".yml", ".json")):
        spec = {"name": value}
    else:
        from foresight.core.scenarios.loader import read_yaml
        from foresight.paths import user_file

        data = read_yaml(user_file(value, "--planner"))
        if not isinstance(data, dict):
            raise ConfigError("a planner file must be a mapping", source=value)
        spec = dict(data) if "name" in data else {"name": "predictive", "config": data}
    if config is not None:
        spec["config"] = _inline_config(config)
    if model is not None:
        spec["model"] = models.ident(model)
    elif default and "model" not in spec and _takes_model(spec.get("name", "predictive"), entry):
        spec["model"] = models.default()
    return spec


def _takes_model(name: str, entry: Any) -> bool:
    try:
        return entry(name).takes_model
    except LookupError:  # an unknown name: the spec's validation names it with the installed ones
        return False


def _inline_config(text: str) -> dict[str, Any]:
    import yaml

    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ConfigError(
            f"not JSON or YAML ({str(exc).splitlines()[0]})", source="command line", item="--planner-config"
        ) from None
    if not isinstance(data, dict):
        raise ConfigError("expected a mapping of config keys", source="command line", item="--planner-config")
    return data


def overrides(items: list[str] | None) -> dict[str, Any]:
    """``["ped_speed_tier=typical", "robot_config.radius=0.5"]`` -> nested scenario overrides (values as YAML
    scalars; a bare key of SimulationConfig means simulation_config.KEY)."""
    import yaml

    from foresight.core.scenarios.model import SimulationConfig

    out: dict[str, Any] = {}
    for item in items or []:
        key, sep, raw = item.partition("=")
        if not sep or not key.strip():
            raise ConfigError(f"expected KEY=VALUE, got {item!r}", source="command line", item="--override")
        path = key.strip().split(".")
        if len(path) == 1 and path[0] in SimulationConfig.model_fields:
            path = ["simulation_config", *path]
        node = out
        for part in path[:-1]:
            node = node.setdefault(part, {})
            if not isinstance(node, dict):
                raise ConfigError(
                    f"{key} conflicts with another override", source="command line", item="--override"
                )
        node[path[-1]] = yaml.safe_load(raw)
    return out


def build_config(model: type[BaseModel], values: dict[str, Any]) -> Any:
    """Validate CLI values into the stage's config model; errors become one readable ConfigError."""
    try:
        return model.model_validate({k: v for k, v in values.items() if v is not None})
    except ValidationError as exc:
        first = exc.errors()[0]
        field = ".".join(str(x) for x in first["loc"]) or "spec"
        raise ConfigError(first["msg"], source="command line", item=field) from None


def spec(kind: str, values: dict[str, Any]) -> BaseModel:
    """The job kind's spec from command-line values (None = not given); one readable ConfigError when invalid."""
    from foresight.core.jobs.kinds import KINDS

    return build_config(KINDS[kind].spec, {**values, "kind": kind})


def config_of(spec_obj: BaseModel) -> Any:
    """The core stage config of a job spec, exactly as a worker builds it (the job kind's ``config_of``)."""
    from foresight.core.jobs.kinds import KINDS

    return KINDS[spec_obj.kind].config_of(spec_obj)


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

    def resolve_dataset(ident: str) -> Path:
        """Only files here: a dataset id is the server's (a file that exists never gets here)."""
        import os

        raise NotFoundError(
            f"no dataset file {ident!r} in {os.getcwd()} (in-process runs read a .npz file; "
            "a dataset id names a server's dataset: run without --local)"
        )

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
        workdir=root,
        progress=progress,
        resolve_bundle=resolve_bundle,
        resolve_data_root=resolve_data_root,
        resolve_dataset=resolve_dataset,
    )


def progress_bar(*, quiet: bool) -> Any:
    """The CLI's one progress-bar style (rich, on stderr): in-process runs and followed server jobs alike."""
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    return Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.percentage:>5.1f}%"),
        TimeElapsedColumn(),
        TextColumn("{task.fields[message]}"),
        console=Console(stderr=True),
        disable=quiet,
        transient=False,
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
    from foresight.core.render.episode_trace import read_compact, trace_name
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
