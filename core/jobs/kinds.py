"""Job kinds: ONE table of typed entries (name, spec model, run function, result model).

The API validates submissions against the spec models (a discriminated union on ``kind``), the worker runs
the run functions, the CLI builds the same specs, in-process pipelines run the same functions: everything
imports this table, and no entry is found by a string. A spec model is the stage's core config plus a
``kind: Literal[name]`` field. Stage modules are imported here (cheap); training's module, which imports
torch, is imported when a training job runs.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, create_model

from foresight.core import files
from foresight.core.bounds import BoundedConfig
from foresight.core.evaluation.campaign import run_campaign
from foresight.core.evaluation.config import CampaignConfig, DiagnosticsConfig, EvaluationConfig
from foresight.core.evaluation.conformance import ConformanceConfig, run_conformance
from foresight.core.evaluation.diagnostics import run_diagnostics
from foresight.core.evaluation.runner import run_evaluation
from foresight.core.evaluation.witness_job import WitnessConfig, run_witness
from foresight.core.jobs.pipeline.config import PipelineConfig
from foresight.core.jobs.pipeline.service import run_pipeline_job
from foresight.core.jobs.results import RESULTS
from foresight.core.jobs.simulate import SimulateConfig, run_simulate
from foresight.core.predict.ethucy import ImportDatasetConfig, ImportEthucyConfig, run_import_ethucy
from foresight.core.runtime.context import StageContext
from foresight.core.training.collect import CollectConfig, MixConfig, run_collect, run_mix
from foresight.core.training.config import TrainConfig, TrainResult
from foresight.core.training.predict_eval import PredictEvalConfig, run_predict_eval

#: a stage function: ``run(config, ctx) -> result`` (a pydantic result model, or a JSON-able dict)
Run = Callable[[Any, StageContext], Any]


@dataclass(frozen=True)
class JobKind:
    name: str
    config: type[
        BaseModel
    ]  #: the stage's core config (YAML files, CLI flags and API bodies validate into it)
    run: Run
    description: str = ""
    #: create ``ctx.workdir`` before the run (stages write into it); False: only ``ctx.artifact`` creates it
    make_workdir: bool = True
    spec: type[BaseModel] = field(init=False)  #: the config plus ``kind: Literal[name]``: the API's job spec
    result: type[BaseModel] | None = field(
        init=False
    )  #: what ``run`` returns (core.jobs.results; None: a dict)

    def __post_init__(self) -> None:
        spec = create_model(
            f"{self.name.title().replace('_', '')}Spec",
            __base__=self.config,
            kind=(Literal[self.name], self.name),
        )  # type: ignore[valid-type]
        object.__setattr__(self, "spec", spec)
        object.__setattr__(self, "result", RESULTS.get(self.name))

    def config_of(self, spec: BaseModel | dict[str, Any]) -> Any:
        """The stage config of a job spec (a spec model or its JSON)."""
        data = (
            spec.model_dump(exclude={"kind"})
            if isinstance(spec, BaseModel)
            else {k: v for k, v in spec.items() if k != "kind"}
        )
        return self.config.model_validate(data)

    def execute(self, spec: BaseModel | dict[str, Any], ctx: StageContext) -> dict[str, Any]:
        """Run a job's spec in ``ctx``; the result as JSON (what the job row and the report hold)."""
        config = self.config_of(spec)
        result = self.run(config, ctx)
        return (
            result.model_dump(mode="json", by_alias=True)
            if isinstance(result, BaseModel)
            else dict(result or {})
        )


class SleepConfig(BoundedConfig):
    """Built-in diagnostic job: sleeps in steps (reporting progress, honouring cancellation), then
    optionally writes an artifact and/or fails. ``seconds: 0`` is an empty job (queue benchmarks)."""

    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)
    seconds: float = Field(0.0, ge=0, le=3600, description="[s] total sleep")
    steps: int = Field(10, ge=1, le=10_000)
    artifact: str | None = Field(
        None, max_length=200, description="relative name of a text artifact to write"
    )
    fail: str | None = Field(
        None, max_length=2000, description="raise RuntimeError with this message at the end"
    )


def run_sleep(config: SleepConfig, ctx: StageContext) -> dict[str, Any]:
    if config.seconds > 0:
        for i in range(config.steps):
            ctx.check_cancelled()
            time.sleep(config.seconds / config.steps)
            ctx.progress((i + 1) / config.steps, f"step {i + 1}/{config.steps}")
    if config.artifact:
        files.write_text(ctx.artifact(config.artifact), f"slept {config.seconds} s\n")
    if config.fail:
        raise RuntimeError(config.fail)
    return {"slept_s": config.seconds}


def run_train(config: TrainConfig, ctx: StageContext) -> TrainResult:
    if config.executor == "ray":  # one Ray task, on a GPU node when there is one
        from foresight.core.jobs.ray_train import train_on_ray

        return train_on_ray(config, ctx)
    from foresight.core.training.train import run_train as train  # torch: imported by training jobs only

    return train(config, ctx)


def run_import_dataset(config: ImportDatasetConfig, ctx: StageContext) -> dict[str, Any]:
    """A fold of a named data root (resolved by whoever runs the job) -> a dataset and its origin."""
    root = ctx.resolve_data_root(config.root)
    record = run_import_ethucy(
        ImportEthucyConfig(root=str(root), fold=config.fold, max_agents=config.max_agents), ctx
    )
    return imported_dataset(record, {"source": config.source, "root": config.root, "fold": config.fold})


def imported_dataset(record: dict[str, Any], origin: dict[str, Any]) -> dict[str, Any]:
    """An ``import_dataset`` job's result: the written dataset's record and where it came from."""
    return {
        "dataset": record["path"],
        "sha256": record["sha256"],
        "summary": {**record["summary"], **origin},
        "outcomes": {},
        **origin,
    }


KINDS: dict[str, JobKind] = {
    k.name: k
    for k in (
        JobKind(
            "sleep",
            SleepConfig,
            run_sleep,
            "diagnostic: sleep, report progress, optionally fail",
            make_workdir=False,
        ),
        JobKind(
            "simulate",
            SimulateConfig,
            run_simulate,
            "run episodes of a scenario matrix with a simple controller",
        ),
        JobKind(
            "collect",
            CollectConfig,
            run_collect,
            "roll out episodes into a prediction dataset (base, or hard-case with a seed manifest)",
        ),
        JobKind("mix", MixConfig, run_mix, "mix a base and a hard-case dataset"),
        JobKind("train", TrainConfig, run_train, "train the trajectory predictor"),
        JobKind(
            "predict_eval",
            PredictEvalConfig,
            run_predict_eval,
            "ADE/FDE of a predictor on a dataset or ETH/UCY fold",
        ),
        JobKind("evaluate", EvaluationConfig, run_evaluation, "evaluate a planner on a scenario matrix"),
        JobKind(
            "diagnose",
            DiagnosticsConfig,
            run_diagnostics,
            "hard-seed diagnostics: trace every seed of a manifest",
        ),
        JobKind(
            "campaign", CampaignConfig, run_campaign, "checkpoints x planner-grid variants with quality gates"
        ),
        JobKind(
            "witness",
            WitnessConfig,
            run_witness,
            "which episodes (or an evaluation's failures) a robot with these limits can solve: a scripted plan that "
            "arrives, found in the simulator; optionally priced by the planner riding along",
        ),
        JobKind(
            "planner_check",
            ConformanceConfig,
            run_conformance,
            "planner conformance: commands finite and within the robot's limits, deterministic, within the decision "
            "budget, 0 and 200 pedestrians, reset leaves no state, the external protocol's error paths",
        ),
        JobKind(
            "import_dataset",
            ImportDatasetConfig,
            run_import_dataset,
            "import an ETH/UCY fold of a named data root as a dataset",
        ),
        JobKind(
            "pipeline",
            PipelineConfig,
            run_pipeline_job,
            "the runbook as child jobs: collect, hard-case collect, mix, train (proxy), register, evaluate, "
            "diagnose, campaign, gates, promote",
        ),
    )
}
