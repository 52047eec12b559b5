"""Migrating an empty database to head gives exactly the models' schema; un-migrated databases are refused."""

from __future__ import annotations

from pathlib import Path

import pytest
from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext

from foresight.store.models import Base
from foresight.store.session import NotMigratedError, check_migrated, make_engine, upgrade


def _diff(url: str) -> list:
    engine = make_engine(url)
    with engine.connect() as conn:
        diff = compare_metadata(MigrationContext.configure(conn), Base.metadata)
    engine.dispose()
    return diff


def test_sqlite_head_matches_models(tmp_path: Path) -> None:
    url = f"sqlite:///{tmp_path / 'm.db'}"
    upgrade(url)
    assert _diff(url) == []
    check_migrated(make_engine(url))


@pytest.mark.parametrize(
    ("filters", "index"),
    [
        ({}, "ix_jobs_created"),
        ({"statuses": ["queued"]}, "ix_jobs_status_created"),
        ({"kinds": ["train"]}, "ix_jobs_kind_created"),
    ],
)
def test_job_list_pages_are_read_off_an_index(tmp_path: Path, filters: dict, index: str) -> None:
    """The job list's page query walks an index in its order: no temporary B-tree sorts every matching job."""
    from foresight.store import job_reads

    url = f"sqlite:///{tmp_path / 'm.db'}"
    upgrade(url)
    engine = make_engine(url)
    query = job_reads.list_page_query(job_reads.list_filter(**filters), 50, 100)
    sql = str(query.compile(engine, compile_kwargs={"literal_binds": True}))
    with engine.connect() as conn:
        plan = " | ".join(row[3] for row in conn.exec_driver_sql("EXPLAIN QUERY PLAN " + sql))
    engine.dispose()
    assert f"USING INDEX {index}" in plan and "TEMP B-TREE" not in plan, plan


def test_unmigrated_database_is_refused(tmp_path: Path) -> None:
    engine = make_engine(f"sqlite:///{tmp_path / 'empty.db'}")
    with pytest.raises(NotMigratedError, match="foresight db upgrade"):
        check_migrated(engine)


def test_app_refuses_unmigrated_database(tmp_path: Path) -> None:
    from foresight.api.main import create_app
    from foresight.store.settings import Settings

    with pytest.raises(NotMigratedError):
        create_app(Settings(data_dir=tmp_path, api_token="t"))


def test_sqlite_uses_wal_and_busy_timeout(tmp_path: Path) -> None:
    engine = make_engine(f"sqlite:///{tmp_path / 'w.db'}", busy_timeout_ms=1234)
    with engine.connect() as conn:
        assert conn.exec_driver_sql("PRAGMA journal_mode").scalar() == "wal"
        assert conn.exec_driver_sql("PRAGMA busy_timeout").scalar() == 1234


def test_postgres_head_matches_models(pg_url: str) -> None:
    upgrade(pg_url)
    assert _diff(pg_url) == []
