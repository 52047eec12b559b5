"""The Python API for notebooks and scripts: ``foresight.evaluate`` and ``foresight.simulate``.

Both run in-process exactly as ``foresight evaluate --local`` / ``foresight sim run --local`` do (the same spec,
the same stage function, the same typed result). A planner is a name (a built-in, an installed plugin,
``external``, ``module:attr``) or a Python object: a planner class (optionally with a pydantic ``config_model``,
then built as ``cls(config)``), a factory function, or a planner instance (reused, reset every episode).
With ``workers`` > 1 episodes run in spawned processes, which rebuild the planner from its ``module:attr`` name:
define it in an importable module (not in a notebook cell) for that.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from foresight.core.evaluation.episode import EpisodeRun
from foresight.core.evaluation.evaluation_result import EvaluationResult

DEFAULT_MATRIX = "scenarios/classic_interactions.yaml"


def _files(*refs: str | Path | None) -> tuple[str, list[str | None], dict[str, Path]]:
    """(bundle, bundle-relative names, bundle roots) of files, or of names in the built-in configs."""
    from foresight.core.runtime.refs import BUILTIN_CONFIG_ROOT
    from foresight.local import bundle_of

    return bundle_of(
        *(
            None if r is None else str(r if Path(r).expanduser().is_file() else BUILTIN_CONFIG_ROOT / str(r))
            for r in refs
        )
    )


def planner_name(planner: Any) -> str:
    """The name a planner runs under: a name as given, or a Python object registered as ``module:attr``."""
    from foresight.core.planners.registry import register

    if isinstance(planner, str):
        return register(planner) if ":" in planner else planner
    return register(planner)


def model_name(model: Any) -> str | None:
    """The name a model runs under: as given, or a Python predictor object (a predictor plug-in class or instance,
    docs/predictor_protocol.md) registered as ``module:qualname``."""
    if model is None or isinstance(model, str):
        return model
    from foresight.core.predict import plugins

    return plugins.register(model)


def _planner(planner: Any, config: dict[str, Any] | None, model: Any) -> tuple[dict[str, Any], Any]:
    from foresight.core.planners.registry import entry
    from foresight.local import ModelArgs

    models = ModelArgs()
    model = model_name(model)
    name = planner_name(planner)
    spec: dict[str, Any] = {"name": name, "config": config or {}}
    if entry(name).takes_model:
        spec["model"] = models.ident(model) if model is not None else models.default()
    elif model is not None:
        spec["model"] = model
    return spec, models


def evaluate(
    planner: Any = "predictive",
    *,
    matrix: str | Path = DEFAULT_MATRIX,
    scenarios: list[str] | None = None,
    seeds: int | None = None,
    seed_manifest: str | Path | None = None,
    config: dict[str, Any] | None = None,
    model: Any = None,
    max_steps: int | None = None,
    workers: int = 1,
    out: str | Path | None = None,
    quiet: bool = True,
) -> EvaluationResult:
    """Evaluate a planner on a scenario matrix; the same typed result as the service's ``evaluate`` job.

    ``matrix``: a YAML file, or a name in the built-in configs; ``seeds``: N seeds per scenario (default: the
    matrix's own); ``config``: the planner's config (validated by its model); ``model``: predictive planner only
    (a model id, a checkpoint path, "cv", "static", a predictor plug-in name or a Python predictor object; default: the
    shipped default model); ``out``: the work folder (default: a new temporary folder) where evaluation.json and
    episodes.jsonl are written; the result's ``artifacts`` name them by absolute path.
    """
    from foresight.core.evaluation.runner import run_evaluation
    from foresight.local import config_of, local_context, spec

    bundle, (name, manifest), roots = _files(matrix, seed_manifest)
    planner_dict, models = _planner(planner, config, model)
    values = {
        "bundle": bundle,
        "matrix": name,
        "seed_manifest": manifest,
        "scenarios": scenarios,
        "seeds_per_scenario": seeds,
        "max_steps": max_steps,
        "planner": planner_dict,
    }
    cfg = config_of(spec("evaluate", values))
    ctx = local_context(Path(out) if out else None, roots, quiet=quiet)
    ctx.resolve_model = models.resolve
    ctx.workers = max(1, int(workers))
    result = run_evaluation(cfg, ctx)
    # a script finds the files without knowing the (temporary) work folder: artifacts as absolute paths
    folder = ctx.workdir.resolve()
    return result.model_copy(update={"artifacts": {k: str(folder / v) for k, v in result.artifacts.items()}})


def simulate(
    planner: Any = "goal",
    *,
    scenario: str,
    seed: int = 0,
    matrix: str | Path = DEFAULT_MATRIX,
    config: dict[str, Any] | None = None,
    model: Any = None,
    max_steps: int | None = None,
) -> EpisodeRun:
    """One episode of a planner: its evaluation record (outcome, metrics, taxonomy) and the full trace."""
    from foresight.core.evaluation.episode import run_one
    from foresight.core.evaluation.plannerspec import resolve_planner
    from foresight.core.runtime.context import StageContext
    from foresight.core.scenarios.loader import load_matrix

    bundle, (name,), roots = _files(matrix)
    planner_dict, models = _planner(planner, config, model)
    rp = resolve_planner(planner_dict, StageContext(workdir=Path.cwd(), resolve_model=models.resolve))
    return run_one(load_matrix(roots[bundle] / str(name)).get(scenario), seed, rp, max_steps=max_steps)
