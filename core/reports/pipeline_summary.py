"""What a pipeline run reports: its stages, gate verdicts, best campaign variant (the ``pipeline_summary.json``
and the report read this), and the ``pipeline`` job's result; with the builders of its entries from stage results."""

from __future__ import annotations

from pydantic import BaseModel, Field

from foresight.core.evaluation.campaign_result import CampaignResult
from foresight.core.evaluation.gates import GateCheck, GateResult
from foresight.core.evaluation.regression import RegressionGateResult


class IncumbentRef(BaseModel):
    """The model the candidate would replace, as the pipeline resolved it when it started."""

    id: str
    sha256: str
    status: str
    why: str = ""


class StageEntry(BaseModel):
    name: str  #: e.g. collect, train, register, evaluate, diagnose, campaign, gates, promote
    status: str  #: completed | passed | failed_gate | failed | cancelled | skipped
    job_id: str | None = None
    wall_s: float | None = None
    headline: str = ""  #: one line with the stage's key numbers
    report: str | None = None  #: the stage's report page, relative to the pipeline report
    artifacts: dict[str, str] = Field(default_factory=dict)  #: label -> relative path or API URL path
    error: str | None = None


class GateEntry(BaseModel):
    name: str  #: training | evaluation | closed_loop | regression | floors | conformance
    passed: bool | None  #: None = not evaluated (its stage did not run)
    checks: list[GateCheck] = Field(default_factory=list)
    detail: str = ""


class BestVariant(BaseModel):
    variant: str
    checkpoint: str | None = None
    config_hash: str | None = None
    hard_success: float | None = None
    global_success: float | None = None
    hard_clearance: float | None = None  #: mean minimum surface gap [m]
    global_clearance: float | None = None


class PipelineSummary(BaseModel):
    name: str
    status: str  #: passed | failed_gate | failed | cancelled
    exit_code: int
    stages: list[StageEntry]
    gates: list[GateEntry] = Field(default_factory=list)
    best: BestVariant | None = None
    promoted_model: str | None = None
    promotion: str = ""  #: why the model was (not) promoted
    failing_checks: list[str] = Field(default_factory=list)  #: ``gate.check: value (threshold)`` that failed
    incumbent: IncumbentRef | None = None
    regression: RegressionGateResult | None = None  #: candidate vs incumbent: numbers, paired test, episodes
    relaxed: bool = False  #: gates relaxed on purpose: the model can never become the default
    artifacts: dict[str, str] = Field(default_factory=dict)
    code_version: str | None = None
    wall_s: float | None = None


def gate_entry(name: str, gate: GateResult | None) -> GateEntry:
    """A gate's verdict and checks (the training gate: ``TrainingSummary.gate_result()``)."""
    if gate is None:
        return GateEntry(name=name, passed=None, detail="not evaluated")
    return GateEntry(name=name, passed=gate.passed, checks=gate.checks)


def best_from_campaign(result: CampaignResult) -> BestVariant | None:
    """The ranked-first cell of a campaign result."""
    best = result.best
    if best is None:
        return None
    return BestVariant(
        variant=best.variant,
        checkpoint=best.checkpoint,
        config_hash=best.planner.config_hash,
        hard_success=best.hard.success.rate,
        global_success=best.global_.success.rate,
        hard_clearance=best.hard.mean_min_clearance.mean,
        global_clearance=best.global_.mean_min_clearance.mean,
    )


class PipelineResult(BaseModel):
    name: str
    status: str  #: passed | failed_gate
    exit_code: int  #: 0 passed, 2 a required gate failed
    passed: bool
    failed_gates: list[str]
    model_id: str | None
    promoted: bool
    promotion: str
    incumbent: IncumbentRef | None = None  #: id and sha256 of the model the candidate would replace
    failing_checks: list[str] = Field(default_factory=list)
    stages: list[StageEntry]
    summary: PipelineSummary
    report: str = "report.html"
    artifacts: dict[str, str]
    wall_s: float
