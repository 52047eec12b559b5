"""The incumbent: the model a pipeline's candidate would replace, and the reference runs beside the candidate's.

The reference runs (the incumbent's evaluation and hard-seed diagnostics, constant velocity's evaluation) hold the
candidate's episodes and planner settings with another model. Their results do not depend on the candidate, so
they are cached: a child job's key is derived from (kind, spec, model sha256), the spec holding the matrix, the
seeds and the planner config, and a second pipeline against the same incumbent finds the first one's run.
"""

from __future__ import annotations

import hashlib
import json
from typing import Any, Protocol

from foresight.core.evaluation.gates import EvaluationGateConfig
from foresight.core.jobs.pipeline.config import AUTO, PipelineConfig, stage_config
from foresight.core.reports.pipeline_summary import IncumbentRef as Incumbent

DEFAULT = "default"  #: the model id that names the default model
RELAXED = "relaxed"  #: status of a model registered by a pipeline whose gates are relaxed on purpose

#: reference stage -> (kind, the candidate stage whose episodes it runs, its model)
REFERENCE_STAGES = {
    "incumbent_evaluate": ("evaluate", "evaluate", "incumbent"),
    "cv_baseline": ("evaluate", "evaluate", "cv"),
    "incumbent_diagnose": ("diagnose", "diagnose", "incumbent"),
}


class ModelRegistry(Protocol):
    """The registry as a pipeline reads it (the service's store, or an in-process run's registry file)."""

    def model_rows(self) -> list[dict[str, Any]]:
        """Every model: ``id``, ``status``, ``sha256``, ``lineage``, ``created_at``."""
        ...

    def model_row(self, ident: str) -> dict[str, Any] | None:
        """One model by id (``default``: the default model, by the registry's one rule); None if unknown."""
        ...

    def record_promotion(self, model_id: str, verdict: dict[str, Any]) -> None:
        """Keep why the model was or was not promoted with it (the registry shows it)."""
        ...


def resolve_incumbent(config: PipelineConfig, registry: ModelRegistry | None) -> Incumbent | None:
    """The model the candidate would replace (``incumbent.model``; see :class:`IncumbentSection`)."""
    want = config.incumbent.model
    if want is None or registry is None:
        return None
    if want != AUTO:
        row = registry.model_row(want)
        return None if row is None else _incumbent(row, f"named by the config ({want})")
    if config.promote.to != DEFAULT:
        same = [
            r
            for r in registry.model_rows()
            if r["status"] == "promoted" and (r.get("lineage") or {}).get("pipeline") == config.name
        ]
        if same:
            row = max(same, key=lambda r: (r.get("created_at") or 0.0, r["id"]))
            return _incumbent(row, f"the newest promoted model of pipeline {config.name}")
    row = registry.model_row(DEFAULT)
    return None if row is None else _incumbent(row, "the default model")


def _incumbent(row: dict[str, Any], why: str) -> Incumbent:
    return Incumbent(id=row["id"], sha256=row["sha256"], status=row["status"], why=why)


def reference_spec(
    config: PipelineConfig, stage: str, inputs: dict[str, str], incumbent: Incumbent | None
) -> dict[str, Any] | None:
    """The spec of a reference stage: its candidate stage's spec with the other model (None: not applicable)."""
    kind, of, which = REFERENCE_STAGES[stage]
    spec = stage_config(config, of, inputs).model_dump(mode="json")
    if spec["planner"]["name"] != "predictive":
        return None  # no model to swap: the candidate's run is its own reference
    if which == "incumbent":
        if incumbent is None:
            return None
        spec["planner"]["model"] = incumbent.id
        if config.incumbent.planner_config is not None:
            spec["planner"]["config"] = config.incumbent.planner_config
    else:
        spec["planner"]["model"] = "cv"
    if kind == "evaluate":
        spec["gate"] = EvaluationGateConfig().model_dump(mode="json")  # a reference is measured, not gated
    else:
        spec["render"] = False
    return spec


def cache_key(stage: str, kind: str, spec: dict[str, Any], model_sha256: str | None) -> str:
    """Idempotency key of a reference run: the same (kind, spec, model bytes) is the same run, in any pipeline.
    Ends in ``:<stage>`` like a pipeline child's own key, so listings name the stage."""
    body = json.dumps({"kind": kind, "spec": spec, "model": model_sha256}, sort_keys=True)
    return f"reference:{hashlib.sha256(body.encode()).hexdigest()[:32]}:{stage}"
