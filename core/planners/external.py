"""External planners: a separate process speaking the JSON-lines planner protocol on stdin/stdout.

The protocol ``foresight.planner/1`` is documented, with an example of every message, in docs/planner_protocol.md:
a hello per process, then per episode a start (answered "ready"), one observation -> command round trip per step
within a deadline, and an end. A process that exits, misses a deadline (it is killed) or answers anything but the
expected message ends the episode as ``planner_error`` with that reason; the next episode starts a new process.
One process serves the episodes of one thread in turn (``release_planner_processes`` ends them after a run).

Only operator-configured commands run: ``FORESIGHT_EXTERNAL_PLANNERS`` maps names to command lines (a JSON
object ``{"name": "command line" or ["argv", ...]}``); a spec names one of them, never a command.
"""

from __future__ import annotations

import atexit
import contextlib
import os
import shlex
import subprocess
import tempfile
import threading
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator

from foresight.core.errors import ConfigError
from foresight.core.runtime import commands
from foresight.core.runtime.json_lines import ExchangeFailed, JsonLines
from foresight.core.sim.observation import Observation
from foresight.core.sim.planner import EpisodeInfo

PROTOCOL = 1
ENV = "FORESIGHT_EXTERNAL_PLANNERS"


def operator_commands(value: str | None = None) -> dict[str, list[str]]:
    """Name -> argv of the operator-configured external planners (``FORESIGHT_EXTERNAL_PLANNERS``)."""
    return commands.operator_commands(ENV, value)


class ExternalPlannerConfig(BaseModel):
    """Which operator-configured process plans, its deadlines and its own parameters."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    command: str = Field(
        min_length=1, max_length=200
    )  #: a name in FORESIGHT_EXTERNAL_PLANNERS, never a command line
    step_timeout_s: float = Field(
        default=1.0, gt=0, le=60
    )  #: deadline of one observation -> command round trip
    start_timeout_s: float = Field(
        default=20.0, gt=0, le=300
    )  #: deadline of the process start and episode start
    params: dict[str, Any] = Field(default_factory=dict)  #: sent to the process with every episode start
    #: what the process sends: ``unicycle`` (v, omega) for a differential-drive or unicycle robot, ``velocity``
    #: world-frame (vx, vy) for a holonomic one; a scenario whose robot takes the other is refused before any episode
    command_type: Literal["unicycle", "velocity"] = "unicycle"

    @field_validator("command")
    @classmethod
    def _configured(cls, value: str) -> str:
        known = operator_commands()
        if value not in known:
            raise ValueError(
                f"external planner {value!r} is not configured by the operator (configured: "
                f"{', '.join(known) or 'none'}; the operator sets {ENV})"
            )
        return value


class ExternalPlannerError(RuntimeError):
    """The process crashed, missed a deadline or broke the protocol (the episode ends as planner_error)."""


def _tail(path: str, n: int = 300) -> str:
    try:
        with open(path, "rb") as f:
            f.seek(max(0, os.fstat(f.fileno()).st_size - n))
            return f.read().decode(errors="replace").strip()
    except OSError:
        return ""


class PlannerProcess:
    """One running planner process: send a line, wait for a line with a deadline."""

    def __init__(self, name: str, argv: list[str], timeout_s: float):
        self.name = name
        self._err = tempfile.NamedTemporaryFile(prefix="foresight-planner-", suffix=".log", delete=False)  # noqa: SIM115
        try:
            self.proc = subprocess.Popen(
                argv,
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=self._err,
                bufsize=0,
                close_fds=True,
            )
        except OSError as exc:
            raise ExternalPlannerError(
                f"external planner {name!r} did not start: {exc.strerror}: {argv[0]!r} (command "
                f"{shlex.join(argv)!r} resolved against {os.getcwd()}; use absolute paths in {ENV})"
            ) from None
        self._lines = JsonLines(self.proc)
        try:
            hello = self.request({"type": "hello", "protocol": PROTOCOL}, timeout_s, "hello", "hello")
        except ExternalPlannerError as exc:
            raise ExternalPlannerError(
                f"{exc} (command {shlex.join(argv)!r} resolved against {os.getcwd()})"
            ) from None
        if hello.get("protocol") != PROTOCOL:
            self.kill()
            raise ExternalPlannerError(
                f"external planner {name!r} speaks protocol {hello.get('protocol')!r}, expected {PROTOCOL}"
            )
        self.hello = hello

    @property
    def alive(self) -> bool:
        return self.proc.poll() is None

    def send(self, msg: dict[str, Any], where: str) -> None:
        try:
            self._lines.send(msg, where)
        except ExchangeFailed as exc:
            self._fail(str(exc))

    def request(self, msg: dict[str, Any], timeout_s: float, expect: str, where: str) -> dict[str, Any]:
        try:
            return self._lines.request(msg, timeout_s, expect, where)
        except ExchangeFailed as exc:
            self._fail(str(exc))

    def _fail(self, reason: str) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait()
        tail = _tail(self._err.name)
        self.kill()
        raise ExternalPlannerError(
            f"external planner {self.name!r} {reason}" + (f"; stderr: {tail}" if tail else "")
        )

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait()
        self._close_files()

    def close(self) -> None:
        """End the process politely (stdin closed), killing it if it lingers."""
        try:
            self.proc.stdin.close()
            self.proc.wait(timeout=2)
        except (OSError, subprocess.TimeoutExpired):
            pass
        self.kill()

    def _close_files(self) -> None:
        for f in (self.proc.stdin, self.proc.stdout):
            with contextlib.suppress(OSError):
                f.close()
        self._err.close()
        with contextlib.suppress(OSError):
            os.unlink(self._err.name)


_PROCESSES: dict[tuple[tuple[str, ...], int], PlannerProcess] = {}  #: (argv, thread) -> its process
_LOCK = threading.Lock()


def _process(name: str, argv: list[str], timeout_s: float) -> PlannerProcess:
    key = (tuple(argv), threading.get_ident())
    with _LOCK:
        proc = _PROCESSES.get(key)
    if proc is None or not proc.alive:
        proc = PlannerProcess(name, argv, timeout_s)
        with _LOCK:
            _PROCESSES[key] = proc
    return proc


def release_planner_processes() -> None:
    """End the planner processes the calling thread started (after a run: no idle processes left behind)."""
    me = threading.get_ident()
    with _LOCK:
        mine = [key for key in _PROCESSES if key[1] == me]
        procs = [_PROCESSES.pop(key) for key in mine]
    for proc in procs:
        proc.close()


@atexit.register
def close_all() -> None:
    """End every planner process this process started."""
    with _LOCK:
        procs = list(_PROCESSES.values())
        _PROCESSES.clear()
    for proc in procs:
        proc.close()


def _list(a: np.ndarray) -> list:
    return np.asarray(a, dtype=float).tolist()


def observation_message(obs: Observation) -> dict[str, Any]:
    """The protocol's observation message (episode constants on step 0)."""
    msg: dict[str, Any] = {
        "type": "observation",
        "step": int(obs.step),
        "time": float(obs.time),
        "robot": {"pose": _list(obs.robot_pose), "velocity": _list(obs.robot_velocity)},
        "goal": _list(obs.goal),
        "waypoint": _list(obs.waypoint),
        "route": _list(obs.route),
        "goal_tolerance": float(obs.goal_tolerance),
        "pedestrians": {
            "ids": np.asarray(obs.ped_ids).tolist(),
            "positions": _list(obs.ped_positions),
            "velocities": _list(obs.ped_velocities),
        },
    }
    if obs.pending_commands is not None:  # command latency: what the robot will still carry out, oldest first
        msg["pending_commands"] = {
            "commands": _list(obs.pending_commands),
            "durations": _list(obs.pending_durations),
        }
    if obs.step == 0:
        msg["robot_limits"] = {k: float(v) for k, v in obs.robot_limits.items()}
        msg["static"] = {
            "segments": _list(obs.static.segments),
            "width": float(obs.static.width),
            "height": float(obs.static.height),
        }
    return msg


def start_message(info: EpisodeInfo, params: dict[str, Any]) -> dict[str, Any]:
    """The protocol's episode start message."""
    episode = {
        "scenario": info.scenario.name,
        "seed": int(info.seed),
        "dt": float(info.dt),
        "robot_radius": float(info.robot_radius),
        "ped_radius": float(info.ped_radius),
        "kinematics": info.scenario.scenario.robot_config.kinematics,
    }
    return {"type": "start", "episode": episode, "params": params}


class ExternalPlanner:
    """The planner protocol over a planner process (started on first use, reused across episodes)."""

    name = "external"

    def __init__(self, config: ExternalPlannerConfig, argv: list[str]):
        self.config = config
        self.argv = argv
        self._proc: PlannerProcess | None = None
        self._diag: dict[str, Any] | None = None

    def reset(self, info: EpisodeInfo) -> None:
        c = self.config
        self._proc = _process(c.command, self.argv, c.start_timeout_s)
        self._proc.request(start_message(info, c.params), c.start_timeout_s, "ready", "episode start")
        self._diag = None

    def plan(self, obs: Observation) -> tuple[float, float]:
        if self._proc is None:
            raise ExternalPlannerError("plan() before reset()")
        reply = self._proc.request(
            observation_message(obs), self.config.step_timeout_s, "command", f"step {obs.step}"
        )
        try:
            v, w = float(reply["v"]), float(reply["omega"])
        except (KeyError, TypeError, ValueError):
            self._proc.kill()
            raise ExternalPlannerError(
                f"external planner {self.config.command!r} sent a command without numeric "
                f"'v' and 'omega' at step {obs.step}: {str(reply)[:120]}"
            ) from None
        diag = reply.get("diagnostics")
        self._diag = diag if isinstance(diag, dict) else None
        return v, w

    @property
    def diagnostics(self) -> dict[str, Any] | None:
        return self._diag

    def finish(self, outcome: str) -> None:
        if self._proc is not None and self._proc.alive:
            self._proc.send({"type": "end", "outcome": outcome}, "episode end")


def build_external(config: ExternalPlannerConfig) -> ExternalPlanner:
    """An external planner for a validated config (the command is looked up in this process's settings)."""
    commands = operator_commands()
    if config.command not in commands:
        raise ConfigError(
            f"external planner {config.command!r} is not configured here",
            source=ENV,
            item="planner.config.command",
        )
    return ExternalPlanner(config, commands[config.command])
