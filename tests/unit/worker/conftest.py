"""A migrated SQLite file and a worker running in a background thread."""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator

import pytest

from foresight.store.settings import Settings


@pytest.fixture
def start_worker(settings: Settings, engine) -> Iterator[Callable]:  # noqa: ANN001
    from foresight.worker.runner import JobWorker

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
