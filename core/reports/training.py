"""Training report: curves (loss, ADE, FDE against constant velocity, proxy success per epoch), the selected
checkpoint and why, the training gate, the dataset, and the per-epoch table.

Input: ``training_summary.json`` of the ``train`` stage (a dict or its path; ``TrainResult.summary``
names the file).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from foresight.core.render.charts import training_curves
from foresight.core.reports.common import as_dict, figure_path, fmt, num, pct, publish, verdict
from foresight.core.reports.document import Document


def _gates(doc: Document, summary: Mapping[str, Any]) -> None:
    gate = summary.get("quality_gates") or {}
    doc.section("Training gate")
    if not gate:
        doc.note("No training gate recorded.")
        return
    best, cv, lim = summary.get("best") or {}, gate.get("cv") or {}, gate.get("limits") or {}
    values = {"val_ade_below_limit": (best.get("val_ade"), lim.get("max_val_ade")),
              "val_fde_below_limit": (best.get("val_fde"), lim.get("max_val_fde")),
              "val_ade_below_cv": (best.get("val_ade"), cv.get("ade")),
              "val_fde_below_cv": (best.get("val_fde"), cv.get("fde"))}
    doc.text(f"Training gate: **{verdict(gate.get('passed'))}** (validation ADE/FDE of the selected checkpoint "
             "against the limits and against constant velocity on the same validation data).")
    doc.table(["check", "result", "value [m]", "threshold [m]"],
              [[name, "ok" if ok else "FAIL", fmt(values.get(name, (None, None))[0], 3),
                fmt(values.get(name, (None, None))[1], 3)] for name, ok in (gate.get("checks") or {}).items()])


def _dataset(doc: Document, summary: Mapping[str, Any]) -> None:
    doc.section("Dataset")
    ds = summary.get("dataset") or {}
    stats = summary.get("dataset_stats") or {}
    if not ds and not stats:
        doc.note("No dataset information recorded.")
        return
    rows = [[k, f"`{v}`" if k in ("sha256", "config_hash") else v] for k, v in ds.items() if not isinstance(v, dict | list)]
    rows += [[k, v] for k, v in stats.items() if isinstance(v, int | float | str | bool)]
    doc.table(["field", "value"], rows)


def _epochs(doc: Document, history: list[Mapping[str, Any]], best_epoch: Any) -> None:
    doc.section("Epochs")
    if not history:
        doc.note("No epochs recorded.")
        return
    doc.table(["epoch", "train loss", "val loss", "val ADE [m]", "val FDE [m]", "CV ADE [m]", "CV FDE [m]",
               "proxy success", "proxy clearance [m]", "selected"],
              [[r.get("epoch"), fmt(r.get("train_loss"), 4), fmt(r.get("val_loss"), 4), fmt(r.get("val_ade"), 3),
                fmt(r.get("val_fde"), 3), fmt(r.get("cv_val_ade"), 3), fmt(r.get("cv_val_fde"), 3),
                pct((r.get("proxy") or {}).get("success")) if r.get("proxy") else "-",
                fmt((r.get("proxy") or {}).get("clearance")) if r.get("proxy") else "-",
                "**yes**" if r.get("epoch") == best_epoch else ""] for r in history])


def build_training_document(summary: Mapping[str, Any], workdir: Path) -> Document:
    history = list(summary.get("history") or [])
    best = summary.get("best") or {}
    cv = summary.get("cv_val") or {}
    selection = summary.get("selection") or {}
    doc = Document("Predictor training")
    doc.section("Summary")
    ade, cv_ade = num(best.get("val_ade")), num(cv.get("ade"))
    gain = f" ({100 * (1 - ade / cv_ade):.1f}% below constant velocity)" if ade is not None and cv_ade else ""
    doc.text(f"Selected epoch **{best.get('epoch', '-')}** of {len(history)} by {summary.get('selection_mode', '?')}"
             f"{': ' + selection['reason'] if selection.get('reason') else ''}. Validation ADE "
             f"{fmt(best.get('val_ade'), 3, ' m')}, FDE {fmt(best.get('val_fde'), 3, ' m')}; constant velocity ADE "
             f"{fmt(cv.get('ade'), 3, ' m')}, FDE {fmt(cv.get('fde'), 3, ' m')}{gain}.")
    if best.get("proxy"):
        doc.text(f"Proxy evaluation of the selected checkpoint: success {pct(best['proxy'].get('success'))}, "
                 f"clearance {fmt(best['proxy'].get('clearance'), 2, ' m')}.")
    doc.text(f"Checkpoint `{summary.get('checkpoint', '-')}`, code `{summary.get('code_version', '-')}`, "
             f"{fmt(summary.get('total_runtime_s'), 1, ' s')}.")
    doc.section("Training curves")
    if history:
        path, rel = figure_path(workdir, "training_curves.png")
        training_curves(history, path, best_epoch=best.get("epoch"))
        doc.image(rel, "Loss, ADE and FDE per epoch against constant velocity"
                  + (", proxy success per epoch" if any(r.get("proxy") for r in history) else ""))
    else:
        doc.note("No epochs recorded: no curves.")
    _gates(doc, summary)
    _dataset(doc, summary)
    _epochs(doc, history, best.get("epoch"))
    return doc


def write_training_report(summary: Any, workdir: str | Path) -> list[Path]:
    """Write the curves, ``report.md`` and ``report.html`` for a training run; returns their paths.

    ``summary``: the training summary dict or the path of ``training_summary.json``.
    """
    workdir = Path(workdir)
    return publish(build_training_document(as_dict(summary), workdir), workdir)
