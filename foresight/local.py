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
    p = Path(path).expanduser().resolve()
    if not p.is_file():
        raise ConfigError("matrix file not found", source=path)
    try:
        return (
            BUILTIN_BUNDLE,
            p.relative_to(BUILTIN_CONFIG_ROOT).as_posix(),
            {BUILTIN_BUNDLE: BUILTIN_CONFIG_ROOT},
        )
    except ValueError:
        return LOCAL_BUNDLE, p.name, {LOCAL_BUNDLE: p.parent, BUILTIN_BUNDLE: BUILTIN_CONFIG_ROOT}


def bundle_of(*files: str | None) -> tuple[str, list[str], dict[str, Path]]:
    """(bundle id, bundle-relative paths, bundle roots) for command-line files."""
    paths = []
    for f in files:
        if f is None:
            paths.append(None)
            continue
        p = Path(f).expanduser().resolve()
        if not p.is_file():
            raise ConfigError("file not found", source=f)
        paths.append(p)
    real = [p for p in paths if p is not None]
    roots = {BUILTIN_BUNDLE: BUILTIN_CONFIG_ROOT}
    if all(BUILTIN_CONFIG_ROOT in p.parents for p in real):
        bundle, root = BUILTIN_BUNDLE, BUILTIN_CONFIG_ROOT
    else:
        bundle, root = LOCAL_BUNDLE, Path(os.path.commonpath([str(p.parent) for p in real]))
        roots[LOCAL_BUNDLE] = root
    return bundle, [p.relative_to(root).as_posix() if p else None for p in paths], roots


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

        if value is None or value == "cv" or plugins.kind(value):  # a predictor plug-in is its own name
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

    if ":" in value and not Path(value).is_file():
        if not local:
            raise ConfigError(f"{value!r}: module:attr planners run in-process only (--local); the server runs "
                              f"installed plugins and operator-configured external planners",
                              source="command line", item="--planner")  # fmt: skip
        spec: dict[str, Any] = {"name": register(value)}
    elif value in names() or not value.endswith((".yaml", ".yml", ".json")):
        spec = {"name": value}
    else:
        from foresight.core.scenarios.loader import read_yaml

        data = read_yaml(Path(value))
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

    def resolve_data_root(name: str) -> Path:
        """A named data root: FORESIGHT_DATA_ROOTS, or ``ethucy`` from the shared folder."""
        from foresight.store.settings import Settings

        return Settings().data_root(name)

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


def progress_bar(*, quiet: bool) -> Any:
    """The CLI's one progress-bar style (rich, on stderr): in-process runs and followed server jobs alike."""
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    return Progress(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.percentage:>5.1f}%"),
                    TimeElapsedColumn(), TextColumn("{task.fields[message]}"), console=Console(stderr=True),
                    disable=quiet, transient=False)  # fmt: skip


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
    settings = Settings()
    mlflow_export.export_run(
        mlflow_export.target(settings.mlflow_tracking_uri, settings.mlflow_experiment),
        kind,
        result,
        workdir,
        log,
    )
    return pages
