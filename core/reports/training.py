"""Training report: curves (loss, ADE, FDE against constant velocity, proxy success per epoch), the selected
checkpoint and why, the training gate, the dataset, and the per-epoch table.

Input: the ``train`` stage's :class:`TrainingSummary` (the model, its dict or ``training_summary.json``;
``TrainResult.summary`` names the file).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from foresight.core.render.charts import training_curves
from foresight.core.reports.common import figure_path, fmt, pct, publish, read, verdict
from foresight.core.reports.document import Document
from foresight.core.training.config import EpochRecord, TrainingSummary


def _gates(doc: Document, summary: TrainingSummary) -> None:
    gate = summary.quality_gates
    doc.section("Training gate")
    values = gate.reference(summary.best)
    doc.text(
        f"Training gate: **{verdict(gate.passed)}** (validation ADE/FDE of the selected checkpoint "
        "against the limits and against constant velocity on the same validation data)."
    )
    doc.table(
        ["check", "result", "value [m]", "threshold [m]"],
        [
            [name, "ok" if ok else "FAIL", fmt(values[name][0], 3), fmt(values[name][1], 3)]
            for name, ok in gate.checks.items()
        ],
    )
    p = gate.closed_loop
    if p is not None and p.cv_success is not None:
        doc.text(
            f"Closed loop on the selection suite ({fmt(p.episodes, 0)} episodes): success {pct(p.success)} with "
            f"this checkpoint vs {pct(p.cv_success)} with constant velocity, same episodes (McNemar exact "
            f"p = {fmt(p.vs_cv_p, 3)})."
        )


def _dataset(doc: Document, summary: TrainingSummary) -> None:
    doc.section("Dataset")
    ds, stats = summary.dataset, summary.dataset_stats
    if not ds and not stats:
        doc.note("No dataset information recorded.")
        return
    rows = [
        [k, f"`{v}`" if k in ("sha256", "config_hash") else v]
        for k, v in ds.items()
        if not isinstance(v, dict | list)
    ]
    rows += [[k, v] for k, v in stats.items() if isinstance(v, int | float | str | bool)]
    doc.table(["field", "value"], rows)


def _epochs(doc: Document, history: list[EpochRecord], best_epoch: int) -> None:
    doc.section("Epochs")
    if not history:
        doc.note("No epochs recorded.")
        return
    doc.table(
        [
            "epoch",
            "train loss",
            "val loss",
            "val ADE [m]",
            "val FDE [m]",
            "CV ADE [m]",
            "CV FDE [m]",
            "proxy success",
            "proxy clearance [m]",
            "selected",
        ],
        [
            [
                r.epoch,
                fmt(r.train_loss, 4),
                fmt(r.val_loss, 4),
                fmt(r.val_ade, 3),
                fmt(r.val_fde, 3),
                fmt(r.cv_val_ade, 3),
                fmt(r.cv_val_fde, 3),
                pct(r.proxy.success) if r.proxy else "-",
                fmt(r.proxy.clearance) if r.proxy else "-",
                "**yes**" if r.epoch == best_epoch else "",
            ]
            for r in history
        ],
    )


def curves(summary: TrainingSummary, path: Path) -> None:
    """Loss, ADE and FDE per epoch against constant velocity (and proxy success per epoch when measured)."""
    training_curves(
        [r.model_dump(exclude_none=True) for r in summary.history], path, best_epoch=summary.best.epoch
    )


def build_training_document(summary: TrainingSummary, workdir: Path) -> Document:
    history, best, cv = summary.history, summary.best, summary.cv_val
    doc = Document("Predictor training")
    doc.section("Summary")
    gain = f" ({100 * (1 - best.val_ade / cv.ade):.1f}% below constant velocity)" if cv.ade else ""
    reason = summary.selection.reason if summary.selection is not None else ""
    doc.text(
        f"Selected epoch **{best.epoch}** of {len(history)} by {summary.selection_mode}"
        f"{': ' + reason if reason else ''}. Validation ADE "
        f"{fmt(best.val_ade, 3, ' m')}, FDE {fmt(best.val_fde, 3, ' m')}; constant velocity ADE "
        f"{fmt(cv.ade, 3, ' m')}, FDE {fmt(cv.fde, 3, ' m')}{gain}."
    )
    if best.proxy:
        doc.text(
            f"Proxy evaluation of the selected checkpoint: success {pct(best.proxy.success)}, "
            f"clearance {fmt(best.proxy.clearance, 2, ' m')}."
        )
    on = f"trained on {summary.device}, " if summary.device else ""
    doc.text(
        f"Checkpoint `{summary.checkpoint}`, code `{summary.code_version}`, {on}"
        f"{fmt(summary.total_runtime_s, 1, ' s')}."
    )
    doc.section("Training curves")
    if history:
        path, rel = figure_path(workdir, "training_curves.png")
        curves(summary, path)
        doc.image(
            rel,
            "Loss, ADE and FDE per epoch against constant velocity"
            + (", proxy success per epoch" if any(r.proxy for r in history) else ""),
        )
    else:
        doc.note("No epochs recorded: no curves.")
    _gates(doc, summary)
    _dataset(doc, summary)
    _epochs(doc, history, best.epoch)
    return doc


def write_training_report(summary: Any, workdir: str | Path) -> list[Path]:
    """Write the curves, ``report.md`` and ``report.html`` for a training run; returns their paths.

    ``summary``: a :class:`TrainingSummary`, its dict or the path of ``training_summary.json``.
    """
    workdir = Path(workdir)
    return publish(build_training_document(read(TrainingSummary, summary), workdir), workdir)
