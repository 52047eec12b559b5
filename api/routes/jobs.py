"""Jobs: submit, list, read, follow (server-sent events), cancel, retry, delete, download artifacts."""

from __future__ import annotations

import asyncio
import json
import time
from collections.abc import AsyncIterator
from typing import Annotated, Any, Literal

from fastapi import APIRouter, Depends, Header, HTTPException, Path, Query, Request, Response, status
from fastapi.exceptions import RequestValidationError
from fastapi.responses import FileResponse, StreamingResponse
from starlette.concurrency import run_in_threadpool

from foresight.api import admission
from foresight.api.bodies import BoundedJsonRoute
from foresight.api.deps import EngineDep, ResolverDep, SettingsDep, WriteAuth
from foresight.api.errors import AUTH, responses
from foresight.api.schemas import MAX_TAGS, Ident, JobCreate, JobUpdate, Tag, job_public
from foresight.core.jobs.kinds import KINDS
from foresight.schemas import JobPublic, JobsPublic, KindPublic
from foresight.store import folders, job_files, job_reads, labels, queue, space
from foresight.store.models import JobStatus

router = APIRouter(prefix="/jobs", tags=["jobs"], route_class=BoundedJsonRoute)


async def full_job_id(
    job_id: Annotated[Ident, Path(description="a job id or a unique prefix of 8+ characters")],
    request: Request,
) -> str:
    """The job's full id (a short id, as the CLI prints, is resolved)."""
    engine = request.app.state.engine
    if len(job_id) >= 32:
        return job_id
    return await run_in_threadpool(job_reads.resolve_id, engine, job_id)


JobId = Annotated[str, Depends(full_job_id)]

MAX_SPEC_BYTES = 1 << 20  #: [bytes] request body limit of a submission
SSE_POLL_S = 0.3  #: [s] event polling interval of a stream
MAX_EVENT_ID = 2**63 - 1  #: event ids are 64-bit integers in every database
KindName = Literal[tuple(KINDS)]  # type: ignore[valid-type]


def unsafe_paths(value: Any, loc: tuple = ()) -> list[dict[str, Any]]:
    """Validation errors for every spec string that is an absolute path or climbs out with '..'."""
    if isinstance(value, dict):
        return [e for k, v in value.items() for e in unsafe_paths(v, (*loc, k))]
    if isinstance(value, list):
        return [e for i, v in enumerate(value) for e in unsafe_paths(v, (*loc, i))]
    if isinstance(value, str) and folders.looks_unsafe(value):
        msg = "server paths are not allowed in specs: name inputs by id or by a path relative to their bundle"
        return [
            {"loc": ("body", "spec", *loc), "msg": msg, "type": "value_error.unsafe_path", "input": value}
        ]
    return []


@router.get("/kinds")
def read_job_kinds() -> list[KindPublic]:
    """The job kinds this server accepts, with their spec schemas."""
    return [
        KindPublic(kind=k.name, description=k.description, spec_schema=k.spec.model_json_schema())
        for k in KINDS.values()
    ]


async def limit_body(content_length: Annotated[int | None, Header(include_in_schema=False)] = None) -> None:
    """413 before the body is validated (dependencies run first)."""
    if content_length is not None and content_length > MAX_SPEC_BYTES:
        raise HTTPException(
            status.HTTP_413_REQUEST_ENTITY_TOO_LARGE, f"request body over {MAX_SPEC_BYTES} bytes"
        )


@router.post(
    "",
    status_code=status.HTTP_201_CREATED,
    dependencies=[WriteAuth, Depends(limit_body)],
    response_model=JobPublic,
    responses={
        200: {"model": JobPublic, "description": "the job of a known idempotency key"},
        **responses(*AUTH, 404, 409, 413),
    },
)
async def create_job(
    body: JobCreate, engine: EngineDep, settings: SettingsDep, resolver: ResolverDep
) -> Response:
    """Queue a job (201); a known idempotency key returns its job (200). Stage jobs must name known inputs
    (404) and fit the server's step budget (422); a job without ``timeout_s`` gets the server's default."""
    # async: the body is validated on the event loop anyway; the queue decides per database how the job is written
    # (on SQLite a plain submission waits on the submission thread without holding a thread)
    body.spec = await run_in_threadpool(admission.full_ids, body.spec, engine)
    spec = body.spec.model_dump(mode="json")
    errors = unsafe_paths(spec)
    if errors:
        raise RequestValidationError(errors)
    if (
        spec["kind"] != "sleep"
    ):  # the diagnostic kind has no inputs and no episodes (queue benchmarks submit it)
        await run_in_threadpool(admission.admit, body.spec, settings, resolver)
    job, created = await queue.submit_async(
        engine,
        kind=spec["kind"],
        spec=spec,
        priority=body.priority,
        timeout_s=body.timeout_s or settings.job_timeout_s,
        max_attempts=body.max_attempts or settings.max_attempts,
        idempotency_key=body.idempotency_key,
        parent_id=body.parent_id,
        labels=body.labels(),
    )
    code = status.HTTP_201_CREATED if created else status.HTTP_200_OK
    return Response(job_public(job).model_dump_json(), status_code=code, media_type="application/json")


@router.get("")
def read_jobs(
    engine: EngineDep,
    status_: Annotated[list[JobStatus] | None, Query(alias="status")] = None,
    kind: Annotated[list[KindName] | None, Query(max_length=50)] = None,
    parent_id: Ident | None = None,
    name: Annotated[str | None, Query(min_length=1, max_length=200, description="exact job name")] = None,
    tag: Annotated[list[Tag], Query(max_length=MAX_TAGS, description="jobs with every tag given")] = [],  # noqa: B006
    q: Annotated[
        str | None, Query(min_length=1, max_length=200, description="text in the name or note")
    ] = None,
    limit: Annotated[int, Query(ge=1, le=500)] = 50,
    offset: Annotated[int, Query(ge=0, le=10_000_000)] = 0,
) -> JobsPublic:
    """Jobs, newest first, filtered by status, kind, parent, name, tags (all of them) and free text."""
    count, rows = job_reads.list_jobs(
        engine,
        statuses=[s.value for s in status_ or ()],
        kinds=kind or (),
        parent_id=parent_id,
        name=name,
        tags=tag,
        q=q,
        limit=limit,
        offset=offset,
    )
    return JobsPublic(data=[job_public(r) for r in rows], count=count, limit=limit, offset=offset)


@router.get("/{job_id}", response_model=JobPublic, responses=responses(404))
async def read_job(job_id: JobId, request: Request) -> Response:
    """One job: status, progress, timestamps, error, result summary, artifacts and children."""
    # The most frequent request (clients polling): the store reads it inline or in a thread, as suits the
    # database; the body is serialised once, straight from the response model.
    row, artifacts, children = await job_reads.job_detail_async(request.app.state.engine, job_id)
    body = job_public(row, artifacts, [c["id"] for c in children]).model_dump_json().encode()
    return Response(body, media_type="application/json")


async def _sse(engine: Any, job_id: str, after: int) -> AsyncIterator[str]:
    """Events as SSE frames until the job is finished and its events are drained.

    An async generator: a waiting stream holds no thread-pool thread (a sync generator would hold one per
    open stream and starve the other endpoints); its queries run in the pool.
    """
    last_ping = time.monotonic()
    while True:
        batch = await run_in_threadpool(job_reads.events_after, engine, job_id, after)
        for ev in batch:
            after = ev["id"]
            data = {"type": ev["type"], "at": ev["at"], "message": ev["message"], "progress": ev["progress"]}
            yield f"id: {ev['id']}\nevent: {ev['type']}\ndata: {json.dumps(data)}\n\n"
        if batch:
            continue
        try:
            job = await run_in_threadpool(job_reads.get_job, engine, job_id)
        except queue.JobNotFound:
            return
        if job["status"] not in (queue.QUEUED, queue.RUNNING):
            if not await run_in_threadpool(job_reads.events_after, engine, job_id, after, 1):
                yield f"event: end\ndata: {json.dumps({'status': job['status']})}\n\n"
                return
            continue
        if time.monotonic() - last_ping > 15:
            last_ping = time.monotonic()
            yield ": keep-alive\n\n"
        await asyncio.sleep(SSE_POLL_S)


@router.get(
    "/{job_id}/events",
    response_class=StreamingResponse,
    responses={200: {"content": {"text/event-stream": {}}}, **responses(404)},
)
def read_job_events(
    job_id: JobId,
    engine: EngineDep,
    last_event_id: Annotated[int | None, Header(ge=0, le=MAX_EVENT_ID)] = None,
    after: Annotated[int, Query(ge=0, le=MAX_EVENT_ID)] = 0,
) -> StreamingResponse:
    """Progress, log and status lines as server-sent events; ends with an ``end`` event."""
    job_reads.get_job(engine, job_id)
    start = last_event_id if last_event_id is not None else after
    return StreamingResponse(
        _sse(engine, job_id, start), media_type="text/event-stream", headers={"Cache-Control": "no-cache"}
    )


@router.patch("/{job_id}", dependencies=[WriteAuth], responses=responses(*AUTH, 404))
def update_job(job_id: JobId, body: JobUpdate, engine: EngineDep) -> JobPublic:
    """Rename a job, edit its tags or note (any status; the spec and result never change)."""
    fields = body.model_fields_set
    found = labels.edit(
        engine,
        job_id,
        name=body.name if "name" in fields else labels.UNSET,
        note=body.note if "note" in fields and body.note is not None else labels.UNSET,
        tags=body.tags,
        add=body.add_tags,
        remove=body.remove_tags,
    )
    if not found:
        raise queue.JobNotFound(f"no job with id {job_id!r}")
    return job_public(job_reads.get_job(engine, job_id))


@router.post("/{job_id}/cancel", dependencies=[WriteAuth], responses=responses(*AUTH, 404, 409))
def cancel_job(job_id: JobId, engine: EngineDep) -> JobPublic:
    """Cancel a queued job, or ask a running job's worker to stop it (409 when already finished)."""
    queue.request_cancel(engine, job_id)
    return job_public(job_reads.get_job(engine, job_id))


@router.post("/{job_id}/retry", dependencies=[WriteAuth], responses=responses(*AUTH, 404, 409))
def retry_job(job_id: JobId, engine: EngineDep) -> JobPublic:
    """Queue a failed or cancelled job again (409 otherwise)."""
    return job_public(queue.retry(engine, job_id))  # as queued, even when a worker claims it at once


@router.delete(
    "/{job_id}",
    status_code=status.HTTP_204_NO_CONTENT,
    dependencies=[WriteAuth],
    responses=responses(*AUTH, 404, 409),
)
def delete_job(job_id: JobId, engine: EngineDep, settings: SettingsDep) -> Response:
    """Delete a finished job and its whole folder (partial files of a failed run too), keeping files that a
    model or dataset record uses; works on a full disk (files first, then the server's reserve)."""
    job_files.delete_job_and_files(
        engine, settings.store_root, job_id, on_full=lambda: space.release_reserve(settings)
    )
    return Response(status_code=status.HTTP_204_NO_CONTENT)


@router.get(
    "/{job_id}/artifacts/{name:path}",
    response_class=FileResponse,
    responses={200: {"content": {"application/octet-stream": {}}}, **responses(404)},
)
def read_job_artifact(
    job_id: JobId, name: str, engine: EngineDep, settings: SettingsDep, request: Request
) -> FileResponse:
    """Download one artifact of a job."""
    clean = folders.check_relative(name)  # 422 for absolute names and '..'
    row = job_reads.find_artifact(engine, job_id, clean)
    path = folders.resolve_under(settings.store_root, row["path"])
    if not path.is_file():
        raise queue.JobNotFound(f"artifact {clean!r} of job {job_id} is missing from the store")
    return FileResponse(path, filename=path.name)
