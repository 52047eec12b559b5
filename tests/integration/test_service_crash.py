"""SIGKILL a worker mid-job: another worker finishes it after the lease expires; the result is written once."""

from __future__ import annotations

import signal
import time

from sqlalchemy import select

from foresight.store import job_reads, queue
from foresight.store.session import make_engine

from .service import Service


def test_killed_worker_job_is_finished_by_another(service: Service) -> None:
    service.migrate()
    engine = make_engine(f"sqlite:///{service.tmp / 'data' / 'foresight.db'}")
    doomed = service.worker()
    job = queue.submit(
        engine, kind="sleep", spec={"kind": "sleep", "seconds": 2.0, "steps": 20, "artifact": "out.txt"}
    )[0]
    deadline = time.time() + 60
    while (row := job_reads.get_job(engine, job["id"]))["status"] != "running" and time.time() < deadline:
        time.sleep(0.05)
    assert f"-{doomed.pid}-" in row["lease_owner"]
    time.sleep(0.3)
    doomed.send_signal(signal.SIGKILL)
    doomed.wait()
    survivor = service.worker()
    deadline = time.time() + 60
    while (row := job_reads.get_job(engine, job["id"]))["status"] != "succeeded" and time.time() < deadline:
        time.sleep(0.1)
    assert row["status"] == "succeeded", service.logs()
    assert row["attempts"] == 2 and f"-{survivor.pid}-" in row["lease_owner"]
    with engine.connect() as conn:
        arts = conn.execute(select(queue.artifacts).where(queue.artifacts.c.job_id == job["id"])).all()
        finishes = conn.execute(
            select(queue.events.c.id).where(
                queue.events.c.job_id == job["id"], queue.events.c.message == "succeeded"
            )
        ).all()
    assert [a.name for a in arts] == ["out.txt"] and len(finishes) == 1
    engine.dispose()
