"""Operations: health, workers and queue depth, Prometheus metrics."""

from __future__ import annotations

import time

from fastapi import APIRouter, Request
from fastapi.responses import PlainTextResponse

from foresight.api.deps import EngineDep, SettingsDep
from foresight.api.schemas import iso
from foresight.core.jobs.kinds import KINDS
from foresight.schemas import DiskPublic, Health, WorkerPublic, WorkersPublic
from foresight.store import job_reads, space

router = APIRouter(tags=["operations"])  #: always open (liveness probes carry no token)
#: reads: the app adds the read-auth dependency when reads are closed, so the schema's security matches
read_router = APIRouter(tags=["operations"])


def _alive_cutoff(settings) -> float:  # noqa: ANN001
    """Workers silent for longer than this are not alive (three missed heartbeats, at least a lease)."""
    return time.time() - max(3 * settings.heartbeat_s, settings.lease_s)


FULL_RECENTLY_S = 10.0  #: [s] a request that met a full disk this recently keeps /healthz degraded


@router.get("/healthz")
def read_health(request: Request, engine: EngineDep, settings: SettingsDep) -> Health:
    """Liveness, database reachability and free disk space ("degraded" while a disk is full)."""
    state = space.disk_state(settings)
    full_at = request.app.state.full_at
    full = bool(state["full"]) or (full_at is not None and time.time() - full_at < FULL_RECENTLY_S)
    if not full:
        space.keep_reserve(settings)  # back once there is room again
    status = "degraded: the disk of the store or the database is full" if full else "ok"
    return Health(
        status=status,
        database=job_reads.ping(engine),
        revision=request.app.state.revision,
        kinds=sorted(KINDS),
        disk=DiskPublic(**{**state, "full": full}),
    )


@read_router.get("/v1/workers")
def read_workers(engine: EngineDep, settings: SettingsDep) -> WorkersPublic:
    """Alive workers with their current jobs, and the queue depth per kind."""
    data = [
        WorkerPublic(
            id=r["id"],
            host=r["host"],
            pid=r["pid"],
            concurrency=r["concurrency"],
            kinds=r["kinds"],
            started_at=iso(r["started_at"]),
            heartbeat_at=iso(r["heartbeat_at"]),
            jobs=r["jobs"],
        )
        for r in job_reads.alive_workers(engine, _alive_cutoff(settings))
    ]
    return WorkersPublic(data=data, count=len(data), queue=job_reads.depth(engine))


@read_router.get("/metrics", response_class=PlainTextResponse)
def read_metrics(request: Request, engine: EngineDep, settings: SettingsDep) -> PlainTextResponse:
    """Prometheus text format: jobs per kind and status, alive workers, oldest queued job age, and this
    server process's HTTP requests by method, route and status class with their latency histogram."""
    lines = [
        "# HELP foresight_jobs Jobs per kind and status.",
        "# TYPE foresight_jobs gauge",
    ]
    for kind, counts in sorted(job_reads.depth(engine).items()):
        for status, count in sorted(counts.items()):
            lines.append(f'foresight_jobs{{kind="{kind}",status="{status}"}} {count}')
    alive = job_reads.alive_workers(engine, _alive_cutoff(settings))
    oldest = job_reads.oldest_queued_at(engine)
    lines += [
        "# HELP foresight_workers_alive Workers with a recent heartbeat.",
        "# TYPE foresight_workers_alive gauge",
        f"foresight_workers_alive {len(alive)}",
        "# HELP foresight_queue_oldest_age_seconds Age of the oldest queued job.",
        "# TYPE foresight_queue_oldest_age_seconds gauge",
        f"foresight_queue_oldest_age_seconds {time.time() - oldest if oldest else 0:.3f}",
        *request.app.state.http_metrics.exposition(),
    ]
    return PlainTextResponse("\n".join(lines) + "\n", media_type="text/plain; version=0.0.4")
