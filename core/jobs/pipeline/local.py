"""In-process pipeline runs (``foresight pipeline run --local``): each stage's function in ``<workdir>/<stage>/``.

Datasets are named by their local ``.npz`` path, the registered candidate by its id in a small local
registry (``<workdir>/registry.json``); a stage whose ``result.json`` exists is not run again (resume).
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

from pydantic import BaseModel

from foresight.core import files
from foresight.core.errors import NotFoundError
from foresight.core.jobs.kinds import KINDS
from foresight.core.jobs.pipeline.runbook import ChildRun
from foresight.core.jobs.results import read_result
from foresight.core.runtime.context import StageContext
from foresight.core.training.collect import CollectResult
from foresight.core.training.config import TrainResult


class LocalChildren:
    """``run_child`` for in-process runs. ``resolve_model`` is the fallback for ids outside this run
    (e.g. ``default`` from ``model/registry.yaml``); ``reports`` writes each stage's report page."""

    def __init__(
        self, ctx: StageContext, *, resolve_model: Callable[[str], Path] | None = None, reports: bool = True
    ):
        self.ctx = ctx
        self.fallback = resolve_model or ctx.resolve_model
        self.reports = reports
        self.registry_path = ctx.workdir / "registry.json"

    # ---------------------------------------------------------------- local registry
    def _registry(self) -> dict[str, Any]:
        return json.loads(self.registry_path.read_text()) if self.registry_path.is_file() else {}

    def _save_registry(self, data: dict[str, Any]) -> None:
        files.write_text(self.registry_path, json.dumps(data, indent=2))

    def resolve_model(self, ident: str) -> Path:
        entry = self._registry().get(ident)
        if entry is not None:
            return Path(entry["checkpoint"])
        return self.fallback(ident)

    def resolve_dataset(self, ident: str) -> Path:
        path = Path(ident)
        if path.is_file():
            return path
        raise NotFoundError(f"unknown dataset {ident!r} (in-process pipeline runs name datasets by path)")

    # ---------------------------------------------------------------- run_child
    def __call__(
        self, stage: str, kind: str, spec: dict[str, Any], progress: Callable[[float, str], None]
    ) -> ChildRun:
        folder = self.ctx.workdir / stage
        done = folder / "result.json"
        if kind == "register":
            return self._register(spec)
        if kind == "promote":
            data = self._registry()
            data[spec["model_id"]]["status"] = spec["to"]
            self._save_registry(data)
            return ChildRun(
                result={"model_id": spec["model_id"], "status": spec["to"]}, ident=spec["model_id"]
            )
        if done.is_file():
            saved = json.loads(done.read_text())
            if saved["spec"] == spec:
                return self._run_of(
                    stage, folder, read_result(kind, saved["result"]), saved["wall_s"], resumed=True
                )
        stage_kind = KINDS[kind]
        config = stage_kind.config_of(spec)
        folder.mkdir(parents=True, exist_ok=True)
        sub = replace(
            self.ctx,
            workdir=folder,
            progress=progress,
            resolve_model=self.resolve_model,
            resolve_dataset=self.resolve_dataset,
        )
        t0 = time.perf_counter()
        result = read_result(kind, stage_kind.run(config, sub))
        wall = time.perf_counter() - t0
        data = result.model_dump(mode="json", by_alias=True)
        files.write_text(
            done, json.dumps({"spec": spec, "result": data, "wall_s": wall}, indent=2, default=str)
        )
        if self.reports:
            from foresight.core.reports.stage import write_report  # matplotlib: only when reports are wanted

            write_report(kind, result, folder, self.ctx.log)
        return self._run_of(stage, folder, result, wall)

    def _run_of(
        self, stage: str, folder: Path, result: BaseModel, wall: float | None, resumed: bool = False
    ) -> ChildRun:
        ident = str(folder / result.dataset) if isinstance(result, CollectResult) else None
        report = f"{stage}/report.html" if (folder / "report.html").is_file() else None
        return ChildRun(
            result=result,
            ident=ident,
            job_id=None,
            wall_s=wall,
            resumed=resumed,
            report=report,
            artifacts={"folder": f"{stage}/"},
        )

    def _register(self, spec: dict[str, Any]) -> ChildRun:
        from foresight.core.evaluation.plannerspec import sha256_file

        saved = json.loads((self.ctx.workdir / spec["train_stage"] / "result.json").read_text())
        checkpoint = Path(TrainResult.model_validate(saved["result"]).checkpoint)
        data = self._registry()
        data[spec["model_id"]] = {
            "checkpoint": str(checkpoint),
            "sha256": sha256_file(checkpoint),
            **{k: v for k, v in spec.items() if k not in ("model_id", "train_stage")},
        }
        self._save_registry(data)
        return ChildRun(
            result={"model_id": spec["model_id"], "status": spec["status"], "checkpoint": str(checkpoint)},
            ident=spec["model_id"],
        )
