"""The pipeline's gate verdict: every gate's entry (its checks with value and threshold) and whether the candidate
may be promoted. The regression and floors gates are computed here, from the candidate's and the reference runs'
episode records (their run folders); the others are the stages' own gates."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from foresight.core.evaluation.campaign_result import CampaignResult
from foresight.core.evaluation.conformance import ConformanceResult
from foresight.core.evaluation.diagnostics import DiagnosticsResult
from foresight.core.evaluation.gates import GateCheck, GateResult
from foresight.core.evaluation.record import EpisodeRecord
from foresight.core.evaluation.regression import RegressionGateResult, floors_gate, regression_gate
from foresight.core.evaluation.runner import read_records
from foresight.core.jobs.pipeline.config import PipelineConfig
from foresight.core.jobs.pipeline.incumbent import Incumbent
from foresight.core.reports.pipeline_summary import GateEntry, gate_entry
from foresight.core.training.config import TrainResult

#: stage gates: gate name -> the stage whose result holds it
GATE_OF_STAGE = {"training": "train", "evaluation": "evaluate", "closed_loop": "campaign"}


def records_of(folders: dict[str, Path | None], stage: str) -> list[EpisodeRecord] | None:
    folder = folders.get(stage)
    path = None if folder is None else Path(folder) / "episodes.jsonl"
    return read_records(path) if path is not None and path.is_file() else None


def _hard(result: DiagnosticsResult | None) -> list[tuple[str, int, str, str | None]] | None:
    return None if result is None else [(s.scenario, s.seed, s.outcome, s.label) for s in result.seeds]


def regression(
    config: PipelineConfig,
    results: Any,
    folders: dict[str, Path | None],
    model_id: str,
    incumbent: Incumbent | None,
) -> tuple[GateResult | None, RegressionGateResult | None, str]:
    """(gate, its full result, why it did not run)."""
    if incumbent is None:
        return None, None, "no incumbent model (incumbent.model is unset or names no registered model)"
    cand, inc = records_of(folders, "evaluate"), records_of(folders, "incumbent_evaluate")
    if cand is None or inc is None:
        return None, None, "the candidate's or the incumbent's episode records are missing"
    hc, hi = results.of("diagnose", DiagnosticsResult), results.of("incumbent_diagnose", DiagnosticsResult)
    hard = None if hc is None or hi is None else (_hard(hc), _hard(hi))
    full = regression_gate(
        (model_id, cand), (incumbent.id, incumbent.sha256, inc), config.gates.regression, hard=hard
    )
    return GateResult(passed=full.passed, checks=full.checks), full, ""


def floors(
    config: PipelineConfig, results: Any, folders: dict[str, Path | None]
) -> tuple[GateResult | None, str]:
    cand, cv = records_of(folders, "evaluate"), records_of(folders, "cv_baseline")
    if cand is None or cv is None:
        return None, "constant velocity did not run on the candidate's episodes"
    train = results.of("train", TrainResult)
    ade = None if train is None else (train.val_ade, train.cv_val_ade)
    fde = None if train is None else (train.val_fde, train.cv_val_fde)
    return floors_gate(cand, cv, config.gates.floors, ade=ade, fde=fde), ""


def decide(
    config: PipelineConfig,
    results: Any,
    folders: dict[str, Path | None],
    model_id: str,
    incumbent: Incumbent | None,
) -> tuple[list[GateEntry], dict[str, Any], RegressionGateResult | None]:
    """Every gate's entry, the verdict (``passed``, ``failed``, ``promotion``) and the regression gate's result."""
    gates: dict[str, tuple[GateResult | None, str]] = {
        name: (results.gate(stage), "") for name, stage in GATE_OF_STAGE.items()
    }
    reg, full, why = regression(config, results, folders, model_id, incumbent)
    gates["regression"] = (reg, why)
    gates["floors"] = floors(config, results, folders)
    check = results.of("conformance", ConformanceResult)
    conformance = None if check is None else GateResult(passed=check.passed, checks=check.checks)
    gates["conformance"] = (conformance, "" if conformance else "the planner conformance check did not run")
    entries, failed = [], []
    for name, (gate, why) in gates.items():
        entry = gate_entry(name, gate)
        if gate is None and why:
            entry.detail = why
        required = name in config.gates.require
        if not required and entry.passed is None:
            entry.detail = (entry.detail + "; " if entry.detail else "") + "not required for promotion"
        elif (
            entry.passed is None
            and name == "closed_loop"
            and results.of("campaign", CampaignResult) is not None
        ):
            entry.detail = "the campaign has no closed-loop gate configured"
        entries.append(entry)
        # a gate that ran and failed blocks promotion whether or not it is required: a model whose gates fail is
        # never promoted; ``require`` names the gates that must also have run
        if entry.passed is False or (required and entry.passed is not True):
            failed.append(name)
    return entries, {"passed": not failed, "failed": failed, "promotion": ""}, full


def failing_checks(entries: list[GateEntry]) -> list[str]:
    """``gate.check: value vs threshold`` of every failed check (or the gate's detail when it did not run)."""
    out = []
    for e in entries:
        if e.passed is False:
            out += [f"{e.name}.{c.name}: {_v(c)}" for c in e.checks if not c.passed] or [e.name]
    return out


def _v(c: GateCheck) -> str:
    value = "-" if c.value is None else f"{c.value:.3g}"
    threshold = "" if c.threshold is None else f" (threshold {c.threshold:.3g})"
    return value + threshold
