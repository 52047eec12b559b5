"""Pipeline performance summary: stage status, gate results, the best campaign variant (hard and global
success, clearance), the promoted model and links to every stage's artifacts.

Written by the pipeline runner after the last stage that ran, also when a gate failed (exit code 2) or a
stage crashed: a failed run is exactly when a person needs the summary. :class:`PipelineSummary` is the
input; the helpers build its gate and best-variant entries from the stage results.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from pydantic import BaseModel, Field

from foresight.core.render.charts import ranking_chart, training_curves
from foresight.core.reports.campaign import cell_name, glob_suite
from foresight.core.reports.common import (
    as_dict,
    figure_path,
    fmt,
    gate_rows,
    pct,
    publish,
    rate_est,
    verdict,
)
from foresight.core.reports.document import Document


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
    name: str  #: training | evaluation | closed_loop
    passed: bool | None  #: None = not evaluated (its stage did not run)
    checks: list[dict[str, Any]] = Field(default_factory=list)  #: GateCheck dicts (name, passed, value, threshold, detail)
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
    artifacts: dict[str, str] = Field(default_factory=dict)
    code_version: str | None = None
    wall_s: float | None = None


def gate_entry(name: str, gate: Mapping[str, Any] | None) -> GateEntry:
    """From a GateResult dict (``checks`` list) or the training summary's ``quality_gates`` (``checks`` mapping)."""
    if not gate:
        return GateEntry(name=name, passed=None, detail="not evaluated")
    checks = gate.get("checks") or []
    if isinstance(checks, Mapping):
        checks = [{"name": k, "passed": bool(v)} for k, v in checks.items()]
    return GateEntry(name=name, passed=bool(gate.get("passed")), checks=list(checks))


def best_from_campaign(result: Any) -> BestVariant | None:
    """The ranked-first cell of a campaign result (model, dict or path)."""
    best = as_dict(result).get("best")
    if not best:
        return None
    hard, glob = best.get("hard") or {}, glob_suite(best)
    return BestVariant(variant=str(best.get("variant")), checkpoint=best.get("checkpoint"),
                       config_hash=(best.get("planner") or {}).get("config_hash"),
                       hard_success=(hard.get("success") or {}).get("rate"),
                       global_success=(glob.get("success") or {}).get("rate"),
                       hard_clearance=(hard.get("mean_min_clearance") or {}).get("mean"),
                       global_clearance=(glob.get("mean_min_clearance") or {}).get("mean"))


def headline(kind: str, result: Any) -> str:
    """One line of a stage result's key numbers, for :attr:`StageEntry.headline` (empty for unknown kinds)."""
    r = as_dict(result)
    if kind == "evaluate":
        return (f"success {pct(r.get('success_rate'))}, collision {pct(r.get('collision_rate'))} over "
                f"{r.get('episodes', '?')} episodes; gate {verdict((r.get('gate') or {}).get('passed'))}")
    if kind == "diagnose":
        return f"solved {r.get('solved', '?')}/{r.get('episodes', '?')} hard seeds"
    if kind == "campaign":
        b = best_from_campaign(r)
        return "no cells" if b is None else (
            f"best {b.variant}: hard success {pct(b.hard_success)}, global {pct(b.global_success)}, "
            f"clearance {fmt(b.hard_clearance)} / {fmt(b.global_clearance)} m")
    if kind == "train":
        best = r.get("best") or {}
        ade, fde = r.get("val_ade", best.get("val_ade")), r.get("val_fde", best.get("val_fde"))
        cv_ade = r.get("cv_val_ade", (r.get("cv_val") or {}).get("ade"))
        cv_fde = r.get("cv_val_fde", (r.get("cv_val") or {}).get("fde"))
        return (f"val ADE {fmt(ade, 3)} m (CV {fmt(cv_ade, 3)}), FDE {fmt(fde, 3)} m (CV {fmt(cv_fde, 3)}), "
                f"epoch {r.get('best_epoch', best.get('epoch', '?'))}")
    return ""


def _stages(doc: Document, s: PipelineSummary) -> None:
    doc.section("Stages")
    doc.table(["stage", "status", "time [s]", "result", "report", "job"],
              [[st.name, st.status, fmt(st.wall_s, 1), (st.headline + (f" error: {st.error}" if st.error else "")) or "-",
                st.report or "-", st.job_id or "-"] for st in s.stages])
    links = [(f"{st.name}: report", st.report) for st in s.stages if st.report]
    links += [(f"{st.name}: {label}", href) for st in s.stages for label, href in st.artifacts.items()]
    if links:
        doc.links(links)


def _gates(doc: Document, s: PipelineSummary) -> None:
    doc.section("Gates")
    if not s.gates:
        doc.note("No gate was evaluated.")
        return
    doc.table(["gate", "result", "detail"],
              [[g.name, "not evaluated" if g.passed is None else verdict(g.passed), g.detail or "-"] for g in s.gates])
    for g in s.gates:
        if g.checks:
            doc.text(f"**{g.name}** gate checks:")
            doc.table(["check", "result", "value", "threshold", "detail"], gate_rows(g.checks))


def _best(doc: Document, workdir: Path, s: PipelineSummary, campaign: Mapping[str, Any] | None) -> None:
    doc.section("Best campaign variant")
    b = s.best
    if b is None:
        doc.note("No campaign result: no best variant.")
    else:
        doc.text(f"**{b.variant}**" + (f" with checkpoint `{b.checkpoint}`" if b.checkpoint else "")
                 + (f" (config `{b.config_hash[:12]}`)" if b.config_hash else "") + ".")
        doc.table(["suite", "success", "mean min clearance [m]"],
                  [["hard", pct(b.hard_success), fmt(b.hard_clearance)],
                   ["global", pct(b.global_success), fmt(b.global_clearance)]])
    cells = list((campaign or {}).get("ranked") or [])
    if cells:
        path, rel = figure_path(workdir, "pipeline_campaign_ranking.png")
        ranking_chart([cell_name(c) for c in cells], [rate_est((c.get("hard") or {}).get("success")) for c in cells],
                      [rate_est(glob_suite(c).get("success")) for c in cells], path, title="Campaign ranking")
        doc.image(rel, "Campaign cells in rank order: hard-suite and global success with 95 % intervals")


def build_pipeline_document(s: PipelineSummary, workdir: Path, campaign: Mapping[str, Any] | None = None,
                            training: Mapping[str, Any] | None = None) -> Document:
    doc = Document(f"Pipeline {s.name}: performance summary")
    doc.section("Verdict")
    failed = [g.name for g in s.gates if g.passed is False]
    doc.text(f"Status **{s.status}** (exit code {s.exit_code}). Gates: "
             + (f"**FAILED** ({', '.join(failed)})" if failed else "**PASSED**" if s.gates else "none evaluated")
             + f". Promoted model: {'`' + s.promoted_model + '`' if s.promoted_model else 'none'}."
             + (f" Code `{s.code_version}`." if s.code_version else "") + (f" {fmt(s.wall_s, 1, ' s')} in all." if s.wall_s else ""))
    _stages(doc, s)
    _gates(doc, s)
    _best(doc, workdir, s, campaign)
    doc.section("Promoted model")
    doc.text(f"`{s.promoted_model}`" if s.promoted_model else "No model was promoted.")
    if s.promotion:
        doc.text(s.promotion)
    history = list((training or {}).get("history") or [])
    if history:
        doc.section("Training curves")
        path, rel = figure_path(workdir, "pipeline_training_curves.png")
        training_curves(history, path, best_epoch=((training or {}).get("best") or {}).get("epoch"))
        doc.image(rel, "Predictor training: loss, ADE and FDE per epoch against constant velocity")
    doc.section("Artifacts")
    doc.links([(k, v) for k, v in s.artifacts.items()] + [("summary (Markdown)", "report.md")])
    return doc


def write_pipeline_report(summary: PipelineSummary | Mapping[str, Any], workdir: str | Path, *,
                          campaign: Any = None, training: Any = None) -> list[Path]:
    """Write the pipeline summary (``report.md``/``report.html`` plus figures) under ``workdir``; returns the paths.

    ``campaign``: the campaign result (for the ranking chart), ``training``: the training summary (for the
    curves); both optional and may be models, dicts or JSON paths.
    """
    workdir = Path(workdir)
    s = summary if isinstance(summary, PipelineSummary) else PipelineSummary.model_validate(as_dict(summary))
    doc = build_pipeline_document(s, workdir, as_dict(campaign) if campaign is not None else None,
                                  as_dict(training) if training is not None else None)
    return publish(doc, workdir)
