"""The result model of every job kind that has one, defined once: what its run function returns, what a job's
result holds, what the reports, the pipeline and the result rows read back (validated on read, so a renamed field
is an error naming it, never a silent "?" or NULL). The job-kind table (core.stages.kinds) takes its entries'
result models from here; the runbook, which the kind table imports, reads them here too."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel

from foresight.core.evaluation.campaign import CampaignResult
from foresight.core.evaluation.diagnostics import DiagnosticsResult
from foresight.core.evaluation.runner import EvaluationResult
from foresight.core.evaluation.shards import ShardResult
from foresight.core.pipeline.summary import PipelineResult
from foresight.core.predict.collect import CollectResult
from foresight.core.predict.evaluation import PredictEvalResult
from foresight.core.predict.train_config import TrainResult
from foresight.core.stages.simulate import SimulateResult

#: stage kind -> its result model
RESULTS: dict[str, type[BaseModel]] = {
    "simulate": SimulateResult,
    "collect": CollectResult,
    "mix": CollectResult,
    "train": TrainResult,
    "predict_eval": PredictEvalResult,
    "evaluate": EvaluationResult,
    "evaluate_shard": ShardResult,
    "diagnose": DiagnosticsResult,
    "campaign": CampaignResult,
    "campaign_shard": ShardResult,
    "pipeline": PipelineResult,
}


def read_result(kind: str, data: Any) -> BaseModel:
    """A ``kind`` stage's result from its model or its JSON dict (e.g. a job row's result), validated."""
    model = RESULTS[kind]
    return data if isinstance(data, model) else model.model_validate(data)
