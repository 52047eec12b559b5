"""Fixtures for the API tests: a migrated SQLite file, settings pointing at a temp data dir, an app client."""

from __future__ import annotations

import shutil
import warnings
from pathlib import Path

import pytest

from foresight.store.session import make_engine, upgrade
from foresight.store.settings import Settings

TOKEN = "test-token"


@pytest.fixture(scope="session")
def migrated_template(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One migrated SQLite file per session; tests copy it (migrating each time costs ~0.3 s)."""
    path = tmp_path_factory.mktemp("template") / "foresight.db"
    upgrade(f"sqlite:///{path}")
    return path


@pytest.fixture
def settings(tmp_path: Path, migrated_template: Path) -> Settings:
    (tmp_path / "data").mkdir()
    shutil.copyfile(migrated_template, tmp_path / "data" / "foresight.db")
    s = Settings(
        data_dir=tmp_path / "data",
        api_token=TOKEN,
        lease_s=2.0,
        heartbeat_s=0.2,
        poll_s=0.05,
        shutdown_grace_s=0.5,
        model_registry=tmp_path / "registry.yaml",
    )
    return s


@pytest.fixture
def engine(settings: Settings):  # noqa: ANN201
    eng = make_engine(settings.resolved_database_url)
    yield eng
    eng.dispose()


@pytest.fixture
def client(settings: Settings):  # noqa: ANN201
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        from fastapi.testclient import TestClient
    from foresight.api.main import create_app

    with TestClient(create_app(settings), raise_server_exceptions=False) as c:
        yield c


@pytest.fixture
def auth() -> dict[str, str]:
    return {"Authorization": f"Bearer {TOKEN}"}
