"""Pipeline performance summary: stage status, gate results, the best campaign variant (hard and global
success, clearance), the promoted model and links to every stage's artifacts.

Written by the pipeline runner after the last stage that ran, also when a gate failed (exit code 2) or a
stage crashed: a failed run is exactly when a person needs the summary. Its input is the
:class:`~foresight.core.reports.pipeline_summary.PipelineSummary`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pydantic import BaseModel

from foresight.core.evaluation.campaign_result import CampaignResult
from foresight.core.evaluation.conformance import ConformanceResult
from foresight.core.evaluation.diagnostics import DiagnosticsResult
from foresight.core.evaluation.evaluation_result import EvaluationResult
from foresight.core.reports.campaign import ranking_figure
from foresight.core.reports.common import figure_path, fmt, gate_rows, pct, publish, read, verdict
from foresight.core.reports.document import Document
from foresight.core.reports.pipeline_summary import PipelineResult, PipelineSummary, best_from_campaign
from foresight.core.reports.training import curves
from foresight.core.training.collect import CollectResult
from foresight.core.training.config import TrainingSummary, TrainResult


def headline(kind: str, result: BaseModel | None) -> str:
    """One line of a stage result's key numbers, for :attr:`StageEntry.headline` (empty for other kinds)."""
    if kind == "evaluate" and isinstance(result, EvaluationResult):
        return (
            f"success {pct(result.success_rate)}, collision {pct(result.collision_rate)} over "
            f"{result.episodes} episodes; gate {verdict(result.gate.passed)}"
        )
    if kind == "planner_check" and isinstance(result, ConformanceResult):
        return f"{result.planner}: " + (
            "every check passed" if result.passed else "FAILED " + ", ".join(result.failed)
        )
    if kind == "diagnose" and isinstance(result, DiagnosticsResult):
        return f"solved {result.solved}/{result.episodes} hard seeds"
    if kind == "campaign" and isinstance(result, CampaignResult):
        b = best_from_campaign(result)
        return (
            "no cells"
            if b is None
            else (
                f"best {b.variant}: hard success {pct(b.hard_success)}, global {pct(b.global_success)}, "
                f"clearance {fmt(b.hard_clearance)} / {fmt(b.global_clearance)} m"
            )
        )
    if kind == "train" and isinstance(result, TrainResult | TrainingSummary):
        r = result.result("") if isinstance(result, TrainingSummary) else result
        return (
            f"val ADE {fmt(r.val_ade, 3)} m (CV {fmt(r.cv_val_ade, 3)}), FDE {fmt(r.val_fde, 3)} m "
            f"(CV {fmt(r.cv_val_fde, 3)}), epoch {r.best_epoch}"
        )
    if kind in ("collect", "mix") and isinstance(result, CollectResult):
        s = result.summary
        return f"{s.samples} samples from {s.episodes} episodes" + (
            f"; outcomes {result.outcomes}" if result.outcomes else ""
        )
    if kind == "pipeline" and isinstance(result, PipelineResult):
        gates = "gates passed" if result.passed else f"gate failed: {', '.join(result.failed_gates)}"
        return f"{gates}; model {result.model_id or '-'} {'promoted' if result.promoted else 'not promoted'}"
    return ""


def _stages(doc: Document, s: PipelineSummary) -> None:
    doc.section("Stages")
    doc.table(
        ["stage", "status", "time [s]", "result", "report", "job"],
        [
            [
                st.name,
                st.status,
                fmt(st.wall_s, 1),
                (st.headline + (f" error: {st.error}" if st.error else "")) or "-",
                st.report or "-",
                st.job_id or "-",
            ]
            for st in s.stages
        ],
    )
    links = [(f"{st.name}: report", st.report) for st in s.stages if st.report]
    links += [(f"{st.name}: {label}", href) for st in s.stages for label, href in st.artifacts.items()]
    if links:
        doc.links(links)


def _gates(doc: Document, s: PipelineSummary) -> None:
    doc.section("Gates")
    if not s.gates:
        doc.note("No gate was evaluated.")
        return
    doc.table(
        ["gate", "result", "detail"],
        [
            [g.name, "not evaluated" if g.passed is None else verdict(g.passed), g.detail or "-"]
            for g in s.gates
        ],
    )
    for g in s.gates:
        if g.checks:
            doc.text(f"**{g.name}** gate checks:")
            doc.table(["check", "result", "value", "threshold", "detail"], gate_rows(g.checks))


def _incumbent(doc: Document, s: PipelineSummary) -> None:
    """Candidate vs incumbent first: what a person decides on (numbers, paired test, every changed episode)."""
    doc.section("Candidate vs incumbent")
    inc, r = s.incumbent, s.regression
    if inc is None:
        doc.note("No incumbent: no model this candidate would replace was found, so nothing was compared.")
        return
    doc.text(f"Incumbent `{inc.id}` ({inc.why}; status {inc.status}, sha256 `{inc.sha256[:12]}`).")
    if r is None:
        doc.note("The regression gate did not run (the candidate's or the incumbent's run is missing).")
        return
    rows = []
    for name, pr in (("success", r.success), ("collision", r.collision)):
        if pr is not None:
            rows.append(
                [
                    name,
                    pct(pr.candidate),
                    pct(pr.incumbent),
                    str(pr.n_pairs),
                    f"{pr.worse} / {pr.better}",
                    fmt(pr.p_worse, 3),
                ]
            )
    if r.hard_solved is not None:
        c, i, n = r.hard_solved
        rows.append(["hard seeds solved", f"{c}/{n}", f"{i}/{n}", str(n), "-", "-"])
    doc.table(["metric", "candidate", "incumbent", "paired episodes", "worse / better", "one-sided p"], rows)
    doc.table(["check", "result", "value", "threshold", "detail"], gate_rows(r.checks))
    if r.taxonomy is not None:
        labels = list(r.taxonomy.delta)
        if labels:
            doc.text("Failure mechanisms (global suite), candidate vs incumbent; new ones flagged:")
            doc.table(
                ["mechanism", "candidate", "incumbent", "new"],
                [
                    [
                        k,
                        str(r.taxonomy.candidate.get(k, 0)),
                        str(r.taxonomy.baseline.get(k, 0)),
                        "NEW" if k in r.taxonomy.new_labels else "",
                    ]
                    for k in labels
                ],
            )
    if r.changed:
        doc.text(f"{len(r.changed)} episode(s) ended otherwise (incumbent -> candidate):")
        link = r.candidate_run and r.incumbent_run
        doc.table(
            ["scenario", "seed", "incumbent", "candidate", "side by side"],
            [
                [
                    c.scenario,
                    str(c.seed),
                    c.a,
                    c.b,
                    f"/ui/compare/episode?a={r.incumbent_run}&b={r.candidate_run}&scenario={c.scenario}&seed={c.seed}"
                    if link
                    else "-",
                ]
                for c in r.changed
            ],
        )
    else:
        doc.text("Every episode ended the same way for both models.")


def _best(doc: Document, workdir: Path, s: PipelineSummary, campaign: CampaignResult | None) -> None:
    doc.section("Best campaign variant")
    b = s.best
    if b is None:
        doc.note("No campaign result: no best variant.")
    else:
        doc.text(
            f"**{b.variant}**"
            + (f" with checkpoint `{b.checkpoint}`" if b.checkpoint else "")
            + (f" (config `{b.config_hash[:12]}`)" if b.config_hash else "")
            + "."
        )
        doc.table(
            ["suite", "success", "mean min clearance [m]"],
            [
                ["hard", pct(b.hard_success), fmt(b.hard_clearance)],
                ["global", pct(b.global_success), fmt(b.global_clearance)],
            ],
        )
    if campaign is not None and campaign.ranked:
        rel = ranking_figure(
            workdir, "pipeline_campaign_ranking.png", campaign.ranked, title="Campaign ranking"
        )
        doc.image(rel, "Campaign cells in rank order: hard-suite and global success with 95 % intervals")


def build_pipeline_document(
    s: PipelineSummary,
    workdir: Path,
    campaign: CampaignResult | None = None,
    training: TrainingSummary | None = None,
) -> Document:
    doc = Document(f"Pipeline {s.name}: performance summary")
    doc.section("Verdict")
    failed = [g.name for g in s.gates if g.passed is False]
    doc.text(
        f"Status **{s.status}** (exit code {s.exit_code}). Gates: "
        + (f"**FAILED** ({', '.join(failed)})" if failed else "**PASSED**" if s.gates else "none evaluated")
        + f". Promoted model: {'`' + s.promoted_model + '`' if s.promoted_model else 'none'}."
        + (f" Code `{s.code_version}`." if s.code_version else "")
        + (f" {fmt(s.wall_s, 1, ' s')} in all." if s.wall_s else "")
    )
    if s.relaxed:
        doc.note(
            "This pipeline's gates are relaxed on purpose: its model is registered as `relaxed` and can never "
            "be promoted or become the default."
        )
    if s.failing_checks:
        doc.text("Failed checks: " + "; ".join(s.failing_checks) + ".")
    _incumbent(doc, s)
    _stages(doc, s)
    _gates(doc, s)
    _best(doc, workdir, s, campaign)
    doc.section("Promoted model")
    doc.text(f"`{s.promoted_model}`" if s.promoted_model else "No model was promoted.")
    if s.promotion:
        doc.text(s.promotion)
    if training is not None and training.history:
        doc.section("Training curves")
        path, rel = figure_path(workdir, "pipeline_training_curves.png")
        curves(training, path)
        doc.image(rel, "Predictor training: loss, ADE and FDE per epoch against constant velocity")
    doc.section("Artifacts")
    doc.links([(k, v) for k, v in s.artifacts.items()] + [("summary (Markdown)", "report.md")])
    return doc


def write_pipeline_report(
    summary: Any, workdir: str | Path, *, campaign: Any = None, training: Any = None
) -> list[Path]:
    """Write the pipeline summary (``report.md``/``report.html`` plus figures) under ``workdir``; returns the paths.

    ``summary``: a :class:`PipelineSummary` (or its dict); ``campaign``: the campaign result (for the ranking
    chart), ``training``: the training summary (for the curves); both optional, models, dicts or JSON paths.
    """
    workdir = Path(workdir)
    doc = build_pipeline_document(
        read(PipelineSummary, summary),
        workdir,
        read(CampaignResult, campaign) if campaign is not None else None,
        read(TrainingSummary, training) if training is not None else None,
    )
    return publish(doc, workdir)
