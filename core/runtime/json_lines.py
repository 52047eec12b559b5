"""One child process's JSON-lines conversation: a message out, one typed answer back within a deadline.

External planners and external predictors speak it alike (``core.planners.external``,
``core.predict.external``); each turns an :class:`ExchangeFailed` into its own error, with its own name and
what its process wrote to stderr.
"""

from __future__ import annotations

import json
import os
import select
import subprocess
import time
from typing import Any


class ExchangeFailed(Exception):
    """The process gave no usable answer; ``str(exc)`` says what it did ("exited (code 3) at step 2")."""


class JsonLines:
    """Messages to ``proc``'s stdin, answers from its stdout (both unbuffered pipes), one JSON object a line."""

    def __init__(self, proc: subprocess.Popen):
        self.proc = proc
        self._buf = b""
        self.reply_bytes = 0  #: the last answer's size on the wire (benchmarks)

    def send(self, msg: dict[str, Any] | bytes, where: str) -> None:
        """Write ``msg`` (a message, or one already written as a JSON line)."""
        line = msg if isinstance(msg, bytes) else (json.dumps(msg, separators=(",", ":")) + "\n").encode()
        try:
            os.write(self.proc.stdin.fileno(), line)
        except OSError:
            raise self._exited(f"before {where}") from None

    def request(
        self, msg: dict[str, Any] | bytes, timeout_s: float, expect: str, where: str
    ) -> dict[str, Any]:
        """Send ``msg`` and read one answer of type ``expect``."""
        self.send(msg, where)
        line = self._readline(timeout_s, where)
        try:
            reply = json.loads(line)
        except (json.JSONDecodeError, UnicodeDecodeError):
            raise ExchangeFailed(f"sent malformed JSON at {where}: {line[:120]!r}") from None
        if not isinstance(reply, dict) or reply.get("type") != expect:
            raise ExchangeFailed(f"sent {str(reply)[:120]!r} at {where}, expected a {expect!r} message")
        return reply

    def _readline(self, timeout_s: float, where: str) -> bytes:
        fd = self.proc.stdout.fileno()
        deadline = time.monotonic() + timeout_s
        while b"\n" not in self._buf:
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([fd], [], [], left)[0]:
                raise ExchangeFailed(f"sent no answer within {timeout_s:g} s at {where} (killed)")
            chunk = os.read(fd, 1 << 20)
            if not chunk:
                raise self._exited(f"at {where}")
            self._buf += chunk
        line, _, self._buf = self._buf.partition(b"\n")
        self.reply_bytes = len(line) + 1
        return line

    def _exited(self, where: str) -> ExchangeFailed:
        try:
            code = self.proc.wait(timeout=1)
        except subprocess.TimeoutExpired:
            code = None
        return ExchangeFailed(f"exited (code {code}) {where}")
