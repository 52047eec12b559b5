"""The artifact store: one root folder; every path is resolved and checked to stay under it.

Records hold store-relative paths (``jobs/<job id>/<artifact name>``), so the root may move or be a shared
volume mounted at different places on different machines.

Each attempt at a job writes into a folder of its own (``jobs/<id>/.attempts/<stamp>``, seeded with a copy of
the previous attempt's files so that training and campaigns resume), and its files reach the job's folder only
through :func:`publish`, which the worker runs inside the transaction that checks its lease and finishes the
job. A worker paused past its lease may wake up and write on, but only into its own attempt's folder: it can
never overwrite the files of the attempt that finished the job (fencing).
"""

from __future__ import annotations

import errno
import hashlib
import os
import re
import shutil
import time
import uuid
from pathlib import Path, PurePosixPath, PureWindowsPath

from foresight.core import files

_DRIVE = re.compile(r"^[A-Za-z]:[\\/]")


SQLITE_FULL = 13  #: SQLite's result code for "database or disk is full"
PG_DISK_FULL = "53100"  #: PostgreSQL's SQLSTATE disk_full


def is_full_disk(exc: BaseException | None) -> bool:
    """Whether ``exc`` (or what it wraps: a database driver's error, a cause) says a disk or quota is full: an
    OSError ENOSPC/EDQUOT, SQLite's "database or disk is full", PostgreSQL's disk_full."""
    for _ in range(8):  # the chain of wrapped errors, bounded
        if exc is None:
            return False
        if isinstance(exc, OSError) and exc.errno in (errno.ENOSPC, errno.EDQUOT):
            return True
        if getattr(exc, "sqlite_errorcode", None) == SQLITE_FULL or "database or disk is full" in str(exc):
            return True
        if getattr(exc, "sqlstate", None) == PG_DISK_FULL or getattr(exc, "pgcode", None) == PG_DISK_FULL:
            return True
        exc = getattr(exc, "orig", None) or exc.__cause__ or exc.__context__
    return False


class UnsafePath(ValueError):
    """A path that is absolute, contains '..', or otherwise leaves its root."""


def check_relative(name: str) -> str:
    """``name`` as a clean relative POSIX path, or :class:`UnsafePath`."""
    if not name or "\x00" in name:
        raise UnsafePath(f"invalid path {name!r}")
    if name.startswith(("/", "\\")) or _DRIVE.match(name) or PureWindowsPath(name).is_absolute():
        raise UnsafePath(f"absolute path {name!r} not allowed; name files relative to their bundle or job")
    parts = re.split(r"[\\/]+", name)
    if ".." in parts:
        raise UnsafePath(f"path {name!r} contains '..'")
    clean = [p for p in parts if p not in ("", ".")]
    if not clean:
        raise UnsafePath(f"invalid path {name!r}")
    return str(PurePosixPath(*clean))


def looks_unsafe(value: str) -> bool:
    """Whether a spec string is an absolute path or climbs out with '..' (specs name inputs by id)."""
    if value.startswith(("/", "\\", "~")) or _DRIVE.match(value):
        return True
    return ".." in re.split(r"[\\/]+", value)


def resolve_under(root: Path, relative: str) -> Path:
    """``root / relative`` resolved; :class:`UnsafePath` when it would leave ``root``."""
    root = root.resolve()
    path = (root / check_relative(relative)).resolve()
    if path != root and root not in path.parents:
        raise UnsafePath(f"path {relative!r} leaves the store")
    return path


def job_dir(root: Path, job_id: str) -> str:
    """A job's artifact folder, store-relative."""
    return f"jobs/{check_relative(job_id)}"


ATTEMPTS = ".attempts"  #: a job folder's sub-folder of attempt folders (never an artifact)


def attempts_dir(root: Path, job_id: str) -> Path:
    return resolve_under(root, job_dir(root, job_id)) / ATTEMPTS


def start_attempt(root: Path, job_id: str, *, create: bool = True) -> Path:
    """A new, unique folder for one attempt at a job, holding a copy of the latest earlier attempt's files (the
    resume point of a retried training or campaign); created when ``create`` or when there is something to copy.
    Copies, not links: a paused earlier attempt may still append to its files."""
    base = attempts_dir(root, job_id)
    earlier = sorted(p for p in base.iterdir() if p.is_dir()) if base.is_dir() else []
    folder = base / f"{time.time_ns():020d}-{uuid.uuid4().hex[:8]}"
    if earlier:
        shutil.copytree(earlier[-1], folder, ignore=shutil.ignore_patterns("*.tmp"), symlinks=True)
    elif create:
        folder.mkdir(parents=True)
    return folder


def publish(root: Path, job_id: str, attempt: Path) -> None:
    """Move an attempt's files into the job's folder, replacing what is there (run while the finishing
    transaction holds the job's row, so only the lease holder publishes)."""
    target = resolve_under(root, job_dir(root, job_id))
    if not attempt.is_dir():
        return
    for entry in sorted(attempt.iterdir()):
        dest = target / entry.name
        if dest.is_dir() and not dest.is_symlink():
            shutil.rmtree(dest)
        os.replace(entry, dest)


def drop_attempt(folder: Path) -> None:
    """Remove one attempt's folder (a lost lease, a full disk), and its job's folder when nothing is left."""
    shutil.rmtree(folder, ignore_errors=True)
    if folder.parent.name == ATTEMPTS:
        remove_empty(folder.parent.parent)


def drop_attempts(root: Path, job_id: str) -> None:
    """Remove every attempt folder of a finished job (its files were published)."""
    shutil.rmtree(attempts_dir(root, job_id), ignore_errors=True)


def sha256_file(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as handle:
        for chunk in iter(lambda: handle.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


def write_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` through a temporary beside ``path`` and a rename, flushed to the disk (registry uploads)."""
    files.write_bytes(path, data, fsync=True)


def scan(root: Path, relative_dir: str, source: Path | None = None) -> list[dict]:
    """Artifact records (name, store-relative path, size, sha256) of the files under a store folder, read
    from ``source`` (an attempt's folder that :func:`publish` will move there) when given; attempt folders
    and temporaries are never artifacts."""
    base = source if source is not None else resolve_under(root, relative_dir)
    if not base.is_dir():
        return []
    out = []
    files_ = (p for p in base.rglob("*") if p.is_file() and not p.name.endswith(".tmp"))
    for path in sorted(p for p in files_ if ATTEMPTS not in p.relative_to(base).parts):
        name = path.relative_to(base).as_posix()
        out.append(
            dict(name=name, path=f"{relative_dir}/{name}", size=path.stat().st_size, sha256=sha256_file(path))
        )
    return out


def remove_empty(folder: Path) -> None:
    """Remove the empty sub-folders of ``folder``, then ``folder`` itself when nothing is left in it."""
    if not folder.is_dir():
        return
    for sub in sorted((p for p in folder.rglob("*") if p.is_dir()), reverse=True):
        if not any(sub.iterdir()):
            sub.rmdir()
    if not any(folder.iterdir()):
        folder.rmdir()
