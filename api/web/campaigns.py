"""Dashboard page of a campaign: its ranked cells and its metrics plotted against every planner-grid parameter it
varied (success and collision, one line per checkpoint and suite), drawn as inline SVG on the server."""

from __future__ import annotations

from fastapi import APIRouter, Depends, Request
from fastapi.responses import HTMLResponse

from foresight.api.schemas import Rank
from foresight.api.web import files
from foresight.api.web.auth import PageNotFound, read_access
from foresight.api.web.render import page
from foresight.core.runtime.refs import Seed
from foresight.store import job_reads, listing, queue, results

router = APIRouter(prefix="/ui", include_in_schema=False, dependencies=[Depends(read_access)])


@router.get("/campaigns/{campaign_id}")
def campaign_page(request: Request, campaign_id: str) -> HTMLResponse:
    """Ranked cells, the gate, and a chart per varied grid parameter and metric (a short job id works too)."""
    from markupsafe import Markup

    from foresight.core.reports.grid_plot import METRICS, VARIANT_AXIS, chart_svg, parameter_plots

    engine = request.app.state.engine
    try:
        ident = job_reads.resolve_id(engine, campaign_id)
        row, cells, gates = results.campaign(engine, ident)
        grid = listing.campaign_grid_cells(engine, ident)
    except queue.JobNotFound as exc:
        raise PageNotFound(str(exc)) from None
    plots = parameter_plots(grid)
    baselines = _baseline_ranks(cells)
    charts = [(p.parameter, [Markup(chart_svg(p, m)) for m in METRICS]) for p in plots]
    return page(
        request,
        "campaign.html",
        title=f"Campaign {ident[:12]}",
        nav="results",
        campaign=row,
        cells=cells,
        gates=gates,
        charts=charts,
        by_variant=[p.parameter for p in plots] == [VARIANT_AXIS],
        baselines=baselines,
    )


@router.get("/campaigns/{campaign_id}/cells/{rank}")
def cell_page(request: Request, campaign_id: str, rank: Rank) -> HTMLResponse:
    """One cell's episodes, suite by suite (hard first), failures first, each one click from the episode player."""
    from foresight.api.routes.results import episode_list

    engine = request.app.state.engine
    try:
        ident = f"{job_reads.resolve_id(engine, campaign_id)}:{rank}"
        _, config, _ = results.comparison_operand(engine, ident)
        suites = [
            (suite, episode_list(engine, request.app.state.settings, f"{ident}:{suite}"))
            for suite in ("hard", "global")
        ]
    except queue.JobNotFound as exc:
        raise PageNotFound(str(exc)) from None
    return page(
        request,
        "campaign_cell.html",
        title=f"Cell {rank} of campaign {ident[:12]}",
        nav="results",
        campaign_id=ident.partition(":")[0],
        rank=rank,
        variant=config.get("variant"),
        checkpoint=config.get("checkpoint"),
        suites=suites,
    )


@router.get("/campaigns/{campaign_id}/cells/{rank}/episodes/{scenario}/{seed}")
def cell_episode_page(
    request: Request, campaign_id: str, rank: Rank, scenario: str, seed: Seed
) -> HTMLResponse:
    """The episode player on one episode as a campaign cell ran it (404 for an episode it did not store)."""
    from foresight.api.routes.results import trace_url

    try:
        ident = f"{job_reads.resolve_id(request.app.state.engine, campaign_id)}:{rank}"
        _, config, _ = results.comparison_operand(request.app.state.engine, ident)
    except queue.JobNotFound as exc:
        raise PageNotFound(str(exc)) from None
    files.stored_trace(request, ident, scenario, seed)
    return page(
        request,
        "episode.html",
        title=f"{scenario} seed {seed}",
        nav="results",
        scenario=scenario,
        seed=seed,
        data_url=trace_url(ident, scenario, seed),
        source=f"campaign cell {rank} ({config.get('variant')})",
        source_url=f"/ui/campaigns/{ident.partition(':')[0]}/cells/{rank}",
        source_id=ident,
    )


def _baseline_ranks(cells: list[dict]) -> dict[int, int]:
    """Rank of each cell paired with a baseline cell -> that cell's rank: of the same checkpoint, the one cell
    compared with none (``core.evaluation.campaign.with_paired_stats``)."""
    # the rows' metrics as stored (CellMetrics of this version, or an older shape without the key: not paired)
    paired = {c["rank"]: (c["metrics"] or {}).get("vs_baseline") is not None for c in cells}
    base = {c["params"]["checkpoint"]: c["rank"] for c in cells if not paired[c["rank"]]}
    return {
        c["rank"]: base[c["params"]["checkpoint"]]
        for c in cells
        if paired[c["rank"]] and c["params"]["checkpoint"] in base
    }
