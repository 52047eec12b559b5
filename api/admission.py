"""What a submission must pass before it is queued: its inputs exist and its size fits the server's budget.

Runs in the thread pool (a matrix is parsed once per file version, ~0.3 s the first time). The worker repeats the budget check before a
stage starts, so child jobs that never pass the API are bounded too.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from foresight.api.web.previews import load_matrix_cached
from foresight.core.jobs.budget import check_budget, work_size
from foresight.core.runtime.context import StageContext
from foresight.store.registry import Resolver
from foresight.store.settings import Settings


def context(settings: Settings, resolver: Resolver) -> StageContext:
    """A context that resolves ids as a worker does (never local files); it runs nothing."""
    return StageContext(
        workdir=settings.store_root,
        resolve_bundle=resolver.bundle,
        resolve_model=resolver.model,
        resolve_dataset=resolver.dataset,
        resolve_data_root=settings.data_root,
        resolve_run=resolver.run,
        local_files=False,
    )


def named_ids(spec: Any) -> list[tuple[str, str]]:
    """(model | dataset, id) of every stored input a spec names by id (every model named is one a planner drives)."""
    from foresight.core.evaluation.config import CampaignConfig
    from foresight.core.predict import plugins
    from foresight.core.training.collect import CollectConfig, MixConfig
    from foresight.core.training.config import TrainConfig

    out: list[tuple[str, str]] = []
    planner = getattr(spec, "planner", None)
    model = getattr(planner, "model", None) if planner is not None and not isinstance(planner, dict) else None
    if isinstance(spec, CollectConfig) and spec.policy == "planner":
        model = (spec.planner or {}).get("model")
    if isinstance(model, str) and model not in ("cv", "static"):
        out.append(("predictor" if plugins.kind(model) else "model", model))
    if isinstance(spec, CampaignConfig):
        out += [
            ("predictor" if plugins.kind(ck) else "model", ck)
            for ck in spec.checkpoints
            if ck not in ("cv", "static")
        ]
    model = getattr(spec, "model", None)  # predict_eval
    if type(spec).__name__ == "PredictEvalConfig" and isinstance(model, str) and plugins.kind(model):
        out.append(("predictor", model))
    if isinstance(spec, MixConfig):
        out += [("dataset", spec.base), ("dataset", spec.hardcase)]
    if isinstance(spec, TrainConfig):
        out.append(("dataset", spec.dataset))
    return out


def check_predictor(name: str) -> None:
    """ConfigError (422) for a predictor plug-in the server cannot run: ``module:attr`` (in-process runs only) or
    an external one the operator has not configured; NotFoundError / PredictorError for one that does not load."""
    from foresight.core.errors import ConfigError
    from foresight.core.predict import plugins
    from foresight.core.predict.external import ENV, operator_commands

    kind = plugins.kind(name)
    if kind == "module":
        raise ConfigError(
            f"predictor {name!r}: module:attr predictors run in-process only (--local, foresight.evaluate); "
            "the server runs installed predictor plug-ins and operator-configured external predictors",
            item="model",
        )
    if kind == "external":
        command = name[len(plugins.EXTERNAL_PREFIX) :]
        if command not in operator_commands():
            raise ConfigError(f"predictor {name!r} is not configured by the operator ({ENV})", item="model")
        return
    plugins.load(name)  # an installed plug-in whose declaration is broken is refused now


def _matrix(path: Path, overrides: dict[str, Any] | None = None) -> Any:
    """A matrix parsed once per file version (as the dashboard's), unless a spec overrides its scenarios."""
    if overrides or not path.is_file():  # a missing file: load_matrix's error names it
        from foresight.core.scenarios.loader import load_matrix

        return load_matrix(path, overrides=overrides)
    return load_matrix_cached(path)


#: a spec's top-level fields that name a dataset, which is the id of the job that wrote it
DATASET_FIELDS = ("dataset", "base", "hardcase")


def full_ids(spec: Any, engine: Any) -> Any:
    """The spec with short job ids (as the CLI prints them) in its dataset fields replaced by full ids."""
    from foresight.store import job_reads

    update = {}
    for field in DATASET_FIELDS:
        value = getattr(spec, field, None)
        if isinstance(value, str) and value:
            full = job_reads.resolve_id(engine, value)
            if full != value:
                update[field] = full
    return spec.model_copy(update=update) if update else spec


#: a spec's top-level fields that name its matrix inside its config bundle (the other files: BUNDLE_FILE_FIELDS)
BUNDLE_FILES = ("matrix", "seeds")


def bundle_files(spec: Any, ctx: StageContext) -> None:
    """ConfigError (422) naming the field, the name and the bundle (never a server path) for a bundle file that is
    not there; a name that starts with the bundle's own ``configs/`` folder gets the name meant."""
    from foresight.core.errors import ConfigError
    from foresight.core.runtime.refs import resolve_in_bundle

    bundle = getattr(spec, "bundle", None)
    if not isinstance(bundle, str):
        return
    root = ctx.resolve_bundle(bundle)
    for field in BUNDLE_FILES:
        rel = getattr(spec, field, None)
        if not isinstance(rel, str) or resolve_in_bundle(root, rel).is_file():
            continue
        meant = rel.removeprefix("configs/")
        hint = (
            f": names are relative to the bundle's root, did you mean {meant!r}?"
            if meant != rel and resolve_in_bundle(root, meant).is_file()
            else " (e.g. scenarios/classic_interactions.yaml)"
        )
        raise ConfigError(f"no file {rel!r} in config bundle {bundle!r}{hint}", item=field)


#: bundle files a spec may name beside its matrix: seed manifests and planner grids
BUNDLE_FILE_FIELDS = ("seed_manifest", "hard_seeds", "evaluation_seeds", "training_seeds", "grid")


def check_bundle_files(spec: Any, ctx: StageContext) -> None:
    """NotFoundError naming the field for a bundle file the spec names that its bundle lacks (a missing
    ``evaluation_seeds`` was accepted and failed in the worker)."""
    from foresight.core.errors import NotFoundError
    from foresight.core.runtime.refs import resolve_in_bundle

    named = [(f, getattr(spec, f, None)) for f in BUNDLE_FILE_FIELDS]
    named = [(f, v) for f, v in named if isinstance(v, str)]
    if not named:
        return
    bundle = getattr(spec, "bundle", None) or "builtin"
    root = ctx.resolve_bundle(bundle)
    for field, rel in named:
        try:
            found = resolve_in_bundle(root, rel).is_file()
        except ValueError:
            found = False
        if not found:
            raise NotFoundError(f"spec.{field}: bundle {bundle!r} has no file {rel!r}")


def admit(spec: Any, settings: Settings, resolver: Resolver) -> None:
    """NotFoundError (404) for an unknown bundle, matrix, scenario, model, dataset or evaluation; ConfigError (422) for a model
    a planner cannot drive (trained in another frame) or a job larger than ``settings.max_job_steps`` simulation steps."""
    from foresight.core.evaluation.witness_job import WitnessConfig, plan_search

    ctx = context(settings, resolver)
    bundle_files(spec, ctx)  # the matrix, with the name meant for a path typed with configs/
    check_bundle_files(spec, ctx)
    for what, ident in named_ids(spec):
        if what == "predictor":
            check_predictor(ident)
        else:
            (resolver.planner_model if what == "model" else resolver.dataset)(ident)
    if isinstance(
        spec, WitnessConfig
    ):  # its evaluation (kept with its run folder), matrix, scenarios and size
        plan_search(spec, ctx)
    check_budget(work_size(spec, ctx, _matrix), settings.max_job_steps)
