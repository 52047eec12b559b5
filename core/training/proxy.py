"""Closed-loop proxy for checkpoint selection: the predictive planner with a candidate checkpoint on a
TRAINING hard-seed set (never the evaluation manifest), run through the evaluation engine.

``evaluation_proxy(spec, ctx)`` returns the callback ``run_train`` takes: checkpoint path ->
{success, clearance} (success rate, mean minimum clearance [m]), plus the same planner with constant-velocity
forecasts on the same episodes (run once, ``proxy_eval/cv``), paired: ``cv_success``, ``vs_cv_delta`` (candidate
- CV success) and ``vs_cv_p`` (McNemar exact), so the training gate can see whether prediction helps in
closed loop on a suite where it can (the stress suite's training seeds).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pydantic import ConfigDict, Field

from foresight.core.bounds import BoundedConfig
from foresight.core.errors import ConfigError
from foresight.core.runtime.context import StageContext
from foresight.core.runtime.execution import Executor
from foresight.core.runtime.refs import BUILTIN_BUNDLE, BundlePath, Ident
from foresight.core.scenarios.model import MAX_EPISODE_STEPS


class ProxySpec(BoundedConfig):
    model_config = ConfigDict(extra="forbid", frozen=True)
    bundle: Ident = BUILTIN_BUNDLE
    matrix: BundlePath = "scenarios/classic_interactions.yaml"
    seed_manifest: BundlePath | None = (
        None  #: TRAINING hard seeds (>= 30 episodes so rates separate checkpoints)
    )
    scenarios: list[str] | None = None  #: with seeds_per_scenario when there is no manifest
    seeds_per_scenario: int | None = Field(default=None, ge=1, le=10_000)
    max_steps: int | None = Field(default=None, ge=1, le=MAX_EPISODE_STEPS)
    planner_config: dict[str, Any] = Field(
        default_factory=dict
    )  #: predictive planner config (defaults fill the rest)
    executor: Executor = "local"  #: where the proxy's episodes run (its scores do not depend on it)


CANDIDATE = "proxy-candidate"


def check_training_seeds(spec: ProxySpec, ctx: StageContext) -> list[tuple[str, int]]:
    """The proxy's (scenario, seed) episodes; ConfigError when its seed manifest holds one of its matrix's own
    seeds (the evaluation seeds: selecting a model on them would leak the evaluation into training)."""
    from foresight.core.evaluation.config import EpisodeSelection
    from foresight.core.evaluation.runner import load_selection

    sel = EpisodeSelection(
        bundle=spec.bundle,
        matrix=spec.matrix,
        scenarios=spec.scenarios,
        seeds_per_scenario=spec.seeds_per_scenario,
        seed_manifest=spec.seed_manifest,
    )
    _, matrix, pairs = load_selection(sel, ctx)
    if spec.seed_manifest is not None:
        clash = sorted({(n, s) for n, s in pairs if s in set(matrix.get(n).scenario.seeds)})
        if clash:
            raise ConfigError(
                f"{len(clash)} proxy episodes use evaluation seeds of {spec.matrix} (first: "
                f"{clash[0][0]} seed {clash[0][1]}); select models on TRAINING seeds only",
                source=spec.seed_manifest,
                item="seed_manifest",
            )
    return pairs


def evaluation_proxy(spec: ProxySpec, ctx: StageContext):
    """A callback running one evaluation per candidate checkpoint under ``proxy_eval/<name>/``."""
    from foresight.core.evaluation.config import EvaluationConfig
    from foresight.core.evaluation.delta import paired_deltas
    from foresight.core.evaluation.runner import read_records, run_evaluation

    check_training_seeds(spec, ctx)
    cv_records: list = []

    def run(path: Path | None, name: str) -> tuple[Any, list]:
        sub = StageContext(
            workdir=ctx.artifact(f"proxy_eval/{name}/result.json").parent,
            resolve_bundle=ctx.resolve_bundle,
            resolve_model=lambda ident: Path(path),
            is_cancelled=ctx.is_cancelled,
            log=ctx.log,
            workers=ctx.workers,
        )
        config = EvaluationConfig(
            bundle=spec.bundle,
            matrix=spec.matrix,
            seed_manifest=spec.seed_manifest,
            scenarios=spec.scenarios,
            seeds_per_scenario=spec.seeds_per_scenario,
            max_steps=spec.max_steps,
            planner={
                "name": "predictive",
                "config": spec.planner_config,
                "model": CANDIDATE if path else "cv",
            },
            executor=spec.executor,
        )
        result = run_evaluation(config, sub)
        return result.aggregates.overall, read_records(sub.workdir / result.artifacts["episodes"])

    def proxy(path: Path) -> dict[str, float]:
        overall, records = run(path, Path(path).stem)
        if not cv_records:
            cv_records.extend(run(None, "cv")[1])
        vs_cv = (paired_deltas(cv_records, records) or {}).get("success")
        clearance = overall.means["min_clearance"].mean
        out = {
            "success": float(overall.rates["success"].rate or 0.0),
            "clearance": float(clearance) if clearance is not None else float("-inf"),
            "episodes": float(overall.episodes),
        }
        if vs_cv is not None and vs_cv.delta is not None:
            out.update(cv_success=float(vs_cv.a.value), vs_cv_delta=vs_cv.delta, vs_cv_p=float(vs_cv.p_value))
        return out

    return proxy
