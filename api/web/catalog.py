"""Dashboard pages of the records: model registry, results (evaluations, campaigns, other reports), bundles."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Depends, Query, Request
from fastapi.responses import FileResponse, HTMLResponse

from foresight.api.web import files, previews
from foresight.api.web.auth import PageNotFound, read_access
from foresight.api.web.render import page
from foresight.core.errors import NotFoundError
from foresight.core.jobs.results import planner_and_model, typed_result, verdict
from foresight.core.reports.pipeline import headline
from foresight.store import folders, job_reads, registry, results
from foresight.store.models import Bundle

router = APIRouter(prefix="/ui", include_in_schema=False, dependencies=[Depends(read_access)])
RESULT_KINDS = {
    "evaluate": "Evaluations",
    "campaign": "Campaigns",
    "diagnose": "Diagnostics",
    "pipeline": "Pipelines",
    "train": "Training",
}
RESULT_LIMIT = 200


@router.get("/models")
def models_page(request: Request) -> HTMLResponse:
    """The registry: status, lineage, metrics, provenance; promote buttons for run-time entries."""
    rows = registry.models(request.app.state.engine)
    return page(request, "models.html", title="Models", nav="models", models=rows)


@router.get("/results")
def results_page(request: Request) -> HTMLResponse:
    """Finished stage jobs by kind, with their headline numbers, records and report pages."""
    engine = request.app.state.engine
    rows = job_reads.finished_jobs(engine, list(RESULT_KINDS), RESULT_LIMIT)
    records = results.records_by_job(engine)
    sections: dict[str, list[dict[str, Any]]] = {title: [] for title in RESULT_KINDS.values()}
    for row in rows:
        sections[RESULT_KINDS[row["kind"]]].append(
            dict(
                row,
                headline=headline(row["kind"], typed_result(row["kind"], row["result"])),
                records=records.get(row["id"], []),
                report=files.report_of(request, row["id"]),
                verdict=verdict(row["kind"], row["result"]),
                subject=planner_and_model(row["kind"], row["result"]),
            )
        )
    return page(request, "results.html", title="Results", nav="results", sections=sections)


def _bundle(request: Request, bundle_id: str) -> Bundle:
    row = registry.bundle(request.app.state.engine, bundle_id)
    if row is None:
        raise PageNotFound(f"no bundle with id {bundle_id}")
    return row


@router.get("/bundles")
def bundles_page(request: Request) -> HTMLResponse:
    rows = registry.bundles(request.app.state.engine)
    return page(request, "bundles.html", title="Bundles", nav="bundles", bundles=rows)


@router.get("/maps")
def maps_page(request: Request) -> HTMLResponse:
    """Every scenario matrix of every bundle, each a link to its maps' previews (the matrix page)."""
    rows = registry.bundles(request.app.state.engine)
    return page(request, "maps.html", title="Maps", nav="maps", bundles=[b for b in rows if b.scenarios])


@router.get("/bundles/{bundle_id}")
def bundle_page(request: Request, bundle_id: str) -> HTMLResponse:
    """A bundle's files and scenario matrices."""
    return page(
        request, "bundle.html", title=f"Bundle {bundle_id}", nav="bundles", bundle=_bundle(request, bundle_id)
    )


def _matrix(request: Request, bundle_id: str, matrix: str):  # noqa: ANN202
    row = _bundle(request, bundle_id)
    if matrix not in row.scenarios:
        raise PageNotFound(f"bundle {bundle_id} has no scenario matrix {matrix}")
    root = request.app.state.resolver.bundle_root(row)
    return row, previews.load_matrix_cached(folders.resolve_under(root, matrix))


MatrixQuery = Annotated[str, Query(min_length=1, max_length=500)]


@router.get("/bundles/{bundle_id}/matrix")
def matrix_page(request: Request, bundle_id: str, path: MatrixQuery) -> HTMLResponse:
    """A scenario matrix: its scenarios grouped by map, with a preview of each map."""
    row, matrix = _matrix(request, bundle_id, path)
    by_map: dict[str, list[Any]] = {}
    for s in matrix.scenarios:
        by_map.setdefault(s.map.name, []).append(s)
    return page(
        request,
        "matrix.html",
        title=f"{bundle_id}: {path}",
        nav="maps",
        bundle=row,
        path=path,
        matrix=matrix,
        by_map=by_map,
    )


@router.get("/bundles/{bundle_id}/preview.png")
def map_preview(request: Request, bundle_id: str, path: MatrixQuery, scenario: MatrixQuery) -> FileResponse:
    """PNG of a scenario's map (drawn once, then cached under the store root)."""
    _, matrix = _matrix(request, bundle_id, path)
    try:
        resolved = matrix.get(scenario)
    except NotFoundError:
        raise PageNotFound(f"matrix {path} has no scenario {scenario}") from None
    png = previews.preview(request.app.state.settings.store_root, resolved.map)
    return FileResponse(png, media_type="image/png", headers={"Cache-Control": "max-age=3600"})
