"""Shared fixtures. Tests read ../shared only through FORESIGHT_SHARED (default: ../shared next to the repo)."""

from __future__ import annotations

import os
import uuid
from collections.abc import Iterator
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent


def pytest_configure(config: pytest.Config) -> None:
    """Tests never touch the user's own data folder (~/.local/share/foresight): processes that set no
    FORESIGHT_DATA_DIR of their own (servers, --local runs without --out) share one temporary folder."""
    import tempfile

    os.environ["FORESIGHT_DATA_DIR"] = tempfile.mkdtemp(prefix="foresight-test-data-")


def pytest_unconfigure(config: pytest.Config) -> None:
    import shutil

    shutil.rmtree(os.environ.get("FORESIGHT_DATA_DIR", ""), ignore_errors=True)


#: test modules that start Ray: run in one test process, one after the other (two clusters at once contend for Ray's
#: fixed default ports and the two cores)
RAY_MODULES = {"tests/integration/test_ray_cluster.py", "tests/integration/test_ray_executor.py"}


def pytest_xdist_make_scheduler(config: pytest.Config, log):  # noqa: ANN001, ANN201
    """``make test`` (``-n 2 --dist loadscope``): each test module runs whole in one process, so a module fixture
    (a service, a wheel install, an MLflow server) is built once, and the Ray modules share one process."""
    if config.getvalue("dist") != "loadscope":
        return None
    from xdist.scheduler import LoadScopeScheduling

    class ModuleScheduling(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            module = nodeid.split("::", 1)[0]
            return "ray" if module in RAY_MODULES else module

    return ModuleScheduling(config, log)


def shared_root() -> Path:
    """The shared material folder: $FORESIGHT_SHARED, else ../shared beside the repository."""
    return Path(os.environ.get("FORESIGHT_SHARED", REPO.parent / "shared")).resolve()


@pytest.fixture(scope="session")
def shared_dir() -> Path:
    root = shared_root()
    if not (root / "reference").is_dir():
        msg = f"shared material not found at {root} (set FORESIGHT_SHARED)"
        if os.environ.get("CI") == "true":
            pytest.fail(msg)
        pytest.skip(msg)
    return root


@pytest.fixture(scope="session")
def reference_dir(shared_dir: Path) -> Path:
    """The reference system's classic matrix files (robot_sf)."""
    return shared_dir / "reference" / "robot_sf"


@pytest.fixture(scope="session")
def corpus_dir(shared_dir: Path) -> Path:
    """The reference's wider scenario corpus (robot_sf_corpus: configs/scenarios, maps)."""
    return shared_dir / "reference" / "robot_sf_corpus"


@pytest.fixture(scope="session")
def reference_matrix_path(reference_dir: Path) -> Path:
    return reference_dir / "configs" / "scenarios" / "classic_interactions.yaml"


PG_DSN = "host=127.0.0.1 port=5432 user=postgres dbname=test"


def pg_available() -> str | None:
    """None when the PostgreSQL at 127.0.0.1:5432 answers, else why not."""
    import psycopg

    try:
        psycopg.connect(PG_DSN, connect_timeout=3).close()
    except Exception as exc:  # noqa: BLE001
        return str(exc)
    return None


@pytest.fixture
def pg_url() -> Iterator[str]:
    """A freshly created (empty, un-migrated) PostgreSQL database, dropped afterwards; fails under CI=true when
    PostgreSQL is unreachable, skips elsewhere."""
    import psycopg

    why = pg_available()
    if why is not None:
        msg = f"PostgreSQL at 127.0.0.1:5432 unreachable: {why}"
        if os.environ.get("CI") == "true":
            pytest.fail(msg)
        pytest.skip(msg)
    name = f"foresight_test_{uuid.uuid4().hex[:10]}"
    with psycopg.connect(PG_DSN, autocommit=True) as conn:
        conn.execute(f'CREATE DATABASE "{name}"')
    try:
        yield f"postgresql+psycopg://postgres@127.0.0.1:5432/{name}"
    finally:
        with psycopg.connect(PG_DSN, autocommit=True) as conn:
            conn.execute(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)')
