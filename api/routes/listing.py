"""Lists of result records to find runs by: evaluations and campaigns, filtered by what they ran (planner,
model, matrix, grid, verdict) and by their job's labels (name, tags), one page at a time."""

from __future__ import annotations

from typing import Annotated, Any, Literal

from fastapi import APIRouter, Query

from foresight.api.deps import EngineDep
from foresight.api.errors import responses
from foresight.api.schemas import MAX_TAGS, Ident, Tag, iso
from foresight.result_schemas import (
    CampaignsPublic,
    CampaignSummaryPublic,
    EvaluationsPublic,
    EvaluationSummaryPublic,
)
from foresight.store import listing

router = APIRouter(tags=["results"])

Limit = Annotated[int, Query(ge=1, le=500)]
Offset = Annotated[int, Query(ge=0, le=10_000_000)]
Text = Annotated[str | None, Query(min_length=1, max_length=500)]
Tags = Annotated[list[Tag], Query(max_length=MAX_TAGS, description="records whose job has every tag given")]
Name = Annotated[str | None, Query(min_length=1, max_length=200, description="their job's exact name")]


@router.get("/evaluations")
def read_evaluations(
    engine: EngineDep,
    model_id: Ident | None = None,
    bundle: Ident | None = None,
    planner: Text = None,
    matrix: Text = None,
    verdict: Literal["passed", "failed_gate", "failed_integrity"] | None = None,
    name: Name = None,
    tag: Tags = [],  # noqa: B006 (FastAPI copies query defaults)
    limit: Limit = 50,
    offset: Offset = 0,
) -> EvaluationsPublic:
    """Evaluations, newest first, filtered by model id, bundle, planner name, matrix (bundle-relative path),
    verdict and their job's name and tags; config and headline metrics of each."""
    count, rows = listing.evaluations(
        engine,
        model_id=model_id,
        bundle_id=bundle,
        planner=planner,
        matrix=matrix,
        verdict=verdict,
        name=name,
        tags=tag,
        limit=limit,
        offset=offset,
    )
    data = [
        EvaluationSummaryPublic.model_validate(r.row).model_copy(update={"name": r.name, "tags": r.tags})
        for r in rows
    ]
    return EvaluationsPublic(data=data, count=count, limit=limit, offset=offset)


@router.get("/campaigns")
def read_campaigns(
    engine: EngineDep,
    matrix: Text = None,
    grid: Text = None,
    model: Annotated[
        str | None, Query(min_length=1, max_length=200, description="a checkpoint its cells ran")
    ] = None,
    name: Name = None,
    tag: Tags = [],  # noqa: B006
    limit: Limit = 50,
    offset: Offset = 0,
) -> CampaignsPublic:
    """Campaigns, newest first, filtered by matrix, planner grid, a checkpoint of its cells and their job's name
    and tags; what each ran and its best cell."""
    count, rows = listing.campaigns(
        engine, matrix=matrix, grid=grid, model=model, name=name, tags=tag, limit=limit, offset=offset
    )
    data = []
    for r in rows:
        best = r.row.best or None
        data.append(
            CampaignSummaryPublic(
                id=r.row.id,
                job_id=r.row.job_id,
                config=r.row.config,
                name=r.name,
                tags=r.tags,
                created_at=iso(r.row.created_at),
                best={"checkpoint": best["checkpoint"], "variant": best["variant"]} if best else None,
                best_metrics={
                    s: {
                        "success": best[s]["success"]["rate"],
                        "collision": best[s]["collision"]["rate"],
                        "episodes": best[s]["episodes"],
                    }
                    for s in ("global", "hard")
                    if s in best
                }
                if best
                else None,
            )
        )
    return CampaignsPublic(data=data, count=count, limit=limit, offset=offset)


@router.get("/campaigns/{campaign_id}/grid", responses=responses(404))
def read_campaign_grid(campaign_id: Ident, engine: EngineDep) -> list[dict[str, Any]]:
    """The campaign's metrics against each planner-grid parameter it varied (keys whose resolved values differ
    between cells; ``variant`` when none does): per metric (success, collision) a series per checkpoint and
    suite, each point a variant with its rate and 95 % interval. What the dashboard's campaign page plots."""
    from dataclasses import asdict

    from foresight.api.routes.results import full_id
    from foresight.core.reports.grid_plot import parameter_plots

    return [
        asdict(p) for p in parameter_plots(listing.campaign_grid_cells(engine, full_id(engine, campaign_id)))
    ]
