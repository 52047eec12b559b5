"""Reading an untrusted zip or tar archive (a config-bundle upload) into memory, bounded as it streams.

Sizes in headers are never trusted: every member is decompressed in chunks against a running byte limit,
and a tar's whole decompressed stream is metered before tarfile parses it (a header may claim any size).
Every failure is a ConfigError naming the member: a bad CRC, a truncated or corrupt stream, a link or
special file, an encrypted member, too many files, too many bytes.
"""

from __future__ import annotations

import bz2
import gzip
import io
import lzma
import stat
import tarfile
import zipfile
import zlib
from typing import BinaryIO

from foresight.core.errors import ConfigError

CHUNK = 1 << 16  #: [bytes] read size while decompressing
TAR_OVERHEAD = 1024  #: [bytes] per member: a tar header block plus at most one block of padding
_READ_ERRORS = (
    zipfile.BadZipFile,
    tarfile.TarError,
    zlib.error,
    lzma.LZMAError,
    EOFError,
    OSError,
    NotImplementedError,
    RuntimeError,
    ValueError,
)
SOURCE = "upload"


class _Budget:
    """Running count of decompressed bytes against a limit; the error names the member being read."""

    def __init__(self, max_bytes: int):
        self.max_bytes, self.used = max_bytes, 0

    def take(self, n: int, member: str | None) -> None:
        self.used += n
        if self.used > self.max_bytes:
            raise ConfigError(
                f"the archive unpacks to more than {self.max_bytes} bytes", source=SOURCE, item=member
            )


class _Metered(io.RawIOBase):
    """A read-only stream that fails once more than ``limit`` bytes were read from ``inner``."""

    def __init__(self, inner: BinaryIO, limit: int):
        self.inner, self.limit, self.read_bytes = inner, limit, 0

    def readable(self) -> bool:
        return True

    def read(self, n: int = -1) -> bytes:
        data = self.inner.read(CHUNK if n is None or n < 0 else min(n, CHUNK))
        self.read_bytes += len(data)
        if self.read_bytes > self.limit:
            raise ConfigError(f"the archive unpacks to more than {self.limit} bytes", source=SOURCE)
        return data


def _read_member(handle: BinaryIO, name: str, budget: _Budget) -> bytes:
    out = bytearray()
    while chunk := handle.read(CHUNK):
        budget.take(len(chunk), name)
        out += chunk
    return bytes(out)


def _zip_members(data: bytes, max_files: int, budget: _Budget) -> list[tuple[str, bytes]]:
    try:
        archive = zipfile.ZipFile(io.BytesIO(data))
    except _READ_ERRORS as exc:
        raise ConfigError(f"not a readable zip archive ({exc})", source=SOURCE) from None
    out: list[tuple[str, bytes]] = []
    with archive:
        infos = [i for i in archive.infolist() if not i.is_dir()]
        if len(infos) > max_files:
            raise ConfigError(f"more than {max_files} files", source=SOURCE)
        for info in infos:
            if stat.S_ISLNK(info.external_attr >> 16):
                raise ConfigError(
                    "links and special files are not allowed", source=SOURCE, item=info.filename
                )
            try:
                with archive.open(info) as handle:
                    out.append((info.filename, _read_member(handle, info.filename, budget)))
            except ConfigError:
                raise
            except _READ_ERRORS as exc:
                raise ConfigError(
                    f"cannot unpack this member ({exc})", source=SOURCE, item=info.filename
                ) from None
    return out


def _decompressed(data: bytes) -> BinaryIO:
    """The tar stream inside ``data`` (gzip, bzip2, xz or none), decompressed lazily."""
    raw = io.BytesIO(data)
    if data[:2] == b"\x1f\x8b":
        return gzip.GzipFile(fileobj=raw)
    if data[:3] == b"BZh":
        return bz2.BZ2File(raw)
    if data[:6] == b"\xfd7zXZ\x00":
        return lzma.LZMAFile(raw)
    return raw


def _tar_members(data: bytes, max_files: int, budget: _Budget) -> list[tuple[str, bytes]]:
    stream = _Metered(_decompressed(data), budget.max_bytes + TAR_OVERHEAD * (max_files + 2))
    out: list[tuple[str, bytes]] = []
    member: str | None = None
    try:
        with tarfile.open(fileobj=stream, mode="r|") as archive:
            for info in archive:
                member = info.name
                if info.isdir():
                    continue
                if not info.isfile():
                    raise ConfigError("links and special files are not allowed", source=SOURCE, item=member)
                if len(out) >= max_files:
                    raise ConfigError(f"more than {max_files} files", source=SOURCE)
                out.append((member, _read_member(archive.extractfile(info), member, budget)))
                member = None
    except ConfigError as exc:
        if exc.item is None and member is not None:
            raise ConfigError(exc.detail, source=SOURCE, item=member) from None
        raise
    except _READ_ERRORS as exc:
        if member is None and not out:
            raise ConfigError(f"not a zip or tar archive ({exc})", source=SOURCE) from None
        raise ConfigError(
            f"cannot unpack {'this member' if member else 'the archive'} ({exc})", source=SOURCE, item=member
        ) from None
    return out


def read_archive(data: bytes, *, max_bytes: int, max_files: int) -> list[tuple[str, bytes]]:
    """(name, content) of the regular files in a zip or tar (optionally gzip/bzip2/xz) archive.

    At most ``max_files`` files and ``max_bytes`` bytes of content, counted as they are decompressed.
    Names are returned as stored: the caller checks them (relative, allowed suffixes).
    """
    budget = _Budget(max_bytes)
    if data[:4] in (b"PK\x03\x04", b"PK\x05\x06") or zipfile.is_zipfile(io.BytesIO(data)):
        return _zip_members(data, max_files, budget)
    return _tar_members(data, max_files, budget)
