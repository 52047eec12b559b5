"""Files under a job's artifact folder (reports with their figures, renders), and the dashboard's static files.

A report is served at ``/ui/jobs/<id>/files/report.html``, so its relative links (``figures/x.png``,
``campaign/report.html``) resolve to files of the same folder.
"""

from __future__ import annotations

import mimetypes
from pathlib import Path
from typing import Annotated
from urllib.parse import quote

from fastapi import APIRouter, Depends, Request
from fastapi import Path as PathParam
from fastapi.responses import FileResponse, HTMLResponse, RedirectResponse

from foresight.api.web.auth import PageNotFound, read_access
from foresight.api.web.render import HERE
from foresight.store import folders, job_reads, queue

router = APIRouter(include_in_schema=False)
STATIC = HERE / "static"
REPORT = "report.html"
#: pages a job may show: no scripts, no plugins, nothing loaded from other origins
HTML_POLICY = "default-src 'self'; script-src 'none'; object-src 'none'; style-src 'self' 'unsafe-inline'"


def job_folder(request: Request, job_id: str) -> Path:
    root = request.app.state.settings.store_root
    return folders.resolve_under(root, folders.job_dir(root, job_id))


def report_of(request: Request, job_id: str) -> str | None:
    """URL of the job's report page, when its folder holds one."""
    if (job_folder(request, job_id) / REPORT).is_file():
        return f"/ui/jobs/{job_id}/files/{REPORT}"
    return None


NAV = (
    '<nav class="foresight-nav" style="font:14px system-ui,sans-serif;padding:6px 10px;margin:0 0 12px;'
    'background:#f3f5f7;border-bottom:1px solid #d0d7de">'
    '<a href="/ui/jobs/{job}" target="_top">&larr; job {short}</a> &middot; <a href="/ui/results" target="_top">'
    'Results</a> &middot; <a href="/ui/jobs" target="_top">Jobs</a>{up}</nav>'
)


def with_navigation(html: str, job_id: str, name: str) -> str:
    """A report page with a bar of links back to its job, Results and Jobs (and to the job's main report from a
    nested one), inserted after ``<body>``; the file on disk stays self-contained."""
    up = (
        f' &middot; <a href="/ui/jobs/{job_id}/files/{REPORT}" target="_top">main report</a>'
        if name != REPORT
        else ""
    )
    bar = NAV.format(job=job_id, short=job_id[:12], up=up)
    at = html.find(">", html.find("<body")) + 1 if "<body" in html else 0
    return html[:at] + bar + html[at:]


@router.get("/ui/jobs/{job_id}/files/player/{stem}.html", dependencies=[Depends(read_access)])
def report_player_link(job_id: Annotated[str, PathParam(max_length=200)], stem: str) -> RedirectResponse:
    """A report's episode link (``player/<scenario>__<seed>.html``, core.reports.evaluation.player_path): the
    dashboard's player of that episode."""
    scenario, _, seed = stem.rpartition("__")
    if not scenario or not seed.isdigit():
        raise PageNotFound(f"no episode {stem!r}: expected <scenario>__<seed>")
    return RedirectResponse(f"/ui/evaluations/{job_id}/episodes/{quote(scenario)}/{seed}", status_code=307)


@router.get("/ui/jobs/{job_id}/files/{name:path}", dependencies=[Depends(read_access)])
def read_job_file(
    request: Request, job_id: Annotated[str, PathParam(max_length=200)], name: str
) -> FileResponse:
    """One file of a job's folder, shown inline (HTML without scripts)."""
    try:
        job_reads.get_job(request.app.state.engine, job_id)
    except queue.JobNotFound:
        raise PageNotFound(f"no job {job_id}") from None
    folder = job_folder(request, job_id)
    path = folders.resolve_under(folder, name)
    if not path.is_file():
        raise PageNotFound(f"job {job_id} has no file {name}")
    media = mimetypes.guess_type(path.name)[0] or "application/octet-stream"
    headers = {"Content-Security-Policy": HTML_POLICY} if media == "text/html" else {}
    if media == "text/html" and path.name == REPORT:  # a report page links back into the dashboard
        html = with_navigation(path.read_text(encoding="utf-8"), job_id, name)
        return HTMLResponse(html, headers=headers)
    if path.suffix in (".md", ".jsonl", ".log", ".yaml", ".csv"):
        media = "text/plain; charset=utf-8"
    return FileResponse(path, media_type=media, headers=headers)


@router.get("/favicon.ico")
def read_favicon() -> FileResponse:
    """The tab icon browsers ask every site for (a PNG: every browser reads one under this name)."""
    return FileResponse(
        STATIC / "favicon.png", media_type="image/png", headers={"Cache-Control": "max-age=86400"}
    )


@router.get("/ui/static/{name}")
def read_static(name: str) -> FileResponse:
    """The dashboard's CSS and scripts (no CDN: the pages work offline); the episode player is core's."""
    from foresight.core.render.player import PLAYER_JS

    files = {p.name: p for p in STATIC.iterdir() if p.is_file()} | {PLAYER_JS.name: PLAYER_JS}
    if name not in files:
        raise PageNotFound(f"no static file {name}")
    return FileResponse(files[name], headers={"Cache-Control": "no-cache"})


def stored_trace(request: Request, ident: str, scenario: str, seed: int) -> None:
    """PageNotFound unless the evaluation or campaign cell ``ident`` stored this episode's trace."""
    from foresight.core.render.episode_trace import trace_name
    from foresight.store import results

    try:
        folder = results.run_folder(request.app.state.engine, request.app.state.settings.store_root, ident)
    except queue.JobNotFound as exc:
        raise PageNotFound(str(exc)) from None
    if folder is None or folder.trace(trace_name(scenario, seed)) is None:
        raise PageNotFound(f"{ident} stored no episode {scenario} seed {seed}")
