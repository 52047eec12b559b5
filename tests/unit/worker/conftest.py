"""A migrated SQLite file and a worker running in a background thread."""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from api.db.session import make_engine, upgrade
from api.settings import Settings


@pytest.fixture
def settings(tmp_path: Path) -> Settings:
    s = Settings(data_dir=tmp_path, api_token="t", lease_s=2.0, heartbeat_s=0.2, poll_s=0.05, shutdown_grace_s=0.3,
                 model_registry=tmp_path / "none.yaml")  # fmt: skip
    upgrade(s.resolved_database_url)
    return s


@pytest.fixture
def engine(settings: Settings) -> Iterator:
    eng = make_engine(settings.resolved_database_url)
    yield eng
    eng.dispose()


@pytest.fixture
def start_worker(settings: Settings, engine) -> Iterator[Callable]:  # noqa: ANN001
    from worker.runner import JobWorker

    started: list[tuple[JobWorker, threading.Thread]] = []

    def start(concurrency: int = 1, **overrides) -> JobWorker:  # noqa: ANN003
        worker = JobWorker(settings.model_copy(update=overrides), engine, concurrency=concurrency)
        thread = threading.Thread(target=worker.run, daemon=True)
        thread.start()
        started.append((worker, thread))
        return worker

    yield start
    for worker, thread in started:
        worker.stop()
        worker.stop()
        thread.join(timeout=10)
