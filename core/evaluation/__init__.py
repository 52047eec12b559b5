"""Evaluation engine: metrics, failure taxonomy, aggregates, the parallel runner, diagnostics, campaigns, gates.

Stage entry points (each ``run_<stage>(config, ctx) -> result``, exported lazily so that importing a
small module such as ``core.evaluation.stats`` does not load the simulator):
``run_evaluation(EvaluationConfig)``, ``run_diagnostics(DiagnosticsConfig)``, ``run_campaign(CampaignConfig)``.
Definitions follow the shared metrics-and-taxonomy.md.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "EvaluationConfig": "foresight.core.evaluation.config",
    "DiagnosticsConfig": "foresight.core.evaluation.config",
    "CampaignConfig": "foresight.core.evaluation.config",
    "run_evaluation": "foresight.core.evaluation.runner",
    "EvaluationResult": "foresight.core.evaluation.evaluation_result",
    "run_diagnostics": "foresight.core.evaluation.diagnostics",
    "DiagnosticsResult": "foresight.core.evaluation.diagnostics",
    "run_campaign": "foresight.core.evaluation.campaign",
    "CampaignResult": "foresight.core.evaluation.campaign_result",
}

__all__ = list(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name in _EXPORTS:
        return getattr(importlib.import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module 'foresight.core.evaluation' has no attribute {name!r}")
