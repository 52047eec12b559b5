"""Retry policy: which failures are worth another automatic attempt (a pure function, unit-tested).

A lost worker (expired lease) is always retried by the reaper up to the job's attempt limit. A stage's
own exception is retried only when it looks transient (I/O, the database); bad input, unknown ids and
programming errors would fail the same way again, so they fail at once and the user retries explicitly.
"""

from __future__ import annotations

from pydantic import ValidationError

from foresight.core.errors import CoreError
from foresight.store.session import TRANSIENT_ERRORS

TRANSIENT: tuple[type[BaseException], ...] = (*TRANSIENT_ERRORS, ConnectionError, TimeoutError)


def decide_retry(exc: BaseException) -> bool:
    """Whether a job that raised ``exc`` should be queued again (attempts permitting)."""
    if isinstance(exc, CoreError | ValidationError | ValueError):
        return False
    if isinstance(exc, TRANSIENT):
        return True
    return isinstance(exc, OSError) and not isinstance(exc, FileNotFoundError | PermissionError)
