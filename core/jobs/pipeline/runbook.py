"""The seed runbook as one stage function: ``run_pipeline(config, ctx, run_child)``.

The graph (each arrow names what flows into the next stage)::

    collect ──base dataset──┐
    hardcase (TRAINING seeds) ──hard-case dataset──> mix ──mixed dataset──> train (proxy on TRAINING seeds)
    train ──checkpoint──> register (status candidate) ──model id──> evaluate, diagnose (EVALUATION seeds),
    campaign (candidate x planner grid on the EVALUATION seeds + the global suite)
    train, evaluate, campaign ──gate results──> gates ──verdict──> promote (only when the required gates pass)

Core stays database-free: ``run_child(stage, kind, spec, progress)`` is the caller's. It runs one stage
(the worker: a child job row it claims and runs itself; ``--local``: the stage function in a sub-folder)
and returns a :class:`ChildRun` (or the bare result); a stage's result is validated here as its kind's
result model (core.jobs.results). A caller that already holds a succeeded run of
that stage returns it again without running it: that is how a pipeline resumes from its failed stage.
``kind`` is a job kind (collect, mix, train, evaluate, diagnose, campaign) or one of the registry actions
``register`` and ``promote``. ``progress(fraction, message)`` maps the child's progress into the pipeline's.

The performance summary (``report.md``/``report.html`` + ``pipeline_summary.json``) is written after the
last stage that ran, also when a gate failed (the result then carries exit code 2) and when a stage failed
or was cancelled (the summary is written, then the error propagates so the job fails and can be retried).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

from pydantic import BaseModel

from foresight.core import files
from foresight.core.errors import ConfigError, CoreError
from foresight.core.evaluation.campaign_result import CampaignResult
from foresight.core.evaluation.conformance import ConformanceResult
from foresight.core.evaluation.evaluation_result import EvaluationResult
from foresight.core.evaluation.gates import GATE_FAILED_EXIT, GateResult
from foresight.core.jobs.pipeline.config import PipelineConfig, stage_config
from foresight.core.jobs.pipeline.decide import decide, failing_checks
from foresight.core.jobs.pipeline.incumbent import (
    REFERENCE_STAGES,
    RELAXED,
    ModelRegistry,
    cache_key,
    reference_spec,
    resolve_incumbent,
)
from foresight.core.jobs.results import RESULTS, read_result
from foresight.core.reports.pipeline import headline, write_pipeline_report
from foresight.core.reports.pipeline_summary import (
    PipelineResult,
    PipelineSummary,
    StageEntry,
    best_from_campaign,
)
from foresight.core.runtime.context import Cancelled, StageContext
from foresight.core.training.config import TrainingSummary, TrainResult

M = TypeVar("M", bound=BaseModel)

#: (stage name, kind) in run order; gates is decided here, register/promote are registry actions; the reference
#: runs (core.jobs.pipeline.incumbent.REFERENCE_STAGES) hold the candidate's episodes with the incumbent or constant velocity
RUNBOOK: list[tuple[str, str]] = [
    ("collect", "collect"),
    ("hardcase", "collect"),
    ("mix", "mix"),
    ("train", "train"),
    ("register", "register"),
    ("conformance", "planner_check"),
    ("evaluate", "evaluate"),
    ("incumbent_evaluate", "evaluate"),
    ("cv_baseline", "evaluate"),
    ("diagnose", "diagnose"),
    ("incumbent_diagnose", "diagnose"),
    ("campaign", "campaign"),
    ("gates", "gates"),
    ("promote", "promote"),
]
#: relative effort of each stage, for the overall progress bar
WEIGHT = {
    "collect": 1,
    "hardcase": 0.5,
    "mix": 0.1,
    "train": 3,
    "register": 0.05,
    "conformance": 0.3,
    "evaluate": 2,
    "incumbent_evaluate": 2,
    "cv_baseline": 2,
    "diagnose": 1,
    "incumbent_diagnose": 1,
    "campaign": 4,
    "gates": 0.01,
    "promote": 0.05,
}


@dataclass
class ChildRun:
    """What a caller's ``run_child`` hands back for one stage."""

    result: Any  #: the stage's result model (its JSON dict is validated by run_pipeline); registry actions: a dict
    ident: str | None = None  #: how later stages name this output (dataset id, model id); default: job_id
    job_id: str | None = None
    wall_s: float | None = None
    resumed: bool = False  #: True: an earlier run's result, not run again
    report: str | None = None  #: link to the stage's report page
    artifacts: dict[str, str] = field(default_factory=dict)  #: label -> link
    folder: Path | None = None  #: the stage's run folder, where this process can read it (episodes.jsonl)


#: ``run_child(stage, kind, spec, progress, cache_key=None)``: ``cache_key`` names a run any pipeline may share
RunChild = Callable[..., "ChildRun | BaseModel | dict[str, Any]"]


class StageFailed(CoreError):
    """A pipeline stage failed; the summary was written, and a retry resumes from this stage."""


def _selection_text(config: PipelineConfig) -> str:
    return (
        f"training seeds {config.training_seeds}, evaluation seeds {config.evaluation_seeds} "
        f"(matrix {config.matrix} in bundle {config.bundle})"
    )


def check_seed_separation(config: PipelineConfig, ctx: StageContext) -> dict[str, int]:
    """Refuse a config whose TRAINING hard seeds, or whose model-selection suite (``selection``), meet the
    EVALUATION hard seeds or any seed the evaluate stage or the campaign's global suite runs, or whose
    selection suite holds one of its own matrix's (evaluation) seeds; returns the episode counts of the suites."""
    from foresight.core.evaluation.config import EpisodeSelection
    from foresight.core.evaluation.runner import load_selection
    from foresight.core.training.proxy import ProxySpec, check_training_seeds

    where = {"bundle": config.bundle, "matrix": config.matrix}
    _, _, train = load_selection(EpisodeSelection(**where, seed_manifest=config.training_seeds), ctx)
    _, _, hard = load_selection(EpisodeSelection(**where, seed_manifest=config.evaluation_seeds), ctx)
    ev = config.evaluate
    _, _, glob = load_selection(
        EpisodeSelection(
            **where,
            scenarios=ev.scenarios,
            seeds_per_scenario=ev.seeds_per_scenario,
            seed_manifest=ev.seed_manifest,
        ),
        ctx,
    )
    cp = config.campaign
    _, _, camp = load_selection(
        EpisodeSelection(**where, scenarios=cp.scenarios, seeds_per_scenario=cp.seeds_per_scenario), ctx
    )
    sel = config.selection
    selection = (
        []
        if sel is None
        else check_training_seeds(
            ProxySpec(bundle=config.bundle, matrix=sel.matrix, seed_manifest=sel.seeds), ctx
        )
    )
    for item, what, mine in (
        ("training_seeds", "training hard seeds", train),
        ("selection", "selection seeds", selection),
    ):
        for label, pairs in (("evaluation_seeds", hard), ("evaluate", glob), ("campaign global suite", camp)):
            shared = sorted(set(mine) & set(pairs))
            if shared:
                raise ConfigError(
                    f"{what} overlap the {label} episodes: {shared[:5]}"
                    + (f" (+{len(shared) - 5} more)" if len(shared) > 5 else ""),
                    source="pipeline",
                    item=item,
                )
    return {
        "training_seeds": len(train),
        "evaluation_seeds": len(hard),
        "evaluate": len(glob),
        "campaign_global": len(camp),
        "selection": len(selection),
    }


@dataclass
class StageResults:
    """The typed results of the stages run so far (and the training summary the train result names)."""

    by_stage: dict[str, BaseModel] = field(default_factory=dict)
    training: TrainingSummary | None = None

    def of(self, stage: str, model: type[M]) -> M | None:
        result = self.by_stage.get(stage)
        return result if isinstance(result, model) else None

    def gate(self, stage: str) -> GateResult | None:
        """A stage's gate (training: the summary's, or the bare verdict when the summary is unavailable)."""
        if stage == "train":
            train = self.of("train", TrainResult)
            if self.training is not None:
                return self.training.gate_result()
            return None if train is None else GateResult(passed=train.gates_passed, checks=[])
        result = self.of(stage, EvaluationResult) or self.of(stage, CampaignResult)
        return None if result is None else result.gate


def run_pipeline(
    config: PipelineConfig,
    ctx: StageContext,
    run_child: RunChild,
    *,
    run_id: str = "local",
    registry: ModelRegistry | None = None,
) -> PipelineResult:
    """Run (or resume) every stage through ``run_child``; write the summary; return the verdict.

    ``run_id`` names this run (the worker passes the pipeline job's id): the candidate model is
    ``<name>-<run_id[:8]>`` unless ``register.model_id`` is set. ``registry`` resolves the incumbent (None: no
    incumbent, so a required regression gate fails).
    """
    t0 = time.perf_counter()
    stages = [
        (s, k)
        for s, k in RUNBOOK
        if not (config.hardcase is None and s in ("hardcase", "mix"))
        and not (config.diagnose is None and s in ("diagnose", "incumbent_diagnose"))
        and not (config.conformance is None and s == "conformance")
    ]
    total = sum(WEIGHT[s] for s, _ in stages)
    done_weight = 0.0
    entries: dict[str, StageEntry] = {s: StageEntry(name=s, status="pending") for s, _ in stages}
    results = StageResults()
    inputs: dict[str, str] = {}
    model_id = config.registration.model_id or f"{config.name}-{run_id[:8]}"
    gates: list[Any] = []
    verdict: dict[str, Any] = {"passed": None, "failed": [], "promotion": ""}
    promoted = False
    regression: Any = None
    folders: dict[str, Path | None] = {}
    incumbent = resolve_incumbent(config, registry)
    if incumbent is not None:
        inputs["incumbent"] = incumbent.id
    ctx.log(
        f"incumbent: {incumbent.id} ({incumbent.why}, sha256 {incumbent.sha256[:12]})"
        if incumbent
        else "incumbent: none (the regression gate cannot run)"
    )
    ctx.log(f"pipeline {config.name}: {_selection_text(config)}")
    sizes = check_seed_separation(config, ctx)
    ctx.log("episodes: " + ", ".join(f"{k} {v}" for k, v in sizes.items()))

    def summary(status: str, exit_code: int) -> PipelineSummary:
        campaign = results.of("campaign", CampaignResult)
        best = best_from_campaign(campaign) if campaign is not None else None
        for entry in entries.values():
            if entry.status == "pending":
                entry.status = "skipped"
        return PipelineSummary(
            name=config.name,
            status=status,
            exit_code=exit_code,
            stages=list(entries.values()),
            gates=gates,
            best=best,
            promoted_model=model_id if promoted else None,
            promotion=verdict["promotion"],
            failing_checks=failing_checks(gates),
            incumbent=incumbent,
            regression=regression,
            relaxed=config.gates.relaxed,
            artifacts={"summary (JSON)": "pipeline_summary.json", "config": "pipeline_config.json"},
            code_version=_code_version(),
            wall_s=time.perf_counter() - t0,
        )

    def publish(s: PipelineSummary) -> None:
        files.write_text(ctx.artifact("pipeline_summary.json"), s.model_dump_json(indent=2))
        try:
            write_pipeline_report(
                s, ctx.workdir, campaign=results.of("campaign", CampaignResult), training=results.training
            )
        except Exception as exc:  # a report is a by-product: never hide the pipeline's own outcome
            ctx.log(f"pipeline report failed: {exc!r}")

    files.write_text(ctx.artifact("pipeline_config.json"), config.model_dump_json(indent=2))
    for stage, kind in stages:
        entry = entries[stage]
        span = WEIGHT[stage] / total
        base = done_weight / total

        def progress(
            fraction: float, message: str, base: float = base, span: float = span, stage: str = stage
        ) -> None:
            ctx.progress(min(base + span * max(0.0, min(1.0, fraction)), 0.999), f"{stage}: {message}")

        try:
            ctx.check_cancelled()
            progress(0.0, "starting")
            if stage == "gates":
                t = time.perf_counter()
                gates, verdict, regression = decide(config, results, folders, model_id, incumbent)
                if regression is not None:
                    regression.candidate_run = entries["evaluate"].job_id
                    regression.incumbent_run = entries["incumbent_evaluate"].job_id
                entry.status = "passed" if verdict["passed"] else "failed_gate"
                entry.wall_s = time.perf_counter() - t
                entry.headline = (
                    "all required gates passed"
                    if verdict["passed"]
                    else "failed: " + ", ".join(verdict["failed"])
                )
            elif stage == "promote":
                if config.gates.relaxed:
                    entry.status = "skipped"
                    entry.headline = f"{model_id} stays {RELAXED}: never promoted"
                    verdict["promotion"] = (
                        f"`{model_id}` is registered as {RELAXED}: this pipeline's gates are relaxed on purpose "
                        "(gates.relaxed), so its model can never be promoted or become the default."
                    )
                elif not verdict["passed"]:
                    entry.status = "skipped"
                    entry.headline = f"{model_id} stays a candidate"
                else:
                    run = _as_run(
                        run_child(stage, kind, {"model_id": model_id, "to": config.promote.to}, progress),
                        kind,
                    )
                    _fill(entry, run, kind)
                    promoted = True
                    entry.status = "completed"
                    entry.headline = f"{model_id} -> {config.promote.to}"
                    verdict["promotion"] = (
                        f"Promoted `{model_id}` to {config.promote.to}: every required gate "
                        f"({', '.join(config.gates.require) or 'none'}) passed."
                    )
            elif stage in REFERENCE_STAGES:
                spec = reference_spec(config, stage, inputs | {"model": model_id}, incumbent)
                if spec is None:
                    entry.status = "skipped"
                    entry.headline = "no incumbent" if incumbent is None else "the planner takes no model"
                else:
                    sha = (
                        incumbent.sha256 if incumbent is not None and stage.startswith("incumbent") else None
                    )
                    key = cache_key(stage, kind, spec, sha)
                    run = _as_run(run_child(stage, kind, spec, progress, cache_key=key), kind)
                    _fill(entry, run, kind)
                    results.by_stage[stage] = run.result
                    folders[stage] = run.folder
                    entry.status = "completed"
            else:
                spec = _spec(config, stage, inputs, results, model_id)
                run = _as_run(run_child(stage, kind, spec, progress), kind)
                _fill(entry, run, kind)
                folders[stage] = run.folder
                if kind in RESULTS:
                    results.by_stage[stage] = run.result
                if kind in ("collect", "mix"):
                    inputs[{"collect": "base", "hardcase": "hardcase", "mix": "mixed"}[stage]] = (
                        run.ident or run.job_id or ""
                    )
                elif stage == "train":
                    results.training = _training_summary(run.result, run.folder)
                elif stage == "register":
                    inputs["model"] = run.ident or model_id
                    model_id = inputs["model"]
                    entry.headline = f"{model_id} registered as candidate"
                entry.status = _status(run.result)
        except Cancelled:
            entry.status = "cancelled"
            publish(summary("cancelled", 1))
            raise
        except Exception as exc:
            entry.status, entry.error = "failed", f"{type(exc).__name__}: {exc}"[:500]
            publish(summary("failed", 1))
            raise StageFailed(f"pipeline {config.name}: stage {stage} failed: {exc}") from exc
        done_weight += WEIGHT[stage]
        progress(1.0, entry.status)

    passed = bool(verdict["passed"])
    exit_code = 0 if passed else GATE_FAILED_EXIT
    if not passed and not verdict["promotion"]:
        verdict["promotion"] = (
            f"`{model_id}` stays a candidate: required gate(s) failed ({', '.join(verdict['failed'])})."
        )
    s = summary("passed" if passed else "failed_gate", exit_code)
    publish(s)
    if registry is not None and inputs.get("model"):
        registry.record_promotion(inputs["model"], promotion_record(s, promoted))
    ctx.progress(1.0, f"{s.status}: " + ("promoted " + model_id if promoted else "not promoted"))
    return PipelineResult(
        name=config.name,
        status=s.status,
        exit_code=exit_code,
        passed=passed,
        failed_gates=verdict["failed"],
        model_id=inputs.get("model"),
        promoted=promoted,
        promotion=verdict["promotion"],
        incumbent=incumbent,
        failing_checks=s.failing_checks,
        stages=s.stages,
        summary=s,
        artifacts={"report": "report.html", "markdown": "report.md", "summary": "pipeline_summary.json"},
        wall_s=time.perf_counter() - t0,
    )


def _spec(
    config: PipelineConfig, stage: str, inputs: dict[str, str], results: StageResults, model_id: str
) -> dict[str, Any]:
    if stage == "register":
        train = results.of("train", TrainResult)
        assert train is not None, "register runs after train"
        summary = results.training
        return {
            "model_id": model_id,
            "status": RELAXED if config.gates.relaxed else "candidate",
            "train_stage": "train",
            "tags": list(dict.fromkeys([*config.registration.tags, "pipeline", config.name])),
            "lineage": {
                "pipeline": config.name,
                "datasets": {k: v for k, v in inputs.items() if k != "model"},
                "training_seeds": config.training_seeds,
                "dataset": summary.dataset if summary else None,
            },
            "training": {
                "best_epoch": train.best_epoch,
                "selection_mode": train.selection_mode,
                "config": summary.config if summary else None,
            },
            "metrics": train.model_dump(
                include={"val_ade", "val_fde", "cv_val_ade", "cv_val_fde", "gates_passed"}
            ),
        }
    return stage_config(config, stage, {**inputs, "model": inputs.get("model", model_id)}).model_dump(
        mode="json"
    )


def promotion_record(s: PipelineSummary, promoted: bool) -> dict[str, Any]:
    """What the registry keeps with the candidate: promoted or not, why, each failed check, the incumbent."""
    return {
        "promoted": promoted,
        "status": s.status,
        "why": s.promotion.replace("`", ""),
        "failing_checks": s.failing_checks,
        "gates": {g.name: g.passed for g in s.gates},
        "incumbent": None if s.incumbent is None else {"id": s.incumbent.id, "sha256": s.incumbent.sha256},
    }


def _status(result: Any) -> str:
    if isinstance(result, TrainResult):
        return "completed" if result.gates_passed else "failed_gate"
    if isinstance(result, EvaluationResult):
        return "failed_gate" if result.status == "failed_integrity" else result.status
    if isinstance(result, CampaignResult):
        return result.status
    if isinstance(result, ConformanceResult):
        return "passed" if result.passed else "failed_gate"
    return "completed"


def _fill(entry: StageEntry, run: ChildRun, kind: str) -> None:
    entry.job_id, entry.wall_s, entry.report = run.job_id, run.wall_s, run.report
    entry.artifacts = dict(run.artifacts)
    entry.headline = headline(kind, run.result) + (" (resumed)" if run.resumed else "")


def _as_run(value: ChildRun | BaseModel | dict[str, Any], kind: str) -> ChildRun:
    """The caller's answer as a ChildRun whose result is validated as the kind's result model."""
    run = value if isinstance(value, ChildRun) else ChildRun(result=value)
    if kind in RESULTS:
        run.result = read_result(kind, run.result)
    return run


def _training_summary(train: TrainResult, folder: Path | None = None) -> TrainingSummary | None:
    """The summary file a train result names, else the one in the stage's folder (a worker writes an attempt's files
    in an attempt folder, then moves them into the job's folder); None when this process cannot read it."""
    path = Path(train.summary)
    if not path.is_file() and folder is not None:
        path = Path(folder) / path.name
    return TrainingSummary.model_validate_json(path.read_text()) if path.is_file() else None


def _code_version() -> str | None:
    try:
        from foresight.core.version import code_version

        return code_version()
    except Exception:  # noqa: BLE001 - provenance only
        return None
