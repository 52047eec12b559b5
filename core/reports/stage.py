"""One call for the service: the report of a finished stage by its kind, so the worker needs no per-kind code.

A report is a by-product: the worker writes it after storing the stage result, and a report that fails is
logged, never turned into a failed job (the result stands on its own).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from foresight.core.errors import ConfigError
from foresight.core.reports.campaign import write_campaign_report
from foresight.core.reports.common import read
from foresight.core.reports.diagnostics import write_diagnostics_report
from foresight.core.reports.evaluation import write_evaluation_report
from foresight.core.reports.pipeline import write_pipeline_report
from foresight.core.reports.training import write_training_report
from foresight.core.reports.witness import write_witness_report
from foresight.core.training.config import TrainingSummary, TrainResult

REPORTERS: dict[str, Callable[..., list[Path]]] = {
    "evaluate": write_evaluation_report,
    "diagnose": write_diagnostics_report,
    "campaign": write_campaign_report,
    "train": write_training_report,
    "pipeline": write_pipeline_report,
    "witness": write_witness_report,
}


def _training_summary(result: Any, workdir: Path) -> TrainingSummary:
    """A ``TrainResult`` names its summary file; the training report reads that file's TrainingSummary."""
    if isinstance(result, TrainingSummary):
        return result
    path = Path(read(TrainResult, result).summary)
    path = path if path.is_absolute() else workdir / path
    if not path.is_file():
        raise ConfigError("training summary file not found", source=path)
    return read(TrainingSummary, path)


def write_stage_report(kind: str, result: Any, workdir: str | Path, **options: Any) -> list[Path]:
    """Write the report of a ``kind`` stage's ``result`` under ``workdir``; returns the written paths.

    ``options`` go to the kind's writer (e.g. ``maps`` for diagnostics, ``campaign``/``training`` for a
    pipeline). Unknown kinds raise :class:`ConfigError`.
    """
    workdir = Path(workdir)
    writer = REPORTERS.get(kind)
    if writer is None:
        raise ConfigError(f"no report for stage kind {kind!r}; known: {sorted(REPORTERS)}", item="kind")
    if kind == "train":
        result = _training_summary(result, workdir)
    return writer(result, workdir, **options)


def write_report(
    kind: str, result: Any, folder: Path, log: Callable[[str], None], **options: Any
) -> list[Path]:
    """The stage's report page as a by-product: none for kinds without a report or when one exists; a failure
    is logged through ``log``, never raised (the stage's result stands on its own)."""
    if kind not in REPORTERS or (folder / "report.html").is_file():
        return []
    try:
        return write_stage_report(kind, result, folder, **options)
    except Exception as exc:  # noqa: BLE001 - any report failure must leave the finished stage intact
        log(f"{kind} report failed: {exc!r}")
        return []
