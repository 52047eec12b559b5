"""Archive reading: streamed with a running byte limit, headers never trusted, every failure a
ConfigError naming the member."""

from __future__ import annotations

import resource
import time

import pytest

from foresight.core.archive import read_archive
from foresight.core.errors import ConfigError
from tests.archives import hostile, mangled, tar_of, zip_of

LIMIT = 50 << 20
FILES = {"scenarios/m.yaml": b"scenarios: []\n", "maps/a.svg": b"<svg/>"}


@pytest.mark.parametrize("mode", ["zip", "w", "w:gz", "w:bz2", "w:xz"])
def test_well_formed_archives_read_back(mode: str) -> None:
    data = zip_of(FILES) if mode == "zip" else tar_of(FILES, mode)
    assert dict(read_archive(data, max_bytes=LIMIT, max_files=10)) == FILES


@pytest.mark.parametrize("case", sorted(hostile()))
def test_hostile_archives_are_refused_quickly_naming_the_member(case: str) -> None:
    data, why, member = hostile()[case]
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    t0 = time.process_time()
    with pytest.raises(ConfigError) as err:
        read_archive(data, max_bytes=LIMIT, max_files=10)
    assert time.process_time() - t0 < 5.0  # 23 s of CPU for the 4 GiB tar.bz2 before
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - rss0 < 300 * 1024  # [KiB]; +1.2 GB before
    assert why in str(err.value) and err.value.source == "upload"
    assert err.value.item == member


def test_file_count_limit() -> None:
    with pytest.raises(ConfigError, match="more than 1 files"):
        read_archive(tar_of(FILES), max_bytes=LIMIT, max_files=1)
    with pytest.raises(ConfigError, match="more than 1 files"):
        read_archive(zip_of(FILES), max_bytes=LIMIT, max_files=1)


def test_byte_limit_counts_actual_content() -> None:
    with pytest.raises(ConfigError, match="more than 19 bytes") as err:
        read_archive(tar_of(FILES, "w:gz"), max_bytes=19, max_files=10)
    assert err.value.item in FILES


def test_mangled_archives_give_a_config_error_or_their_files() -> None:
    """Random corruptions never escape as another exception type."""
    for data in mangled(seed=15, count=300):
        try:
            members = read_archive(data, max_bytes=LIMIT, max_files=10)
        except ConfigError:
            continue
        assert all(isinstance(n, str) and isinstance(b, bytes) for n, b in members)
