"""Job kinds: each maps a kind name to its spec model and its runner.

A spec model is a pydantic model with a ``kind: Literal[...]`` field (the API's discriminated union is built
from this table). A runner is ``run(spec, ctx: StageContext) -> dict`` (a JSON-able result summary);
artifacts are whatever it writes under ``ctx.workdir``. Adding a kind is one :func:`register` call; the
stage kinds are registered as their core modules exist (core imports stay inside the runners).
"""

from __future__ import annotations

import importlib
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, create_model

from core.stages.context import StageContext


@dataclass(frozen=True)
class JobKind:
    name: str
    spec: type[BaseModel]
    run: Callable[[Any, StageContext], dict[str, Any]]
    description: str = ""


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


register(JobKind("sleep", SleepSpec, run_sleep, "diagnostic: sleep, report progress, optionally fail"))


def _stage_kind(name: str, module: str, config: str, function: str, description: str) -> None:
    """Register a core stage ``module.function(config, ctx)`` as a kind, when that module exists."""
    try:
        mod = importlib.import_module(module)
    except ModuleNotFoundError as exc:
        if exc.name and module.startswith(exc.name):
            return  # that stage has not landed yet
        raise
    config_model, stage = getattr(mod, config, None), getattr(mod, function, None)
    if config_model is None or stage is None:
        return  # the module exists but its stage entry point has not landed yet
    spec = create_model(
        f"{name.title().replace('_', '')}Spec", __base__=config_model, kind=(Literal[name], name)  # type: ignore[valid-type]
    )

    def run(spec_obj: BaseModel, ctx: StageContext) -> dict[str, Any]:
        config_obj = config_model.model_validate(spec_obj.model_dump(exclude={"kind"}))
        result = stage(config_obj, ctx)
        return result.model_dump(mode="json") if isinstance(result, BaseModel) else dict(result or {})

    register(JobKind(name, spec, run, description))


_stage_kind("evaluate", "core.evaluation", "EvaluationConfig", "run_evaluation", "evaluate a planner on a bundle")
_stage_kind("simulate", "core.stages.simulate", "SimulateConfig", "run_simulate", "run episodes of a scenario matrix")
