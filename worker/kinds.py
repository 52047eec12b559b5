"""Job kinds: each maps a kind name to its spec model and its runner.

A spec model is a pydantic model with a ``kind: Literal[...]`` field (the API's discriminated union is built
from this table). A runner is ``run(spec, ctx: StageContext) -> dict`` (a JSON-able result summary);
artifacts are whatever it writes under ``ctx.workdir``; an optional recorder stores result rows. Adding a kind is one :func:`register` call; the
stage kinds are registered as their core modules exist (core imports stay inside the runners).
"""

from __future__ import annotations

import importlib
import importlib.util
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, create_model

from foresight.core.stages.context import StageContext
from foresight.store import records
from foresight.store.records import Recorder


@dataclass(frozen=True)
class JobKind:
    name: str
    spec: type[BaseModel]
    run: Callable[[Any, StageContext], dict[str, Any]]
    description: str = ""
    #: writes the result's records (datasets, evaluations, ...) in the transaction that finishes the job
    record: Recorder | None = None
    #: create ``ctx.workdir`` before the run (stages write into it); False: only ``ctx.artifact`` creates it
    make_workdir: bool = True


KINDS: dict[str, JobKind] = {}


def register(kind: JobKind) -> JobKind:
    KINDS[kind.name] = kind
    return kind


class SpecBase(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class SleepSpec(SpecBase):
    """Built-in diagnostic job: sleeps in steps (reporting progress, honouring cancellation), then
    optionally writes an artifact and/or fails. ``seconds: 0`` is an empty job (queue benchmarks)."""

    kind: Literal["sleep"] = "sleep"
    seconds: float = Field(0.0, ge=0, le=3600, description="[s] total sleep")
    steps: int = Field(10, ge=1, le=10_000)
    artifact: str | None = Field(None, max_length=200, description="relative name of a text artifact to write")
    fail: str | None = Field(None, max_length=2000, description="raise RuntimeError with this message at the end")


def run_sleep(spec: SleepSpec, ctx: StageContext) -> dict[str, Any]:
    if spec.seconds > 0:
        for i in range(spec.steps):
            ctx.check_cancelled()
            time.sleep(spec.seconds / spec.steps)
            ctx.progress((i + 1) / spec.steps, f"step {i + 1}/{spec.steps}")
    if spec.artifact:
        path = ctx.artifact(spec.artifact)
        path.write_text(f"slept {spec.seconds} s\n")
    if spec.fail:
        raise RuntimeError(spec.fail)
    return {"slept_s": spec.seconds}


register(JobKind("sleep", SleepSpec, run_sleep, "diagnostic: sleep, report progress, optionally fail", make_workdir=False))


def _stage_kind(
    name: str, config_ref: str, stage_ref: str, description: str, record: Recorder | None = None,
    sharded: bool = False,
) -> None:
    """Register the core stage ``stage_ref`` ("module:function") with its config ``config_ref`` as a kind.

    Only the config's module is imported here (the API needs the spec model); the stage's module (which may
    import torch) is imported when a worker runs the job. Stages that have not landed are skipped.
    ``sharded``: a config with ``shards`` > 1 runs as shard jobs and their merge (worker/shards.py).
    """
    config_module, config_name = config_ref.split(":")
    stage_module, stage_name = stage_ref.split(":")
    try:
        config_model = getattr(importlib.import_module(config_module), config_name, None)
        stage_found = importlib.util.find_spec(stage_module) is not None
    except ModuleNotFoundError as exc:
        if exc.name and config_module.startswith(exc.name):
            return
        raise
    if config_model is None or not stage_found:
        return
    spec = create_model(
        f"{name.title().replace('_', '')}Spec", __base__=config_model, kind=(Literal[name], name)  # type: ignore[valid-type]
    )

    def run(spec_obj: BaseModel, ctx: StageContext) -> dict[str, Any]:
        config_obj = config_model.model_validate(spec_obj.model_dump(exclude={"kind"}))
        if sharded and getattr(config_obj, "shards", 1) > 1:
            result = importlib.import_module("foresight.worker.shards").run_sharded(name, config_obj, ctx)
        else:
            result = getattr(importlib.import_module(stage_module), stage_name)(config_obj, ctx)
        return result.model_dump(mode="json", by_alias=True) if isinstance(result, BaseModel) else dict(result or {})

    register(JobKind(name, spec, run, description, record))


_stage_kind("simulate", "foresight.core.stages.simulate:SimulateConfig", "foresight.core.stages.simulate:run_simulate",
            "run episodes of a scenario matrix with a simple controller")
_stage_kind("collect", "foresight.core.predict.collect:CollectConfig", "foresight.core.predict.collect:run_collect",
            "roll out episodes into a prediction dataset (base, or hard-case with a seed manifest)", records.dataset)
_stage_kind("mix", "foresight.core.predict.collect:MixConfig", "foresight.core.predict.collect:run_mix",
            "mix a base and a hard-case dataset", records.dataset)
_stage_kind("train", "foresight.core.predict.train_config:TrainConfig", "foresight.core.predict.nn.train:run_train",
            "train the trajectory predictor")
_stage_kind("predict_eval", "foresight.core.predict.evaluation:PredictEvalConfig", "foresight.core.predict.evaluation:run_predict_eval",
            "ADE/FDE of a predictor on a dataset or ETH/UCY fold")
_stage_kind("evaluate", "foresight.core.evaluation.config:EvaluationConfig", "foresight.core.evaluation.runner:run_evaluation",
            "evaluate a planner on a scenario matrix", records.evaluation, sharded=True)
_stage_kind("evaluate_shard", "foresight.core.evaluation.config:EvaluationShardConfig",
            "foresight.core.evaluation.shards:run_evaluation_shard",
            "one shard of an evaluation with shards > 1 (submitted by its parent evaluate job)")
_stage_kind("diagnose", "foresight.core.evaluation.config:DiagnosticsConfig", "foresight.core.evaluation.diagnostics:run_diagnostics",
            "hard-seed diagnostics: trace every seed of a manifest")
_stage_kind("campaign", "foresight.core.evaluation.config:CampaignConfig", "foresight.core.evaluation.campaign:run_campaign",
            "checkpoints x planner-grid variants with quality gates", records.campaign, sharded=True)
_stage_kind("campaign_shard", "foresight.core.evaluation.config:CampaignShardConfig", "foresight.core.evaluation.shards:run_campaign_shard",
            "one shard of a campaign with shards > 1 (submitted by its parent campaign job)")


def _import_dataset_kind() -> None:
    """``import_dataset``: a fold of a named data root (``FORESIGHT_DATA_ROOTS``) -> a dataset record.

    The root name is checked at submission against the settings read from the environment (the discriminated
    union validating a spec has no app object to ask; the environment is every process's settings source),
    and resolved again by the worker that runs the job.
    """
    from pydantic import field_validator

    from foresight.core.predict.ethucy import ImportDatasetConfig
    from foresight.store.settings import Settings

    class ImportDatasetSpec(ImportDatasetConfig):
        kind: Literal["import_dataset"] = "import_dataset"

        @field_validator("root")
        @classmethod
        def _known_root(cls, value: str) -> str:
            try:
                Settings().data_root(value)
            except LookupError as exc:  # a 422 naming the field, the name and the known roots
                raise ValueError(str(exc)) from None
            return value

    def run(spec: ImportDatasetSpec, ctx: StageContext) -> dict[str, Any]:
        from foresight.core.predict.ethucy import ImportEthucyConfig, run_import_ethucy

        root = ctx.resolve_data_root(spec.root)  # the running worker's own settings
        record = run_import_ethucy(ImportEthucyConfig(root=str(root), fold=spec.fold, max_agents=spec.max_agents), ctx)
        origin = {"source": spec.source, "root": spec.root, "fold": spec.fold}
        return {"dataset": record["path"], "sha256": record["sha256"], "summary": {**record["summary"], **origin},
                "outcomes": {}, **origin}

    register(JobKind("import_dataset", ImportDatasetSpec, run, "import an ETH/UCY fold of a named data root as a dataset",
                     records.dataset))


_import_dataset_kind()
register(JobKind("pipeline", **importlib.import_module("foresight.worker.pipeline").KIND_FIELDS))  # the runbook as child jobs
