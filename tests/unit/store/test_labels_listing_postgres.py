"""Job labels and the result lists' JSON-path filters on PostgreSQL (the scale-out database), as on SQLite:
tags written by the PostgreSQL submission path, edited, and filtered with a record's planner, matrix and verdict."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from foresight.store import job_reads, labels, listing, queue, records
from foresight.store.session import make_engine, upgrade
from tests.unit.reports import data


@pytest.fixture
def pg(pg_url: str) -> Iterator:  # noqa: ANN401
    """An engine on a fresh PostgreSQL database migrated to head."""
    upgrade(pg_url)
    engine = make_engine(pg_url)
    yield engine
    engine.dispose()


def test_labels_and_record_filters_on_postgres(pg) -> None:  # noqa: ANN001
    job, _ = queue.submit(
        pg,
        kind="evaluate",
        spec={"kind": "evaluate"},
        labels={"name": "n1", "tags": ["a", "b"], "note": "Hello there"},
    )
    assert job_reads.get_job(pg, job["id"])["tags"] == ["a", "b"]
    claimed = queue.claim(pg, "w", ["evaluate"], 30)
    result = data.evaluation(failures=True)
    result["config"] = {**result.get("config", {}), "matrix": "m.yaml", "planner": {"name": "orca"}}
    queue.finish(pg, job["id"], "w", claimed["attempts"], result)
    with pg.begin() as conn:
        records.RECORDERS["evaluate"](conn, job_reads.get_job(pg, job["id"]), result, "")
    assert (
        job_reads.list_jobs(pg, tags=["a", "b"], q="HELLO")[0] == 1
        and job_reads.list_jobs(pg, tags=["c"])[0] == 0
    )
    assert labels.edit(pg, job["id"], add=["c"], remove=["a"])
    assert (
        job_reads.get_job(pg, job["id"])["tags"] == ["b", "c"] and job_reads.list_jobs(pg, tags=["a"])[0] == 0
    )
    count, rows = listing.evaluations(
        pg, planner="orca", matrix="m.yaml", verdict="failed_gate", tags=["c"], name="n1"
    )
    assert count == 1 and rows[0].name == "n1" and rows[0].tags == ["b", "c"]
    assert listing.evaluations(pg, planner="goal")[0] == 0
    assert listing.campaigns(pg, matrix="m.yaml", model="cv", tags=["c"])[0] == 0
