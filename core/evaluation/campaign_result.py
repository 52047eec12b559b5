"""A campaign's result models: one cell (checkpoint x variant), the ranked campaign, the lazily read cells."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from foresight.core.evaluation.aggregate import SuiteSummary
from foresight.core.evaluation.delta import Delta, EpisodeChange
from foresight.core.evaluation.evaluation_result import PlannerProvenance
from foresight.core.evaluation.gates import ClosedLoopGateResult
from foresight.core.evaluation.integrity import IntegrityReport
from foresight.core.runtime.execution import Execution

CELL_FORMAT = "foresight.campaign_cell/1"


class CellMetrics(BaseModel):
    """A cell's two suites (``global`` by alias) and its paired comparison with the baseline cell: the metrics
    its result row and API record keep."""

    model_config = ConfigDict(serialize_by_alias=True, validate_by_name=True, validate_by_alias=True)

    hard: SuiteSummary
    global_: SuiteSummary = Field(alias="global")
    #: suite (hard, global) -> headline metric -> paired delta vs the baseline cell (same episodes)
    vs_baseline: dict[str, dict[str, Delta] | None] | None = None
    #: suite -> the episodes whose outcome differs from the baseline cell's (a: the baseline's, b: this cell's)
    changed_vs_baseline: dict[str, list[EpisodeChange]] | None = None


class CellParams(BaseModel):
    """Which cell: the checkpoint and the planner-grid variant."""

    checkpoint: str
    variant: str


class CellResult(CellMetrics, CellParams):
    """One checkpoint x variant: both suites' summaries and integrity (written to cells/<key>.json)."""

    format: str = CELL_FORMAT
    key: str
    fingerprint: str
    planner: PlannerProvenance
    integrity: IntegrityReport
    ranking_key: list[float]
    episodes_file: str
    run_dir: str | None = (
        None  #: the cell's run folder (episodes.jsonl, traces/); None for cells written before
    )
    baseline: str | None = None  #: key of the baseline cell it is compared with (same checkpoint)

    def metrics(self) -> CellMetrics:
        return CellMetrics(
            hard=self.hard,
            global_=self.global_,
            vs_baseline=self.vs_baseline,
            changed_vs_baseline=self.changed_vs_baseline,
        )

    def params(self) -> CellParams:
        return CellParams(checkpoint=self.checkpoint, variant=self.variant)


class CampaignResult(BaseModel):
    status: Literal["completed", "passed", "failed_gate"]  #: completed = no gate configured
    exit_code: int
    best: CellResult | None
    ranked: list[CellResult]
    gate: ClosedLoopGateResult | None
    best_vs_reference: dict[
        str, list
    ]  #: resolved-config keys where the best differs from the baseline (or first) cell
    cells_run: int
    cells_resumed: int
    matrix: str
    seed_manifest: str
    grid: str
    horizon: str
    hard_episodes: int
    global_episodes: int
    #: suite (hard, global) -> its (scenario, seed) episodes in order: a cell's records of one suite (None: older)
    suites: dict[str, list[tuple[str, int]]] | None = None
    code_version: str
    execution: Execution | None = (
        None  #: which executor ran the episodes, on how many CPUs (None: older results)
    )
    artifacts: dict[str, str]
    wall_s: float
    config: dict  #: the stage config as given (with defaults)


class CampaignCells(BaseModel):
    """The part of a :class:`CampaignResult` that a lookup of one cell reads: the ranked cells, each validated only
    when asked for (:meth:`cell`; a grid of 10^4 cells is a result of tens of MB), and the suites."""

    ranked: list[dict[str, Any]]
    suites: dict[str, list[tuple[str, int]]] | None = None

    def cell(self, rank: int) -> CellResult:
        """The cell of ``rank`` (1 = best)."""
        return CellResult.model_validate(self.ranked[rank - 1])
