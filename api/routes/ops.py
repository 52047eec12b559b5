"""Operations: health, workers and queue depth, Prometheus metrics."""

from __future__ import annotations

import time

from fastapi import APIRouter, Request
from fastapi.responses import PlainTextResponse

from foresight.api.deps import EngineDep, SettingsDep
from foresight.api.schemas import Health, WorkerPublic, WorkersPublic, iso
from foresight.core.jobs.kinds import KINDS
from foresight.store import queue

router = APIRouter(tags=["operations"])  #: always open (liveness probes carry no token)
#: reads: the app adds the read-auth dependency when reads are closed, so the schema's security matches
read_router = APIRouter(tags=["operations"])


def _alive_cutoff(settings) -> float:  # noqa: ANN001
    """Workers silent for longer than this are not alive (three missed heartbeats, at least a lease)."""
    return time.time() - max(3 * settings.heartbeat_s, settings.lease_s)


@router.get("/healthz")
def read_health(request: Request, engine: EngineDep) -> Health:
    """Liveness and database reachability."""
    return Health(
        status="ok", database=queue.ping(engine), revision=request.app.state.revision, kinds=sorted(KINDS)
    )


@read_router.get("/v1/workers")
def read_workers(engine: EngineDep, settings: SettingsDep) -> WorkersPublic:
    """Alive workers with their current jobs, and the queue depth per kind."""
    data = [
        WorkerPublic(id=r["id"], host=r["host"], pid=r["pid"], concurrency=r["concurrency"], kinds=r["kinds"],
                     started_at=iso(r["started_at"]), heartbeat_at=iso(r["heartbeat_at"]), jobs=r["jobs"])
        for r in queue.alive_workers(engine, _alive_cutoff(settings))
    ]  # fmt: skip
    return WorkersPublic(data=data, count=len(data), queue=queue.depth(engine))


@read_router.get("/metrics", response_class=PlainTextResponse)
def read_metrics(request: Request, engine: EngineDep, settings: SettingsDep) -> PlainTextResponse:
    """Prometheus text format: jobs per kind and status, alive workers, oldest queued job age, and this
    server process's HTTP requests by method, route and status class with their latency histogram."""
    lines = [
        "# HELP foresight_jobs Jobs per kind and status.",
        "# TYPE foresight_jobs gauge",
    ]
    for kind, counts in sorted(queue.depth(engine).items()):
        for status, count in sorted(counts.items()):
            lines.append(f'foresight_jobs{{kind="{kind}",status="{status}"}} {count}')
    alive = queue.alive_workers(engine, _alive_cutoff(settings))
    oldest = queue.oldest_queued_at(engine)
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
