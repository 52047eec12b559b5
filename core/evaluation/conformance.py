"""Planner conformance: does a planner keep the planner contract before its numbers enter a campaign or a gate?

Each check drives the planner in the simulator (a short stretch of a real episode) and names what it found:

- ``finite``: every command is two finite numbers;
- ``within_limits``: every command is within the robot's limits for its kinematics (``robot_limits``: v in
  [v_min, v_max] and |omega| <= w_max; a holonomic robot's (vx, vy) no faster than v_max);
- ``deterministic``: two fresh planners on the same seed give the same commands;
- ``decision_budget``: the 95th percentile of the decision time (first decision excluded) within the budget;
- ``no_pedestrians`` / ``crowd_200``: answers two finite numbers with 0 and with 200 pedestrians;
- ``reset_leaves_no_state``: a planner that ran another episode first, then reset, gives the commands of a fresh
  one (needs ``deterministic``; left out when that failed);
- ``protocol_error_paths`` (external planners): after an episode that ended with an error the process serves the
  next episode, and closing its input ends it.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np
from pydantic import ConfigDict, Field

from foresight.core.evaluation.config import _Config
from foresight.core.evaluation.gates import GateCheck, GateResult
from foresight.core.evaluation.plannerspec import PlannerSpec, build_planner, planner_spec, resolve_planner
from foresight.core.evaluation.runner import bundle_file
from foresight.core.runtime.context import StageContext
from foresight.core.runtime.refs import BUILTIN_BUNDLE, BundlePath, Ident, Name
from foresight.core.sim.observation import Observation
from foresight.core.sim.planner import Planner
from foresight.core.sim.simulator import Simulator

CHECKS = (
    "finite",
    "within_limits",
    "deterministic",
    "decision_budget",
    "no_pedestrians",
    "crowd_200",
    "reset_leaves_no_state",
    "protocol_error_paths",
)
TOLERANCE = 1e-6  #: commands may exceed a limit by this much (float round-off)


class ConformanceConfig(_Config):
    """Which planner, on which episode stretch, with which decision budget."""

    planner: PlannerSpec = Field(default_factory=planner_spec)
    bundle: Ident = BUILTIN_BUNDLE
    matrix: BundlePath = "scenarios/classic_interactions.yaml"
    scenario: Name = "crossing_medium"  #: a scenario with pedestrians from the start
    seeds: tuple[int, int] = (1, 2)  #: the checked episode's seed, and the other episode's (reset check)
    steps: int = Field(default=40, ge=5, le=400)  #: decisions per episode stretch
    decision_budget_s: float = Field(default=0.5, gt=0, le=60)
    crowd: int = Field(default=200, ge=1, le=1000)  #: the large crowd's size


class ConformanceResult(GateResult):
    model_config = ConfigDict(extra="forbid")
    planner: str
    failed: list[str] = Field(default_factory=list)  #: names of the failed checks
    wall_s: float = 0.0


def _episode(
    make: Callable[[], Planner], scenario: Any, seed: int, steps: int, planner: Planner | None = None
) -> tuple[list[tuple[float, float]], list[float], list[Observation], Planner]:
    """Drive ``steps`` decisions (or to the episode's end); (commands, decision times, observations, planner)."""
    sim = Simulator()
    obs = sim.reset(scenario, seed)
    planner = planner or make()
    planner.reset(sim.episode_info())
    commands, times, seen = [], [], []
    for _ in range(steps):
        seen.append(obs)
        t = time.perf_counter()
        cmd = planner.plan(obs)
        times.append(time.perf_counter() - t)
        commands.append(tuple(float(c) for c in cmd))
        if not all(math.isfinite(c) for c in commands[-1]):
            break
        obs, events = sim.step(commands[-1])
        if events.done:
            break
    _finish(planner, "timeout")
    return commands, times, seen, planner


def _finish(planner: Planner, outcome: str) -> None:
    finish = getattr(planner, "finish", None)
    if callable(finish):
        finish(outcome)


def outside_limits(cmd: tuple[float, ...], limits: dict[str, float]) -> str | None:
    """Why a command breaks the robot's limits (None: it does not)."""
    if len(cmd) != 2:
        return f"{len(cmd)} numbers instead of 2"
    a, b = cmd
    v_max, v_min, w_max = (
        limits.get("v_max", math.inf),
        limits.get("v_min", 0.0),
        limits.get("w_max", math.inf),
    )
    if limits.get("holonomic", 0.0) == 1.0:
        speed = math.hypot(a, b)
        return f"speed {speed:.3g} > v_max {v_max:g}" if speed > v_max + TOLERANCE else None
    if a > v_max + TOLERANCE or a < v_min - TOLERANCE:
        return f"v {a:.3g} outside [{v_min:g}, {v_max:g}]"
    if abs(b) > w_max + TOLERANCE:
        return f"omega {b:.3g} outside +-{w_max:g}"
    return None


def _crowd(obs: Observation, n: int, seed: int = 0) -> Observation:
    """``obs`` with ``n`` pedestrians around the robot (none nearer than 1.5 m), walking in random directions."""
    rng = np.random.default_rng(seed)
    if n == 0:
        pos, vel = np.zeros((0, 2)), np.zeros((0, 2))
    else:
        r = rng.uniform(1.5 + obs.robot_radius + obs.ped_radius, 15.0, n)
        a = rng.uniform(-np.pi, np.pi, n)
        pos = obs.robot_pose[:2] + np.stack([r * np.cos(a), r * np.sin(a)], axis=1)
        b = rng.uniform(-np.pi, np.pi, n)
        vel = 1.2 * np.stack([np.cos(b), np.sin(b)], axis=1)
    return dataclasses.replace(
        obs, ped_ids=np.arange(n, dtype=np.int64), ped_positions=pos, ped_velocities=vel
    )


def _crowd_check(name: str, make: Callable[[], Planner], scenario: Any, seed: int, n: int) -> GateCheck:
    sim = Simulator()
    obs = sim.reset(scenario, seed)
    planner = make()
    planner.reset(sim.episode_info())
    try:
        for k in range(3):
            o = _crowd(dataclasses.replace(obs, step=k, time=k * obs.dt), n)
            cmd = tuple(float(c) for c in planner.plan(o))
            bad = None if len(cmd) == 2 and all(map(math.isfinite, cmd)) else f"command {cmd}"
            if bad:
                return GateCheck(name=name, passed=False, value=float(n), detail=f"decision {k}: {bad}")
    except Exception as exc:  # noqa: BLE001 - what the planner raised is the finding
        return GateCheck(
            name=name, passed=False, value=float(n), detail=f"raised {type(exc).__name__}: {exc}"[:300]
        )
    finally:
        _finish(planner, "timeout")
    return GateCheck(name=name, passed=True, value=float(n), detail="3 decisions, each two finite numbers")


def check_planner(
    make: Callable[[], Planner], scenario: Any, cfg: ConformanceConfig, label: str, external: Any = None
) -> ConformanceResult:
    """Every check of the module docstring on planners built by ``make`` (``external``: the external planner's
    config, for the protocol's error paths)."""
    t0 = time.perf_counter()
    checks: list[GateCheck] = []
    s1, s2 = cfg.seeds
    try:
        cmds, times, seen, _ = _episode(make, scenario, s1, cfg.steps)
    except Exception as exc:  # noqa: BLE001 - a planner that cannot drive one stretch fails everything after
        detail = f"raised {type(exc).__name__}: {exc}"[:300]
        checks = [GateCheck(name=n, passed=False, detail=detail) for n in CHECKS[:2]]
        return _result(label, checks, t0)
    limits = seen[0].robot_limits
    nonfinite = [k for k, c in enumerate(cmds) if not all(map(math.isfinite, c))]
    checks.append(
        GateCheck(
            name="finite",
            passed=not nonfinite,
            value=float(len(nonfinite)),
            threshold=0.0,
            detail=f"decision {nonfinite[0]}: {cmds[nonfinite[0]]}"
            if nonfinite
            else f"{len(cmds)} decisions",
        )
    )
    bad = [(k, why) for k, c in enumerate(cmds) if (why := outside_limits(c, limits))]
    checks.append(
        GateCheck(
            name="within_limits",
            passed=not bad,
            value=float(len(bad)),
            threshold=0.0,
            detail=f"decision {bad[0][0]}: {bad[0][1]}" if bad else "every command",
        )
    )
    again, _, _, _ = _safe_episode(make, scenario, s1, cfg.steps)
    first = _first_difference(cmds, again)
    deterministic = first is None
    checks.append(
        GateCheck(
            name="deterministic",
            passed=deterministic,
            detail="same commands on the same seed" if deterministic else first,
        )
    )
    steady = sorted(times[1:]) or times
    p95 = steady[min(len(steady) - 1, int(0.95 * len(steady)))]
    checks.append(
        GateCheck(
            name="decision_budget",
            passed=p95 <= cfg.decision_budget_s,
            value=p95,
            threshold=cfg.decision_budget_s,
            detail="95th percentile decision time [s]",
        )
    )
    checks.append(_crowd_check("no_pedestrians", make, scenario, s1, 0))
    checks.append(_crowd_check(f"crowd_{cfg.crowd}", make, scenario, s1, cfg.crowd))
    if deterministic:
        try:
            _, _, _, used = _episode(make, scenario, s2, max(5, cfg.steps // 2))
            reused, _, _, _ = _episode(make, scenario, s1, cfg.steps, planner=used)
            diff = _first_difference(cmds, reused)
        except Exception as exc:  # noqa: BLE001
            diff = f"raised {type(exc).__name__}: {exc}"[:300]
        checks.append(
            GateCheck(
                name="reset_leaves_no_state",
                passed=diff is None,
                detail="after another episode and a reset: a fresh planner's commands"
                if diff is None
                else diff,
            )
        )
    if external is not None:
        from foresight.core.evaluation.conformance_external import protocol_error_paths

        checks.append(protocol_error_paths(external, scenario, s1))
    return _result(label, checks, t0)


def _safe_episode(make: Callable[[], Planner], scenario: Any, seed: int, steps: int) -> tuple:
    try:
        return _episode(make, scenario, seed, steps)
    except Exception as exc:  # noqa: BLE001
        return [("raised", f"{type(exc).__name__}: {exc}")], [], [], None


def _first_difference(a: list, b: list) -> str | None:
    for k, (x, y) in enumerate(zip(a, b, strict=False)):
        if not _same(x, y):
            return f"decision {k}: {x} then {y}"
    return None if len(a) == len(b) else f"{len(a)} decisions then {len(b)}"


def _same(x: tuple, y: tuple) -> bool:
    """The same command (NaN equals NaN: a planner that always answers NaN is non-finite, not non-deterministic)."""
    return len(x) == len(y) and all(a == b or (a != a and b != b) for a, b in zip(x, y, strict=True))


def _result(label: str, checks: list[GateCheck], t0: float) -> ConformanceResult:
    failed = [c.name for c in checks if not c.passed]
    return ConformanceResult(
        passed=not failed, checks=checks, planner=label, failed=failed, wall_s=time.perf_counter() - t0
    )


def run_conformance(config: ConformanceConfig, ctx: StageContext) -> ConformanceResult:
    """The ``planner_check`` stage: resolve the planner as an evaluation would, then :func:`check_planner`."""
    from foresight.core.scenarios.loader import load_matrix

    matrix = load_matrix(bundle_file(ctx, config.bundle, config.matrix))
    scenario = matrix.get(config.scenario)
    rp = resolve_planner(config.planner, ctx)
    ctx.progress(0.0, f"checking {rp.label}")
    external = None
    if rp.name == "external":
        from foresight.core.planners.external import ExternalPlannerConfig

        external = ExternalPlannerConfig.model_validate(rp.config)
    result = check_planner(lambda: build_planner(rp), scenario, config, rp.label, external=external)
    if rp.name == "external":
        from foresight.core.planners.external import release_planner_processes

        release_planner_processes()
    ctx.log(
        f"{rp.label}: " + ("every check passed" if result.passed else "FAILED " + ", ".join(result.failed))
    )
    return result
