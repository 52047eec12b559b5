"""The artifact store: one root folder; every path is resolved and checked to stay under it.

Records hold store-relative paths (``jobs/<job id>/<artifact name>``), so the root may move or be a shared
volume mounted at different places on different machines.
"""

from __future__ import annotations

import errno
import hashlib
import re
from pathlib import Path, PurePosixPath, PureWindowsPath

from foresight.core import files

_DRIVE = re.compile(r"^[A-Za-z]:[\\/]")


def is_full_disk(exc: BaseException) -> bool:
    """Whether ``exc`` says the store's disk (or the user's quota) is full."""
    return isinstance(exc, OSError) and exc.errno in (errno.ENOSPC, errno.EDQUOT)


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


def sha256_file(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as handle:
        for chunk in iter(lambda: handle.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


def write_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` through a temporary beside ``path`` and a rename, flushed to the disk (registry uploads)."""
    files.write_bytes(path, data, fsync=True)


def scan(root: Path, relative_dir: str) -> list[dict]:
    """Artifact records (name, store-relative path, size, sha256) of the files under a store folder."""
    base = resolve_under(root, relative_dir)
    if not base.is_dir():
        return []
    out = []
    for path in sorted(p for p in base.rglob("*") if p.is_file() and not p.name.endswith(".tmp")):
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
