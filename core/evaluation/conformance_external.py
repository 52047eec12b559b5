"""The external planner protocol's error paths, as a conformance check (docs/planner_protocol.md "Failures").

Foresight ends an episode whose planner failed and starts the next one; a conforming process therefore serves a new
episode after one that ended with outcome ``error`` mid-way, and ends when its input is closed (no process is left
behind when a run ends).
"""

from __future__ import annotations

import time
from typing import Any

from foresight.core.evaluation.gates import GateCheck
from foresight.core.planners.external import (
    ExternalPlannerConfig,
    ExternalPlannerError,
    PlannerProcess,
    observation_message,
    operator_commands,
    start_message,
)
from foresight.core.sim.simulator import Simulator

NAME = "protocol_error_paths"
EXIT_WAIT_S = 3.0  #: how long a process may take to end after its input is closed


def protocol_error_paths(config: ExternalPlannerConfig, scenario: Any, seed: int) -> GateCheck:
    sim = Simulator()
    obs = sim.reset(scenario, seed)
    info = sim.episode_info()
    argv = operator_commands()[config.command]
    proc = None
    try:
        proc = PlannerProcess(config.command, argv, config.start_timeout_s)
        for episode in ("an episode ended with outcome error", "the next episode"):
            proc.request(
                start_message(info, config.params), config.start_timeout_s, "ready", f"start of {episode}"
            )
            proc.request(observation_message(obs), config.step_timeout_s, "command", f"step 0 of {episode}")
            proc.send({"type": "end", "outcome": "error"}, f"end of {episode}")
        proc.proc.stdin.close()
        deadline = time.monotonic() + EXIT_WAIT_S
        while proc.proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.02)
        if proc.proc.poll() is None:
            return GateCheck(
                name=NAME,
                passed=False,
                value=EXIT_WAIT_S,
                threshold=EXIT_WAIT_S,
                detail=f"still running {EXIT_WAIT_S:g} s after its input was closed",
            )
    except ExternalPlannerError as exc:
        return GateCheck(name=NAME, passed=False, detail=str(exc)[:300])
    finally:
        if proc is not None:
            proc.kill()
    return GateCheck(
        name=NAME,
        passed=True,
        detail="served an episode after one ended with an error; ended when its input closed",
    )
