"""A generator of zip and tar variants, well-formed and hostile, for the archive reader and the bundle upload.

Bombs are built without compressing their payload: gzip and bzip2 decompress concatenated streams as one,
so a few copies of one compressed MiB of zeros stand for gigabytes.
"""

from __future__ import annotations

import bz2
import functools
import gzip
import io
import random
import struct
import tarfile
import zipfile
import zlib

MIB = 1 << 20


def zip_of(files: dict[str, bytes], compression: int = zipfile.ZIP_DEFLATED) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression) as z:
        for name, data in files.items():
            z.writestr(name, data)
    return buf.getvalue()


def tar_of(files: dict[str, bytes], mode: str = "w") -> bytes:
    buf = io.BytesIO()
    with tarfile.open(fileobj=buf, mode=mode) as t:
        for name, data in files.items():
            info = tarfile.TarInfo(name)
            info.size = len(data)
            t.addfile(info, io.BytesIO(data))
    return buf.getvalue()


def _patch_zip_sizes(data: bytes, *, size: int | None = None, crc: int | None = None) -> bytes:
    """Rewrite the uncompressed size and/or CRC of every member in both the local and central headers."""
    out = bytearray(data)
    for sig, crc_at, size_at in ((b"PK\x03\x04", 14, 22), (b"PK\x01\x02", 16, 24)):
        at = out.find(sig)
        while at >= 0:
            if crc is not None:
                out[at + crc_at : at + crc_at + 4] = struct.pack("<I", crc)
            if size is not None:
                out[at + size_at : at + size_at + 4] = struct.pack("<I", size)
            at = out.find(sig, at + 4)
    return bytes(out)


def zip_understated(name: str = "maps/big.yaml", real: int = 80 * MIB, claimed: int = 10) -> bytes:
    """A zip whose member's headers claim ``claimed`` bytes while it inflates to ``real``."""
    return _patch_zip_sizes(zip_of({name: b"\0" * real}), size=claimed)


def zip_bad_crc(name: str = "scenarios/m.yaml") -> bytes:
    data = b"scenarios: []\n"
    return _patch_zip_sizes(zip_of({name: data}), crc=zlib.crc32(data) ^ 0xFFFF)


def _concatenated(compress, header: bytes, zeros: int, tail: bytes = b"") -> bytes:
    one = compress(b"\0" * MIB)
    return compress(header) + one * (zeros // MIB) + (compress(tail) if tail else b"")


def tar_bomb(name: str = "maps/zero.yaml", size: int = 4 << 30, codec: str = "bz2") -> bytes:
    """A compressed tar whose single member holds ``size`` zero bytes (a few MiB on the wire)."""
    info = tarfile.TarInfo(name)
    info.size = size
    header = info.tobuf(format=tarfile.GNU_FORMAT)
    compress = bz2.compress if codec == "bz2" else gzip.compress
    return _concatenated(compress, header, size, b"\0" * 1024)


def pax_header_bomb(size: int = 2 << 30) -> bytes:
    """A gzip tar whose pax extended header claims ``size`` bytes (tarfile would read it whole)."""
    info = tarfile.TarInfo("././@PaxHeader")
    info.type, info.size = tarfile.XHDTYPE, size
    return _concatenated(gzip.compress, info.tobuf(format=tarfile.USTAR_FORMAT), size)


def link_tar(name: str = "scenarios/link.yaml") -> bytes:
    buf = io.BytesIO()
    with tarfile.open(fileobj=buf, mode="w") as t:
        info = tarfile.TarInfo(name)
        info.type, info.linkname = tarfile.SYMTYPE, "/etc/passwd"
        t.addfile(info)
    return buf.getvalue()


def link_zip(name: str = "scenarios/link.yaml") -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        info = zipfile.ZipInfo(name)
        info.external_attr = 0o120777 << 16
        z.writestr(info, "/etc/passwd")
    return buf.getvalue()


@functools.cache
def hostile() -> dict[str, tuple[bytes, str, str | None]]:
    """name -> (archive bytes, expected message part, member the error must name or None)."""
    small = {"scenarios/m.yaml": b"scenarios: []\n"}
    return {
        "zip header understates size": (zip_understated(), "", "maps/big.yaml"),
        "zip of 80 MiB zeros": (
            zip_of({"maps/big.yaml": b"\0" * (80 * MIB)}),
            "unpacks to more than",
            "maps/big.yaml",
        ),
        "zip bad crc": (zip_bad_crc(), "CRC", "scenarios/m.yaml"),
        "tar.bz2 4 GiB zero member": (tar_bomb(), "unpacks to more than", "maps/zero.yaml"),
        "tar.gz 4 GiB zero member": (tar_bomb(codec="gz"), "unpacks to more than", "maps/zero.yaml"),
        "pax header bomb": (pax_header_bomb(), "unpacks to more than", None),
        "tar symlink": (link_tar(), "links", "scenarios/link.yaml"),
        "zip symlink": (link_zip(), "links", "scenarios/link.yaml"),
        "truncated tar.gz": (tar_of(small, "w:gz")[:-30], "", None),
        "truncated zip": (zip_of(small)[:-30], "", None),
        "not an archive": (b"not an archive at all", "not a zip or tar", None),
    }


def mangled(seed: int, count: int) -> list[bytes]:
    """``count`` random corruptions (flipped, cut, repeated bytes) of small valid zip, tar and tar.gz bundles."""
    rng = random.Random(seed)
    files = {
        "scenarios/m.yaml": b"scenarios:\n  - name: a\n    map_file: ../maps/a.svg\n",
        "maps/a.svg": b"<svg/>",
    }
    bases = [
        zip_of(files),
        zip_of(files, zipfile.ZIP_STORED),
        tar_of(files),
        tar_of(files, "w:gz"),
        tar_of(files, "w:bz2"),
        tar_of(files, "w:xz"),
    ]
    out = []
    for _ in range(count):
        data = bytearray(rng.choice(bases))
        for _ in range(rng.randint(1, 8)):
            op, at = rng.random(), rng.randrange(len(data))
            if op < 0.6:
                data[at] = rng.randrange(256)
            elif op < 0.8:
                del data[at:]
            else:
                data[at:at] = data[at : at + rng.randint(1, 64)]
            if not data:
                data = bytearray(b"\0")
        out.append(bytes(data))
    return out


#: member names a fuzzed archive draws from: valid bundle paths, traversal, absolute, odd and over-long names
MEMBER_NAMES = (
    "scenarios/m.yaml",
    "maps/a.svg",
    "maps/a.yaml",
    "seeds/s.yaml",
    "../escape.yaml",
    "/etc/abs.yaml",
    "scenarios/../../up.yaml",
    "a/./b.yaml",
    "dir/",
    "C:\\win.yaml",
    "n\0ul.yaml",
    "ü/ñ.yaml",
    "x" * 300,
)
MEMBER_BODIES = (
    b"scenarios: []\n",
    b"scenarios:\n  - name: a\n    map_file: ../maps/a.svg\n",
    b"<svg/>",
    b"a: &a [1]\nb: [*a, *a]\n",
    b"[" * 300,
    b"\xff\xfe not utf-8",
    b"",
    b"\0" * 4096,
)
FORMATS = ("zip", "zip-stored", "w", "w:gz", "w:bz2", "w:xz")


def _pack(fmt: str, files: dict[str, bytes]) -> bytes:
    if fmt.startswith("zip"):
        return zip_of(files, zipfile.ZIP_STORED if fmt == "zip-stored" else zipfile.ZIP_DEFLATED)
    return tar_of(files, fmt)


def archive_strategy():  # noqa: ANN201 (hypothesis is a test dependency: imported here only)
    """A Hypothesis strategy of bundle archives: zip or tar (plain, gz, bz2, xz) of drawn member names and
    bodies, then a few drawn corruptions (a byte overwritten, the tail cut, a slice repeated), or none."""
    from hypothesis import strategies as st

    @st.composite
    def archives(draw) -> bytes:  # noqa: ANN001
        files = draw(
            st.dictionaries(
                st.sampled_from(MEMBER_NAMES), st.sampled_from(MEMBER_BODIES), min_size=1, max_size=4
            )
        )
        data = bytearray(_pack(draw(st.sampled_from(FORMATS)), files))
        for _ in range(draw(st.integers(0, 3))):
            op, at = (
                draw(st.sampled_from(("set", "cut", "repeat"))),
                draw(st.integers(0, max(len(data) - 1, 0))),
            )
            if op == "set":
                data[at] = draw(st.integers(0, 255))
            elif op == "cut":
                del data[max(at, 1) :]
            else:
                data[at:at] = data[at : at + draw(st.integers(1, 64))]
        return bytes(data)

    return archives()
