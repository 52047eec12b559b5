"""Quality gates: the evaluation gate and the closed-loop gate of a campaign against a baseline variant.

A gate is a machine-readable result (every check with its value and threshold). A failing gate is a
normal outcome of a stage (exit code 2, summary written), never an exception.
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

from foresight.core.evaluation.aggregate import SuiteSummary
from foresight.core.evaluation.delta import Delta
from foresight.core.evaluation.integrity import IntegrityReport
from foresight.core.evaluation.stats import ALPHA

GATE_FAILED_EXIT = 2


class GateCheck(BaseModel):
    name: str
    passed: bool
    value: float | None = None
    threshold: float | None = None
    detail: str = ""

    def line(self) -> str:
        """``name: ok (1.19 vs 0.25) detail``: the check as one readable line (3 significant digits)."""

        def num(x: float | None) -> str:
            return "-" if x is None else f"{x:.3g}"

        verdict = "ok" if self.passed else "FAIL"
        return f"{self.name}: {verdict} ({num(self.value)} vs {num(self.threshold)}) {self.detail}".rstrip()


class GateResult(BaseModel):
    passed: bool
    checks: list[GateCheck]

    @property
    def exit_code(self) -> int:
        return 0 if self.passed else GATE_FAILED_EXIT


def _result(checks: list[GateCheck]) -> GateResult:
    return GateResult(passed=all(c.passed for c in checks), checks=checks)


class EvaluationGateConfig(BaseModel):
    """Success floor and mean minimum clearance (surface gap, unlike the reference's centre distance)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    min_success_rate: float = Field(default=0.3, ge=0, le=1)  #: the reference's floor; pipelines raise it
    min_mean_clearance: float = Field(default=0.25)  #: mean over episodes of the minimum surface gap [m]


def evaluation_gate(
    summary: SuiteSummary, integrity: IntegrityReport, cfg: EvaluationGateConfig
) -> GateResult:
    success = summary.success.rate
    clearance = summary.mean_min_clearance.mean
    checks = [
        GateCheck(
            name="success_rate",
            passed=success is not None and success >= cfg.min_success_rate,
            value=success,
            threshold=cfg.min_success_rate,
        ),
        GateCheck(
            name="mean_min_clearance",
            passed=clearance is not None and clearance >= cfg.min_mean_clearance,
            value=clearance,
            threshold=cfg.min_mean_clearance,
            detail="" if clearance is not None else "no episode had pedestrians: clearance unavailable",
        ),
        GateCheck(
            name="integrity",
            passed=integrity.ok,
            value=float(len(integrity.violations)),
            threshold=0.0,
            detail="; ".join(f"{v.check} {v.scenario}#{v.seed}" for v in integrity.violations[:10]),
        ),
    ]
    return _result(checks)


class ClosedLoopGateConfig(BaseModel):
    """A campaign's candidate against a named baseline variant (deltas = candidate - baseline)."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    baseline_variant: str = Field(min_length=1)
    min_global_success_delta: float = 0.0  #: no drop in global success
    min_hard_success_delta: float = 0.0  #: no drop in hard-suite success
    max_clearance_regression: float = Field(
        default=0.1, ge=0
    )  #: allowed drop of global mean min clearance [m]
    fail_on_new_failure_labels: bool = False  #: a hard-suite failure mechanism the baseline never showed
    #: also require a significant paired success gain on this suite (McNemar, same episodes, >= MIN_PAIRS pairs)
    require_significant_gain: Literal["hard", "global"] | None = None


class TaxonomyComparison(BaseModel):
    candidate: dict[str, int]
    baseline: dict[str, int]
    delta: dict[str, int]  #: candidate - baseline per label
    new_labels: list[str]  #: labels the candidate shows and the baseline does not


def compare_taxonomy(candidate: dict[str, int], baseline: dict[str, int]) -> TaxonomyComparison:
    labels = list(dict.fromkeys([*baseline, *candidate]))
    return TaxonomyComparison(
        candidate=candidate,
        baseline=baseline,
        delta={k: candidate.get(k, 0) - baseline.get(k, 0) for k in labels},
        new_labels=[k for k in labels if candidate.get(k, 0) > 0 and baseline.get(k, 0) == 0],
    )


class ClosedLoopGateResult(GateResult):
    candidate: str
    baseline: str
    hard_taxonomy: TaxonomyComparison
    paired: dict[str, dict[str, Delta] | None] | None = (
        None  #: suite -> metric -> paired delta (candidate - baseline)
    )


def _paired_detail(paired: dict[str, dict[str, Delta] | None] | None, suite: str, metric: str) -> str:
    d = (paired or {}).get(suite) or {}
    m = d.get(metric)
    if m is None or m.p_value is None:
        return "unpaired"
    disc = f", discordant {m.discordant[0]}/{m.discordant[1]}" if m.discordant else ""
    return f"paired n={m.n_pairs}, {m.test} p={m.p_value:.3g}{disc}{', significant' if m.significant else ''}"


def closed_loop_gate(
    candidate: tuple[str, SuiteSummary, SuiteSummary],
    baseline: tuple[str, SuiteSummary, SuiteSummary],
    cfg: ClosedLoopGateConfig,
    paired: dict[str, dict[str, Delta] | None] | None = None,
) -> ClosedLoopGateResult:
    """``candidate``/``baseline``: (name, hard suite, global suite); ``paired``: their paired deltas per suite
    when both ran the same episodes (the campaign's ``vs_baseline``), reported with each check."""
    cname, chard, cglob = candidate
    bname, bhard, bglob = baseline
    dg = cglob.success_rate - bglob.success_rate
    dh = chard.success_rate - bhard.success_rate
    cc, bc = cglob.mean_min_clearance.mean, bglob.mean_min_clearance.mean
    dc = None if cc is None or bc is None else cc - bc
    tax = compare_taxonomy(chard.taxonomy, bhard.taxonomy)
    checks = [
        GateCheck(
            name="global_success_delta",
            passed=dg >= cfg.min_global_success_delta - 1e-12,
            value=dg,
            threshold=cfg.min_global_success_delta,
            detail=_paired_detail(paired, "global", "success"),
        ),
        GateCheck(
            name="hard_success_delta",
            passed=dh >= cfg.min_hard_success_delta - 1e-12,
            value=dh,
            threshold=cfg.min_hard_success_delta,
            detail=_paired_detail(paired, "hard", "success"),
        ),
        GateCheck(
            name="global_clearance_regression",
            passed=dc is None or -dc <= cfg.max_clearance_regression,
            value=None if dc is None else -dc,
            threshold=cfg.max_clearance_regression,
            detail="" if dc is not None else "clearance unavailable",
        ),
        GateCheck(
            name="hard_new_failure_labels",
            passed=not (cfg.fail_on_new_failure_labels and tax.new_labels),
            value=float(len(tax.new_labels)),
            threshold=0.0,
            detail=", ".join(tax.new_labels),
        ),
    ]
    if cfg.require_significant_gain is not None:
        gain = ((paired or {}).get(cfg.require_significant_gain) or {}).get("success")
        checks.append(
            GateCheck(
                name=f"{cfg.require_significant_gain}_significant_success_gain",
                passed=gain is not None and gain.significant and (gain.delta or 0.0) > 0,
                value=None if gain is None else gain.p_value,
                threshold=ALPHA,
                detail="no paired episodes (the candidate is the baseline, or other episodes)"
                if gain is None
                else _paired_detail(paired, cfg.require_significant_gain, "success"),
            )
        )
    base = _result(checks)
    return ClosedLoopGateResult(
        passed=base.passed,
        checks=base.checks,
        candidate=cname,
        baseline=bname,
        hard_taxonomy=tax,
        paired=paired,
    )
