"""Free space where the database and the store live, and a small reserve that lets deletion work on a full disk.

On a full disk every write fails, deleting a job's rows included (SQLite appends to its write-ahead log first).
The server keeps :data:`RESERVE_BYTES` of ballast beside the database; a deletion that meets a full disk removes
the job's files first and, if the database still cannot write, gives the reserve up and tries once more. The
reserve comes back once there is room again (:func:`keep_reserve`, called by ``/healthz``).
"""

from __future__ import annotations

import contextlib
import os
import shutil
from pathlib import Path

from sqlalchemy.engine import make_url

from foresight.store.settings import Settings

RESERVE = ".space-reserve"  #: the ballast file's name
RESERVE_BYTES = 4 * 2**20  #: [bytes] what a deletion may need to write on a full disk
FULL_BELOW = 2**20  #: [bytes] free space under which a disk counts as full


def database_folder(settings: Settings) -> Path | None:
    """The folder of the SQLite file (None for a database on another machine)."""
    url = make_url(settings.resolved_database_url)
    if url.get_backend_name() != "sqlite" or not url.database or url.database == ":memory:":
        return None
    return Path(url.database).resolve().parent


def free_bytes(folder: Path) -> int | None:
    """Free bytes for an unprivileged writer on ``folder``'s file system (None where it does not exist)."""
    try:
        return shutil.disk_usage(folder).free
    except OSError:
        return None


def disk_state(settings: Settings) -> dict[str, int | bool | None]:
    """Free bytes of the store's and the database's file systems, and whether either counts as full."""
    store = free_bytes(settings.store_root if settings.store_root.exists() else settings.data_dir)
    folder = database_folder(settings)
    database = free_bytes(folder) if folder is not None else None
    full = any(v is not None and v < FULL_BELOW for v in (store, database))
    return {"store_free_bytes": store, "database_free_bytes": database, "full": full}


def _reserve_path(settings: Settings) -> Path:
    return (database_folder(settings) or settings.store_root) / RESERVE


def keep_reserve(settings: Settings) -> None:
    """Create the reserve where it is missing and there is room for it and more (best effort)."""
    path = _reserve_path(settings)
    if path.exists() or (free_bytes(path.parent) or 0) < 4 * RESERVE_BYTES:
        return
    with contextlib.suppress(OSError):
        path.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        try:
            os.write(fd, b"\0" * RESERVE_BYTES)  # written, not sparse: the blocks are really held
        finally:
            os.close(fd)


def release_reserve(settings: Settings) -> bool:
    """Give the reserve's space back (a full disk must still delete); whether there was one."""
    try:
        _reserve_path(settings).unlink()
    except FileNotFoundError:
        return False
    return True
