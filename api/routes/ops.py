"""Operations: health, workers and queue depth, Prometheus metrics."""

from __future__ import annotations

import time

from fastapi import APIRouter, Request
from fastapi.responses import PlainTextResponse
from sqlalchemy import select, text

from foresight.api.deps import EngineDep, SettingsDep
from foresight.api.schemas import Health, WorkerPublic, WorkersPublic, iso
from foresight.core.stages.kinds import KINDS
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
    with engine.connect() as conn:
        conn.execute(text("SELECT 1"))
    return Health(status="ok", database=engine.dialect.name, revision=request.app.state.revision, kinds=sorted(KINDS))


@read_router.get("/v1/workers")
def read_workers(engine: EngineDep, settings: SettingsDep) -> WorkersPublic:
    """Alive workers with their current jobs, and the queue depth per kind."""
    w, j = queue.workers, queue.jobs
    with engine.connect() as conn:
        rows = conn.execute(
            select(w).where(w.c.stopped_at.is_(None), w.c.heartbeat_at >= _alive_cutoff(settings)).order_by(w.c.started_at)
        ).mappings().all()
        running = conn.execute(select(j.c.id, j.c.lease_owner).where(j.c.status == queue.RUNNING)).all()
    held: dict[str, list[str]] = {}
    for job_id, owner in running:
        held.setdefault(owner, []).append(job_id)
    data = [
        WorkerPublic(id=r["id"], host=r["host"], pid=r["pid"], concurrency=r["concurrency"], kinds=r["kinds"],
                     started_at=iso(r["started_at"]), heartbeat_at=iso(r["heartbeat_at"]), jobs=held.get(r["id"], []))
        for r in rows
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
    w, j = queue.workers, queue.jobs
    with engine.connect() as conn:
        alive = conn.execute(
            select(w.c.id).where(w.c.stopped_at.is_(None), w.c.heartbeat_at >= _alive_cutoff(settings))
        ).all()
        oldest = conn.execute(select(j.c.created_at).where(j.c.status == queue.QUEUED).order_by(j.c.created_at).limit(1)).scalar()
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
