"""Witnesses: a scripted plan that reaches the goal without contact proves that a robot with the episode's limits
could have solved it.

Why: a failed episode is the planner's to fix only if it could be solved. Where nobody reacts to the robot,
``core.sim.feasibility`` decides that for a relaxed robot (its "unreachable" is a proof, its "reachable" is not);
where the crowd reacts, the crowd's paths depend on the robot and nothing short of running the robot can tell.
So the plans run in the simulator itself, with the episode's robot and its crowd reacting to it as to any robot.

The family is built from the episode's route, so it serves any map: the route driven as is, then, for waiting
points every ``spacing`` metres along it (and ``offsets`` to either side), a drive there, a stand until a release
time (every ``release_step_s`` seconds, as late as the rest of the route still fits the horizon at full speed), and
the rest of the route. Release times are tried coarse to fine (every 8th first, then the 4th, 2nd and the rest
between), so a search cut short by ``max_plans`` has spread its tries over the whole episode. The first plan in that order
to arrive is the witness; none among the plans tried is evidence, not proof, that no robot could.

How close a witness passes matters as much as that it arrives: a plan that slips past a walker with 2 cm to spare
proves the episode solvable only for a robot that drives with no margin at all, which no planner that is safe
among people would do (``doorway_medium`` 147 at typical speed: the first witness passes within 0.01 m while the
forecast said 0.03-0.12 m). So each witness reports its closest approach to a pedestrian (``clearance_m``), and
``min_clearance`` asks for witnesses that keep that much room: a planner is answerable for the failures solvable with
the margin it is meant to keep. The closest approach to a wall is reported too (``wall_clearance_m``), not asked for:
a route whose goal lies by a wall (the reference's doorways) brings every arrival close to it.
"""

from __future__ import annotations

import math
import multiprocessing as mp
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from foresight.core.planners.scripted import Scripted, ScriptedConfig
from foresight.core.scenarios.model import ResolvedScenario

#: a waiting point needs this much room [m] beyond the robot's radius from every wall and obstacle
WALL_ROOM = 0.1


class WitnessSettings(BaseModel):
    """The plan family and the search's bounds."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    spacing: float = Field(default=1.0, ge=0.25, le=10)  #: [m] between waiting points along the route
    offsets: tuple[float, ...] = (0.0, -0.5, 0.5)  #: [m] waiting points to the route's left (+) and right (-)
    release_step_s: float = Field(default=1.0, ge=0.1, le=30)  #: [s] between release times
    max_plans: int = Field(default=2000, ge=1, le=20_000)  #: plans tried at most per episode
    max_seconds: float = Field(
        default=120.0, gt=0, le=7200
    )  #: wall time per episode [s]; the search stops after it
    #: [m] room a witness keeps from every pedestrian at every step (0: any plan that arrives without contact)
    min_clearance: float = Field(default=0.0, ge=0, le=2)


class Witness(BaseModel):
    """The search's answer for one episode: the witness plan and when it arrives, or none among the plans tried."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    scenario: str
    seed: int
    plans: int  #: plans in the family
    tried: int  #: plans run (all of them, or up to the first witness, ``max_plans`` or ``max_seconds``)
    plan: ScriptedConfig | None = None  #: the witness, None where none was found
    arrival_s: float | None = None  #: when the witness reaches the goal [s]
    clearance_m: float | None = (
        None  #: the witness's closest approach to a pedestrian [m] (None: none on the map)
    )
    wall_clearance_m: float | None = (
        None  #: its closest approach to a wall, an obstacle or the map's edge [m]
    )
    seconds: float  #: wall time of the search [s]

    @property
    def found(self) -> bool:
        return self.plan is not None

    def summary(self) -> str:
        """One line: the witness and its arrival, or how many plans found none."""
        if self.plan is not None:
            room = (
                "" if self.clearance_m is None else f", {self.clearance_m:.2f} m from the closest pedestrian"
            )
            if self.wall_clearance_m is not None:
                room += f" and {self.wall_clearance_m:.2f} m from the closest wall"
            return (
                f"solvable: {self.plan.describe()} arrives at {self.arrival_s:g} s{room} "
                f"(plan {self.tried} of {self.plans})"
            )
        cut = f" ({self.tried} of {self.plans} tried)" if self.tried < self.plans else ""
        return f"no witness among {self.tried} plans{cut}: not proof that no robot could"


def route_plans(
    scenario: ResolvedScenario, seed: int, settings: WitnessSettings | None = None
) -> list[ScriptedConfig]:
    """The family for one episode, in the order it is tried (the route driven as is first)."""
    from foresight.core.sim.geometry import points_in_polygons
    from foresight.core.sim.simulator import Simulator

    s = settings or WitnessSettings()
    sim = Simulator()
    obs = sim.reset(scenario, seed)
    path = np.vstack([obs.robot_pose[:2], obs.route]).astype(float)  # start, the waypoints, the goal
    seg = np.hypot(*np.diff(path, axis=0).T)
    ends = np.cumsum(seg)  #: route length at the end of each segment
    total = float(ends[-1])
    v_max = float(obs.robot_limits["v_max"])
    horizon = scenario.scenario.simulation_config.max_episode_steps * obs.dt
    obstacles = [np.asarray(p, dtype=float) for p in scenario.map.obstacles]
    room = obs.robot_radius + WALL_ROOM
    waypoints = [tuple(map(float, p)) for p in obs.route[:-1]]  # the goal is the driver's last target anyway
    direct = ScriptedConfig(via=tuple(waypoints))
    holds: list[tuple[tuple[int, float, float, float], ScriptedConfig]] = []
    for along in np.arange(0.0, max(total - obs.goal_tolerance, 0.0), s.spacing):
        i = min(int(np.searchsorted(ends, along, side="right")), len(seg) - 1)  # the segment holding it
        u = (path[i + 1] - path[i]) / max(seg[i], 1e-9)
        on_route = path[i] + (along - (ends[i] - seg[i])) * u
        earliest = along / v_max
        latest = horizon - (total - along) / v_max
        releases = np.arange(
            math.ceil(earliest / s.release_step_s), math.floor(latest / s.release_step_s) + 1
        )
        for off in s.offsets:
            p = on_route + off * np.array([-u[1], u[0]])
            if (
                np.any(points_in_polygons(p[None], obstacles))
                or obs.static.distance(p[None])[0] < room
                or not (0 <= p[0] <= obs.static.width and 0 <= p[1] <= obs.static.height)
            ):
                continue
            hold = (round(float(p[0]), 3), round(float(p[1]), 3))
            plan = dict(via=tuple(waypoints[:i]), hold=hold, after=tuple(waypoints[i:]))
            for k in releases.tolist():
                holds.append(
                    (
                        (_level(k), k, along, off),
                        ScriptedConfig(**plan, release_s=round(k * s.release_step_s, 3)),
                    )
                )
    holds.sort(key=lambda h: h[0])
    return [direct, *(plan for _, plan in holds)]


def _level(k: int) -> int:
    """Coarse-to-fine rank of the k-th release time: multiples of 8 first, then of 4, of 2, then the rest."""
    return next(level for level, every in enumerate((8, 4, 2, 1)) if k % every == 0)


_SCENARIO: dict[str, Any] = {}  #: what a forked worker reads: the scenario and seed searched, its simulator


def _arrival(plan: ScriptedConfig) -> tuple[float, float | None, float] | None:
    """Run one plan (in a worker): its arrival time [s] and closest approaches to a pedestrian and to a wall [m], None
    where it did not arrive or came closer to a pedestrian than the search's ``min_clearance``."""
    from foresight.core.sim.episode import run_episode
    from foresight.core.sim.simulator import Simulator

    sim = _SCENARIO.get("sim") or _SCENARIO.setdefault("sim", Simulator())
    res = run_episode(_SCENARIO["scenario"], _SCENARIO["seed"], Scripted(plan), simulator=sim)
    room = res.min_clearance
    if res.outcome != "success" or (room is not None and room < _SCENARIO["min_clearance"]):
        return None
    wall = float(np.min(sim.static.distance(res.trace.robot[:, :2]))) - sim.limits.radius
    return round(res.steps * sim.dt, 3), None if room is None else round(room, 3), round(wall, 3)


def search(
    scenario: ResolvedScenario,
    seed: int,
    settings: WitnessSettings | None = None,
    workers: int = 1,
    check: Callable[[], None] | None = None,
) -> Witness:
    """Try the family in order until a plan arrives, ``max_plans`` are tried or ``max_seconds`` pass; ``check`` (a
    job's cancellation test) is called after every plan and stops the search by raising.

    Within ``max_plans`` the answer does not depend on ``workers``: results are read in the family's order and the
    first arrival wins (``max_seconds`` is wall time, so where it cuts depends on the machine)."""
    s = settings or WitnessSettings()
    t0 = time.monotonic()
    family = route_plans(scenario, seed, s)
    todo = family[: s.max_plans]
    tried, found, arrival, room, wall = 0, None, None, None, None
    _SCENARIO.clear()
    _SCENARIO.update(scenario=scenario, seed=int(seed), min_clearance=s.min_clearance)
    for plan, arrived in _runs(todo, workers):
        tried += 1
        if arrived is not None:
            found, (arrival, room, wall) = plan, arrived
            break
        if check is not None:
            check()
        if time.monotonic() - t0 > s.max_seconds:
            break
    return Witness(
        scenario=scenario.name,
        seed=int(seed),
        plans=len(family),
        tried=tried,
        plan=found,
        arrival_s=arrival,
        clearance_m=room,
        wall_clearance_m=wall,
        seconds=round(time.monotonic() - t0, 1),
    )


def _runs(plans: list[ScriptedConfig], workers: int) -> Iterator[tuple[ScriptedConfig, tuple | None]]:
    """(plan, arrival) in the plans' order, from ``workers`` forked processes (in this one for 1); stopping early
    ends the pool."""
    if workers <= 1 or len(plans) < 2:
        for plan in plans:
            yield plan, _arrival(plan)
        return
    with mp.get_context("fork").Pool(min(workers, len(plans))) as pool:
        yield from zip(plans, pool.imap(_arrival, plans, chunksize=2), strict=True)


def witness_run(scenario: ResolvedScenario, seed: int, plan: ScriptedConfig) -> Any:
    """The witness's episode, recorded as any run (``EpisodeRun``: record, trace, geometry)."""
    from foresight.core.evaluation.episode import run_one
    from foresight.core.evaluation.plannerspec import NO_MODEL, ResolvedPlanner
    from foresight.core.sim.planner import config_hash

    config = plan.model_dump(mode="json")
    rp = ResolvedPlanner(
        name="scripted",
        variant="witness",
        config=config,
        config_hash=config_hash(config),
        model_id=NO_MODEL,
        checkpoint_sha256=NO_MODEL,
    )
    return run_one(scenario, seed, rp)


def write_player(
    out: Path,
    scenario: ResolvedScenario,
    witness: Witness,
    planner_trace: Path | None = None,
    planner_outcome: str | None = None,
    witness_trace: dict[str, Any] | None = None,
) -> Path:
    """A player page of the witness, beside the planner's own run where its compact trace is given:
    ``out/<scenario>__<seed>.html``; ``witness_trace``: the witness's compact trace where the caller has it already."""
    from foresight.core.render import player
    from foresight.core.render.episode_trace import compact_trace, episode_stem, read_compact

    if witness.plan is None:
        raise ValueError(f"{witness.scenario} seed {witness.seed} has no witness to play")
    panes = []
    if planner_trace is not None and planner_trace.is_file():
        panes.append((f"planner: {planner_outcome or 'its run'}", read_compact(planner_trace)))
    if witness_trace is None:
        witness_trace = compact_trace(witness_run(scenario, witness.seed, witness.plan), scenario.map)
    panes.append((f"witness: {witness.plan.describe()}", witness_trace))
    title = f"{witness.scenario} seed {witness.seed}: the planner and a witness"
    return player.write_player(
        out / f"{episode_stem(witness.scenario, witness.seed)}.html", panes, title, player.PAIR_NOTE
    )
