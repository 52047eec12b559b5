"""The worker process's memory limit: a job that allocates past it fails with a reason, the machine stays up.

Stages run in the worker's threads (and its pool processes, which inherit the limit), so the limit is the
process's data segment (``RLIMIT_DATA``: heap and private mappings, what numpy and Python allocate; address
space merely reserved, as by thread stacks' guards or CUDA, does not count). An allocation past it raises
``MemoryError`` in the job that asked, which fails that job; the others keep running.
"""

from __future__ import annotations

import os
import resource

from foresight.store.settings import Settings

DEFAULT_SHARE = 0.75  #: without FORESIGHT_WORKER_MEMORY_MB: this share of the machine's physical memory


def physical_mb() -> int:
    return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE") // 2**20


def limit_mb(settings: Settings) -> int | None:
    """The limit to apply [MiB]: ``worker_memory_mb``, its default share of the machine, or None (0: none)."""
    if settings.worker_memory_mb is None:
        return int(DEFAULT_SHARE * physical_mb())
    return settings.worker_memory_mb or None


def limit_memory(settings: Settings) -> int | None:
    """Cap this process's data segment at :func:`limit_mb` (never above a hard limit already set); the cap in
    MiB, or None when there is none."""
    mb = limit_mb(settings)
    if mb is None:
        return None
    _, hard = resource.getrlimit(resource.RLIMIT_DATA)
    limit = mb * 2**20 if hard == resource.RLIM_INFINITY else min(mb * 2**20, hard)
    resource.setrlimit(resource.RLIMIT_DATA, (limit, hard))
    return limit // 2**20


def current_limit_mb() -> int | None:
    soft, _ = resource.getrlimit(resource.RLIMIT_DATA)
    return None if soft == resource.RLIM_INFINITY else soft // 2**20


def memory_error_text(exc: MemoryError) -> str:
    """Why a job that raised ``exc`` failed, naming the limit and the setting that raises it."""
    limit = current_limit_mb()
    what = f" ({exc})" if str(exc) else ""
    if limit is None:
        return f"the job ran out of memory{what}"
    return (
        f"the job needed more memory than this worker's limit of {limit} MiB{what}: lower the job's size, "
        "or raise FORESIGHT_WORKER_MEMORY_MB"
    )
