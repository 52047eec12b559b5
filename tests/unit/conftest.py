"""Fixtures shared by unit tests that need a real, migrated SQLite store (worker and pipeline child jobs).

``tests/unit/api`` overrides ``settings``/``engine`` with its own (a copied migrated template)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from foresight.store.session import make_engine, upgrade
from foresight.store.settings import Settings


@pytest.fixture
def settings(tmp_path: Path) -> Settings:
    s = Settings(
        data_dir=tmp_path,
        api_token="t",
        lease_s=2.0,
        heartbeat_s=0.2,
        poll_s=0.05,
        shutdown_grace_s=0.3,
        model_registry=tmp_path / "none.yaml",
    )
    upgrade(s.resolved_database_url)
    return s


@pytest.fixture
def engine(settings: Settings) -> Iterator:
    eng = make_engine(settings.resolved_database_url)
    yield eng
    eng.dispose()


@pytest.fixture
def small_store(tmp_path: Path) -> Iterator[Path]:
    """A real full disk: a 1 MiB tmpfs mounted for the test (skipped where mounting needs privileges we lack)."""
    import subprocess

    mount = tmp_path / "small-store"
    mount.mkdir()
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(mount)], capture_output=True)
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here (needs root): {done.stderr.decode().strip()}")
    yield mount
    subprocess.run(["umount", str(mount)], check=True)
