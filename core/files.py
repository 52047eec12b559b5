"""Writing a file so that its final name only ever holds a complete file.

Every artifact (datasets, checkpoints, traces, reports, figures) is written to a temporary beside its final
name and renamed into place when the write finished: a crash, a kill or a full disk (ENOSPC) mid-write leaves
no half file under the name readers trust, and a failed write removes its temporary at once. The temporary is
``.<name>.<random>.tmp`` in the same folder (a rename within one file system is atomic); artifact scans skip
``*.tmp`` and ``foresight store gc`` removes the ones a killed process left.
"""

from __future__ import annotations

import os
import secrets
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path


@contextmanager
def replacing(path: str | Path, *, fsync: bool = False) -> Iterator[Path]:
    """Yield a temporary path beside ``path`` to write; it becomes ``path`` when the block ends normally and is
    removed when the block raises. ``fsync`` flushes it to the disk first (for records that must survive a
    power cut, not only a crash of this process)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{secrets.token_hex(4)}.tmp")  # the writer creates it (umask applies)
    try:
        yield tmp
        if fsync:
            with tmp.open("rb") as handle:
                os.fsync(handle.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def write_bytes(path: str | Path, data: bytes, *, fsync: bool = False) -> Path:
    """``Path.write_bytes`` through a temporary and a rename."""
    with replacing(path, fsync=fsync) as tmp:
        tmp.write_bytes(data)
    return Path(path)


def write_text(path: str | Path, text: str, *, fsync: bool = False) -> Path:
    """``Path.write_text`` (UTF-8) through a temporary and a rename."""
    return write_bytes(path, text.encode("utf-8"), fsync=fsync)
