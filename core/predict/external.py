"""External predictors: a separate process speaking the JSON-lines predictor protocol on stdin/stdout.

``foresight.predictor/1`` (docs/predictor_protocol.md): the process answers a hello with its declaration (name,
time base, frame, modes), then each ``observe`` message (the observation window) with one ``forecast`` message
within ``FORESIGHT_PREDICTOR_TIMEOUT_S`` (default 2 s; the first after the hello within the start timeout). A
process that exits, misses a deadline (it is killed) or answers anything else fails the episode with a
PredictorError naming it; the next episode starts a new process. One process per predictor and thread.

Only operator-configured commands run: ``FORESIGHT_EXTERNAL_PREDICTORS`` maps names to command lines (a JSON
object ``{"name": "command line" or ["argv", ...]}``); a model names one as ``external:<name>``.
"""

from __future__ import annotations

import atexit
import contextlib
import os
import subprocess
import tempfile
import threading
from typing import Any

from foresight.core.errors import ConfigError
from foresight.core.predict.forecast import PredictorError
from foresight.core.runtime import commands
from foresight.core.runtime.json_lines import ExchangeFailed, JsonLines

PROTOCOL = 1
ENV = "FORESIGHT_EXTERNAL_PREDICTORS"
TIMEOUT_ENV = "FORESIGHT_PREDICTOR_TIMEOUT_S"
ARTIFACTS_ENV = "FORESIGHT_PREDICTOR_ARTIFACTS"  #: a registered model's files folder, for its process
START_TIMEOUT_S = 20.0


def operator_commands(value: str | None = None) -> dict[str, list[str]]:
    """Name -> argv of the operator-configured external predictors (``FORESIGHT_EXTERNAL_PREDICTORS``)."""
    return commands.operator_commands(ENV, value)


def step_timeout() -> float:
    try:
        return float(os.environ.get(TIMEOUT_ENV, "2"))
    except ValueError:
        raise ConfigError("expected seconds (a number)", source=TIMEOUT_ENV) from None


class PredictorProcess:
    """One running predictor process: a line out, a line back within a deadline."""

    def __init__(self, who: str, argv: list[str], env: dict[str, str] | None = None):
        self.who = who
        self._err = tempfile.NamedTemporaryFile(prefix="foresight-predictor-", suffix=".log", delete=False)  # noqa: SIM115
        try:
            self.proc = subprocess.Popen(
                argv,
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=self._err,
                bufsize=0,
                close_fds=True,
                env=env,
            )
        except OSError as exc:
            self._err.close()
            raise PredictorError(who, f"did not start: {exc}") from None
        self._lines = JsonLines(self.proc)
        self.hello = self.request({"type": "hello", "protocol": PROTOCOL}, START_TIMEOUT_S, "hello", "hello")
        if self.hello.get("protocol") != PROTOCOL:
            self.kill()
            raise PredictorError(who, f"speaks protocol {self.hello.get('protocol')!r}, expected {PROTOCOL}")

    @property
    def alive(self) -> bool:
        return self.proc.poll() is None

    def request(
        self, msg: dict[str, Any] | bytes, timeout_s: float, expect: str, where: str
    ) -> dict[str, Any]:
        """Send ``msg`` (a message, or one already written as a JSON line) and read one answer of type ``expect``."""
        try:
            return self._lines.request(msg, timeout_s, expect, where)
        except ExchangeFailed as exc:
            self._fail(str(exc))

    @property
    def reply_bytes(self) -> int:
        """The last answer's size on the wire (benchmarks)."""
        return self._lines.reply_bytes

    def _fail(self, reason: str) -> None:
        self.kill()
        with contextlib.suppress(OSError), open(self._err.name, "rb") as f:
            f.seek(max(0, os.fstat(f.fileno()).st_size - 300))
            tail = f.read().decode(errors="replace").strip()
            reason += f"; stderr: {tail}" if tail else ""
        with contextlib.suppress(OSError):
            os.unlink(self._err.name)
        raise PredictorError(self.who, reason)

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait()
        for f in (self.proc.stdin, self.proc.stdout, self._err):
            with contextlib.suppress(OSError):
                f.close()

    def close(self) -> None:
        with contextlib.suppress(OSError, subprocess.TimeoutExpired):
            self.proc.stdin.close()
            self.proc.wait(timeout=2)
        self.kill()
        with contextlib.suppress(OSError):
            os.unlink(self._err.name)


_PROCESSES: dict[tuple[tuple[str, ...], int], PredictorProcess] = {}
_LOCK = threading.Lock()


@atexit.register
def close_all() -> None:
    """End every predictor process this process started."""
    with _LOCK:
        procs = list(_PROCESSES.values())
        _PROCESSES.clear()
    for proc in procs:
        proc.close()


class ExternalPredictor:
    """A predictor plug-in whose ``predict`` is a round trip to an operator-configured process."""

    predictor_api = 1

    def __init__(self, command: str, artifacts: str | None = None):
        self.command = command
        self.env = None if artifacts is None else {**os.environ, ARTIFACTS_ENV: str(artifacts)}
        self.who = f"external:{command}"
        commands = operator_commands()
        if command not in commands:
            raise PredictorError(
                self.who,
                f"is not configured by the operator (configured: {', '.join(commands) or 'none'}; set {ENV})",
            )
        self.argv = commands[command]
        hello = self._process().hello
        self.name = str(hello.get("name", command))
        self.timebase = hello.get("timebase")
        self.frame = hello.get("frame", "world")
        self.modes = hello.get("modes", 1)
        self.timeout_s = step_timeout()

    def _process(self) -> PredictorProcess:
        key = (tuple(self.argv), (self.env or {}).get(ARTIFACTS_ENV), threading.get_ident())
        with _LOCK:
            proc = _PROCESSES.get(key)
        if proc is None or not proc.alive:
            proc = PredictorProcess(self.who, self.argv, self.env)
            with _LOCK:
                _PROCESSES[key] = proc
        return proc

    def reset(self) -> None:
        self._process()  # a process that died in the last episode is replaced before this one

    def predict(self, window: Any) -> dict[str, Any]:
        return self._process().request(
            window.to_line(), self.timeout_s, "forecast", f"time {window.time:g} s"
        )
