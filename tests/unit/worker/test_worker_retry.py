"""The retry policy is a pure function of the exception."""

from __future__ import annotations

import pytest
from sqlalchemy.exc import OperationalError

from foresight.core.errors import ConfigError, NotFoundError
from foresight.worker.retry import decide_retry


@pytest.mark.parametrize(
    "exc,retry",
    [
        (ConfigError("bad"), False),
        (NotFoundError("x"), False),
        (ValueError("x"), False),
        (RuntimeError("bug"), False),
        (FileNotFoundError("x"), False),
        (OSError("disk full"), True),
        (ConnectionError("reset"), True),
        (OperationalError("stmt", {}, Exception("locked")), True),
    ],
)
def test_decide_retry(exc: BaseException, retry: bool) -> None:
    assert decide_retry(exc) is retry
