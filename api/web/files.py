"""Files under a job's artifact folder (reports with their figures, renders), and the dashboard's static files.

A report is served at ``/ui/jobs/<id>/files/report.html``, so its relative links (``figures/x.png``,
``campaign/report.html``) resolve to files of the same folder.
"""

from __future__ import annotations

import mimetypes
from pathlib import Path
from typing import Annotated

from fastapi import APIRouter, Depends, Request
from fastapi import Path as PathParam
from fastapi.responses import FileResponse

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
    if path.suffix in (".md", ".jsonl", ".log", ".yaml", ".csv"):
        media = "text/plain; charset=utf-8"
    return FileResponse(path, media_type=media, headers=headers)


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
