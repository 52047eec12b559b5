"""Dashboard pages of the jobs: the list (live rows), one job (summary, log stream, report, artifacts)."""

from __future__ import annotations

from typing import Annotated, Any
from urllib.parse import urlencode

from fastapi import APIRouter, Depends, Query, Request
from fastapi import Path as PathParam
from fastapi.responses import HTMLResponse, RedirectResponse, Response

from foresight.api.web import campaigns, catalog, files, forms
from foresight.api.web.auth import PageNotFound, read_access
from foresight.api.web.render import page, ts
from foresight.core.jobs.kinds import KINDS
from foresight.core.jobs.results import Verdict, verdict
from foresight.core.runtime.refs import Seed
from foresight.store import job_reads, queue
from foresight.store.models import JobStatus

router = APIRouter(include_in_schema=False)
pages = APIRouter(prefix="/ui", include_in_schema=False, dependencies=[Depends(read_access)])
PAGE_SIZE = 50

StatusFilter = Annotated[list[JobStatus] | None, Query(alias="status")]
KindFilter = Annotated[list[str] | None, Query(max_length=50)]
TagFilter = Annotated[list[str] | None, Query(max_length=20)]
TextFilter = Annotated[str | None, Query(max_length=200)]


@router.get("/")
@router.get("/ui")
def read_root() -> RedirectResponse:
    return RedirectResponse("/ui/jobs", status_code=307)


def job_verdict(job: dict[str, Any]) -> Verdict | None:
    """A job row's gate/integrity verdict (succeeded jobs only), shown as a badge next to its status."""
    return verdict(job["kind"], job["result"]) if job["status"] == queue.SUCCEEDED else None


def _jobs(
    request: Request,
    status: list[JobStatus] | None,
    kind: list[str] | None,
    offset: int,
    tag: list[str] | None = None,
    q: str | None = None,
) -> dict[str, Any]:
    tags = [t for t in tag or [] if t]
    count, data = job_reads.list_jobs(
        request.app.state.engine,
        statuses=[s.value for s in status or []],
        kinds=kind or [],
        tags=tags,
        q=q or None,
        limit=PAGE_SIZE,
        offset=offset,
    )
    data = [dict(job) for job in data]  # rows are read-only: the page's copies get its extra fields
    for job in data:
        job["report"] = files.report_of(request, job["id"]) if job["status"] == queue.SUCCEEDED else None
        job["verdict"] = job_verdict(job)
    filters = urlencode(
        [("status", s.value) for s in status or []]
        + [("kind", k) for k in kind or []]
        + [("tag", t) for t in tags]
        + ([("q", q)] if q else [])
    )
    return {"jobs": data, "count": count, "offset": offset, "page_size": PAGE_SIZE, "filters": filters}


@pages.get("/jobs")
def jobs_page(
    request: Request,
    status: StatusFilter = None,
    kind: KindFilter = None,
    offset: Annotated[int, Query(ge=0, le=10_000_000)] = 0,
    tag: TagFilter = None,
    q: TextFilter = None,
) -> HTMLResponse:
    """All jobs, newest first, filtered by status, kind, tags and text in the name or note; rows refresh
    themselves."""
    from foresight.store import labels

    query = request.url.query
    return page(
        request,
        "jobs.html",
        title="Jobs",
        nav="jobs",
        statuses=[s.value for s in JobStatus],
        kinds=sorted(KINDS),
        selected_status=[s.value for s in status or []],
        selected_kind=kind or [],
        known_tags=labels.known_tags(request.app.state.engine),
        selected_tag=[t for t in tag or [] if t],
        q=q or "",
        rows_url="/ui/jobs/rows" + (f"?{query}" if query else ""),
        **_jobs(request, status, kind, offset, tag, q),
    )


@pages.get("/jobs/rows")
def jobs_rows(
    request: Request,
    status: StatusFilter = None,
    kind: KindFilter = None,
    offset: Annotated[int, Query(ge=0, le=10_000_000)] = 0,
    tag: TagFilter = None,
    q: TextFilter = None,
) -> HTMLResponse:
    """The table body of the jobs page (polled by the page)."""
    return page(request, "_job_rows.html", **_jobs(request, status, kind, offset, tag, q))


def _job(request: Request, job_id: str) -> dict[str, Any]:
    try:
        row, artifacts, children = job_reads.job_detail(request.app.state.engine, job_id)
    except queue.JobNotFound:
        raise PageNotFound(f"no job with id {job_id}") from None
    job = {**row, "artifacts": artifacts, "children": children}
    job["report"] = files.report_of(request, job_id)
    job["verdict"] = job_verdict(job)
    job["episodes"] = (
        _episodes(request, job) if job["kind"] == "evaluate" and job["status"] == queue.SUCCEEDED else []
    )
    job["witnesses"] = _witnesses(job) if job["kind"] == "witness" else None
    job["gates"] = _gates(job) if job["kind"] in ("pipeline", "planner_check") else None
    return job


def _gates(job: dict[str, Any]) -> dict[str, Any] | None:
    """Why a pipeline's model was or was not promoted (every gate's checks with value and threshold), or a planner
    check's checks; None while it runs or for a result of another version."""
    from foresight.core.jobs.results import typed_result

    result = typed_result(job["kind"], job.get("result"))
    if result is None:
        return None
    if job["kind"] == "planner_check":
        head = f"planner {result.planner}: " + (
            "conforms" if result.passed else "FAILED " + ", ".join(result.failed)
        )
        return {"headline": head, "rows": [("conformance", c) for c in result.checks]}
    gates = result.summary.gates
    return {
        "headline": result.promotion.replace("`", ""),
        "incumbent": result.incumbent,
        "rows": [(g.name, c) for g in gates for c in g.checks],
        "not_run": [(g.name, g.detail) for g in gates if g.passed is None],
    }


def _witnesses(job: dict[str, Any]) -> Any:
    """A witness job's typed result (None while it runs, or for a result of another version)."""
    from foresight.core.jobs.results import typed_result

    return typed_result("witness", job.get("result"))


@pages.get("/jobs/{job_id}/witnesses/{scenario}/{seed}")
def witness_page(
    request: Request, job_id: str, scenario: Annotated[str, PathParam(max_length=200)], seed: Seed
) -> HTMLResponse:
    """A witness beside the planner's own run of the episode (the evaluation the job searched), on one clock."""
    from foresight.api.routes.results import trace_url

    job = _job(request, job_id)
    found = job["witnesses"]
    row = (
        next((e for e in found.episodes if (e.scenario, e.seed) == (scenario, seed) and e.trace), None)
        if found
        else None
    )
    if row is None:
        raise PageNotFound(f"job {job_id} found no witness for {scenario} seed {seed}")
    sides = []
    if found.evaluation is not None and found.failed_only:
        sides.append(
            (
                "planner",
                row.planner_outcome or "",
                trace_url(found.evaluation, scenario, seed),
                f"/ui/jobs/{found.evaluation}",
            )
        )
    sides.append(
        (
            "witness",
            row.plan.describe(),
            f"/v1/jobs/{job['id']}/witnesses/{scenario}/{seed}",
            f"/ui/jobs/{job['id']}",
        )
    )
    return page(
        request,
        "witness.html",
        title=f"{scenario} seed {seed}: a witness",
        nav="jobs",
        job=job,
        row=row,
        sides=sides,
    )


def _episodes(request: Request, job: dict[str, Any]) -> list[Any]:
    """An evaluation job's episodes (failures first) with their player links; none when it recorded none."""
    from foresight.api.routes.results import episode_list

    try:
        return episode_list(request.app.state.engine, request.app.state.settings, job["id"])
    except queue.JobNotFound:  # no evaluation row (e.g. one written before rows were kept)
        return []


@pages.get("/jobs/{job_id}")
def job_page(request: Request, job_id: str) -> Response:
    """One job: summary, error, spec, result, live log, report, artifacts, children (a short id redirects)."""
    try:
        full = job_reads.resolve_id(request.app.state.engine, job_id)
    except queue.JobNotFound as exc:
        raise PageNotFound(str(exc)) from None
    if full != job_id:
        return RedirectResponse(f"/ui/jobs/{full}", status_code=307)
    job = _job(request, job_id)
    return page(request, "job.html", title=f"Job {job_id}", nav="jobs", job=job)


@pages.get("/jobs/{job_id}/summary")
def job_summary(request: Request, job_id: str) -> HTMLResponse:
    """The summary block of a job's page (refreshed on status changes)."""
    return page(request, "_job_summary.html", job=_job(request, job_id))


@pages.get("/evaluations/{evaluation_id}/episodes/{scenario}/{seed}")
def episode_page(request: Request, evaluation_id: str, scenario: str, seed: Seed) -> HTMLResponse:
    """The episode player: the stored compact trace drawn on a canvas, with play/pause and a time slider (404
    for an episode the evaluation did not store)."""
    files.stored_trace(request, evaluation_id, scenario, seed)
    data_url = f"/v1/evaluations/{evaluation_id}/episodes/{scenario}/{seed}"
    return page(
        request,
        "episode.html",
        title=f"{scenario} seed {seed}",
        nav="results",
        scenario=scenario,
        seed=seed,
        data_url=data_url,
        source="evaluation",
        source_url=f"/ui/jobs/{evaluation_id}#episodes",
        source_id=evaluation_id,
    )


@pages.get("/compare/episode")
def episode_pair_page(
    request: Request,
    a: Annotated[str, Query(max_length=200)],
    b: Annotated[str, Query(max_length=200)],
    scenario: Annotated[str, Query(max_length=200)],
    seed: Seed,
) -> HTMLResponse:
    """One episode of two evaluations or campaign cells side by side on one clock (a comparison's changed episodes
    link here)."""
    from foresight.api.routes.results import full_id, trace_url
    from foresight.store import results

    engine = request.app.state.engine
    try:
        a, b = full_id(engine, a), full_id(engine, b)
        configs = [
            results.comparison_operand(engine, ident)[1] for ident in (a, b)
        ]  # evaluations or campaign cells
    except queue.JobNotFound as exc:
        raise PageNotFound(str(exc)) from None
    sides = [
        (
            side,
            ident,
            trace_url(ident, scenario, seed),
            f"/ui/jobs/{ident}" if ":" not in ident else f"/ui/campaigns/{ident.partition(':')[0]}",
            config.get("variant") if ":" in ident else None,
        )
        for side, ident, config in zip("AB", (a, b), configs, strict=True)
    ]
    return page(
        request,
        "episode_pair.html",
        title=f"{scenario} seed {seed}: A and B",
        nav="compare",
        a=a,
        b=b,
        scenario=scenario,
        seed=seed,
        sides=sides,
    )


PICKER_RUNS = 100  #: recent evaluations the compare page offers to pick


def _recent_runs(engine: Any) -> list[dict[str, str]]:
    """The compare page's pickers: recent evaluations (id, and what ran: planner, model, matrix, when, name)."""
    from foresight.store import listing

    out = []
    for item in listing.evaluations(engine, limit=PICKER_RUNS)[1]:
        row, stage = item.row, (item.row.config or {}).get("stage") or {}
        planner = (stage.get("planner") or {}).get("name", "?")
        model = row.model_id if row.model_id and row.model_id != "none" else None
        parts = [planner, model, stage.get("matrix"), ts(row.created_at)[:16], item.name]
        out.append({"id": row.id, "label": " · ".join(str(p) for p in parts if p)})
    return out


@pages.get("/compare")
def compare_page(
    request: Request,
    a: Annotated[str | None, Query(max_length=200)] = None,
    b: Annotated[str | None, Query(max_length=200)] = None,
) -> HTMLResponse:
    """Two evaluations or campaign cells: what differs first (planner, model, matrix, episodes, horizon), the
    metric deltas with their intervals and tests, then the config keys that differ."""
    from foresight.api.routes.results import compare_results
    from foresight.core.evaluation.stats import MIN_PAIRS

    cmp, error = None, None
    if a and b:
        try:
            cmp = compare_results(request.app.state.engine, request.app.state.settings, a, b)
        except queue.JobNotFound as exc:
            error = str(exc)
    return page(
        request,
        "compare.html",
        title="Compare",
        nav="compare",
        a=a,
        b=b,
        runs=_recent_runs(request.app.state.engine),
        cmp=cmp,
        error=error,
        min_pairs=MIN_PAIRS,
        status_code=404 if error else 200,
    )


router.include_router(forms.router)  # before pages: /ui/jobs/new is not a job id
router.include_router(pages)
router.include_router(catalog.router)
router.include_router(campaigns.router)
router.include_router(files.router)
