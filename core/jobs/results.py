"""The result model of every job kind that has one, defined once: what its run function returns, what a job's
result holds, what the reports, the pipeline and the result rows read back (validated on read, so a renamed field
is an error naming it, never a silent "?" or NULL). The job-kind table (core.jobs.kinds) takes its entries'
result models from here; the runbook, which the kind table imports, reads them here too."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ValidationError

from foresight.core.evaluation.campaign_result import CampaignResult
from foresight.core.evaluation.conformance import ConformanceResult
from foresight.core.evaluation.diagnostics import DiagnosticsResult
from foresight.core.evaluation.evaluation_result import EvaluationResult
from foresight.core.evaluation.witness_job import WitnessResult
from foresight.core.jobs.simulate import SimulateResult
from foresight.core.reports.pipeline_summary import PipelineResult
from foresight.core.runtime.execution import Execution
from foresight.core.runtime.verdict import Verdict
from foresight.core.training.collect import CollectResult
from foresight.core.training.config import TrainResult
from foresight.core.training.predict_eval import PredictEvalResult

#: stage kind -> its result model
RESULTS: dict[str, type[BaseModel]] = {
    "simulate": SimulateResult,
    "collect": CollectResult,
    "mix": CollectResult,
    "train": TrainResult,
    "predict_eval": PredictEvalResult,
    "evaluate": EvaluationResult,
    "diagnose": DiagnosticsResult,
    "campaign": CampaignResult,
    "pipeline": PipelineResult,
    "witness": WitnessResult,
    "planner_check": ConformanceResult,
}


def read_result(kind: str, data: Any) -> BaseModel:
    """A ``kind`` stage's result from its model or its JSON dict (e.g. a job row's result), validated."""
    model = RESULTS[kind]
    return data if isinstance(data, model) else model.model_validate(data)


def typed_result(kind: str, data: Any) -> BaseModel | None:
    """A job row's result as its kind's model; None where the kind has none, the job has no result, or the result
    is not this version's model (an old row): readers that only display something skip it rather than fail."""
    if kind not in RESULTS or data is None:
        return None
    try:
        return read_result(kind, data)
    except ValidationError:
        return None


def verdict(kind: str, data: Any) -> Verdict | None:
    """The gate/integrity verdict of a ``kind`` job's result (None: the kind has no gate, none was configured, or
    the result is not this version's model). One rule for the API's job status, the dashboard's badges and the
    CLI's exit codes (2 for a failed verdict, as ``foresight evaluate`` exits)."""
    result = typed_result(kind, data)
    if isinstance(result, TrainResult):
        return "passed" if result.gates_passed else "failed_gate"
    if isinstance(result, EvaluationResult):
        return result.status
    if isinstance(result, ConformanceResult):
        return "passed" if result.passed else "failed_gate"
    if isinstance(result, CampaignResult | PipelineResult):
        return (
            None if result.status == "completed" else "passed" if result.status == "passed" else "failed_gate"
        )
    return None


def planner_and_model(kind: str, data: Any) -> tuple[str | None, str | None]:
    """(planner name, model id) a result was produced with, for result tables (None where the kind has none)."""
    result = typed_result(kind, data)
    if isinstance(result, EvaluationResult | DiagnosticsResult):
        return result.planner.name, result.planner.model_id
    if isinstance(result, CampaignResult) and result.best is not None:
        best = result.best.planner
        return f"{best.name} ({result.best.variant})", best.model_id
    if isinstance(result, PipelineResult):
        return None, result.model_id
    return None, None


def execution_of(kind: str, data: Any) -> Execution | None:
    """Which executor ran a ``kind`` job's episodes and on how many CPUs (None: the kind runs no episodes, or the
    result predates the record)."""
    if kind not in RESULTS or data is None:
        return None
    try:
        result = read_result(kind, data)
    except ValidationError:
        return None
    if isinstance(result, EvaluationResult | CampaignResult | DiagnosticsResult | CollectResult):
        return result.execution
    return None
