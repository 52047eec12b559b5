"""Could any robot have made it? Space-time reachability against the crowd as it actually walks.

Where pedestrians do not react to the robot (``peds_have_robot_repulsion: false``, replays), their paths
do not depend on what the robot does, so an episode is a question with an answer: is there a motion
from the start to the goal, within the robot's top speed and the episode's steps, that touches no one
and no wall? This module answers it for a *relaxed* robot: holonomic (it turns and brakes at once), no
farther over any stretch of steps than the robot at its top speed and acceleration (plus a grid's slack
of sqrt 2 cells per stretch), its contact distance shortened by the grid's slack. Everything the real
robot can do, the relaxed one can, so "unreachable" is a proof that no planner could have succeeded;
"reachable" is an upper bound (a real differential-drive robot may still not make it).

The crowd is recorded once with the robot standing at its start: where pedestrians react to it
(``Reachability.peds_react``) the verdict is for that crowd, an approximation; and even where nobody
does, a group respawns, a scripted walker waiting for the robot is released and a replayed person is
admitted as they would be for a robot standing there.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from foresight.core.scenarios.model import ResolvedScenario
from foresight.core.sim.robot import RobotLimits
from foresight.core.sim.simulator import Simulator

GRID = 0.1  #: [m] cell size of the reachable set


@dataclass(frozen=True, eq=False)
class ReachMap:
    """Where the relaxed robot could be when: what a picture of the verdict shows (``core.render.reachability``)."""

    grid: float  #: [m] cell size; cell (i, j) is centred at (i grid, j grid)
    reached_at: (
        np.ndarray
    )  #: (nx, ny) first step each cell was reachable, -1 never (up to the verdict's step)
    crowd: list[np.ndarray]  #: pedestrian positions (N_t, 2) at steps 0..that step
    start: np.ndarray  #: (2,) the robot's start [m]
    goal: np.ndarray  #: (2,) its goal [m]
    tolerance: float  #: goal tolerance [m]
    dt: float  #: simulator step [s]


@dataclass(frozen=True)
class Reachability:
    """The verdict for one (scenario, seed) episode."""

    scenario: str
    seed: int
    reachable: bool
    first_step: int | None  #: earliest step the relaxed robot is within the goal tolerance; None if never
    horizon: int
    peds_react: (
        bool  #: pedestrians feel the robot: their paths were recorded around a standing one (approximate)
    )
    where: ReachMap | None = field(default=None, compare=False, repr=False)  #: with ``keep_map`` only


def crowd_paths(
    scenario: ResolvedScenario, seed: int, max_steps: int | None = None
) -> tuple[Simulator, list[np.ndarray], list[np.ndarray]]:
    """The pedestrians' positions (N_t, 2) and ids (N_t,) at steps 0..horizon around a robot that stands at its start
    (contacts with it do not end the recording)."""
    sim = Simulator()
    obs = sim.reset(scenario, int(seed), max_steps=max_steps)
    pos, ids = [np.asarray(obs.ped_positions, dtype=float)], [np.asarray(obs.ped_ids, dtype=np.int64)]
    while sim.t < sim.horizon:
        sim.done = False  # a pedestrian walking into the standing robot does not end the recording
        obs, _ = sim.step((0.0, 0.0))
        pos.append(np.asarray(obs.ped_positions, dtype=float))
        ids.append(np.asarray(obs.ped_ids, dtype=np.int64))
    return sim, pos, ids


def reachability(
    scenario: ResolvedScenario,
    seed: int,
    grid: float = GRID,
    max_steps: int | None = None,
    keep_map: bool = False,
) -> Reachability:
    """Whether a relaxed robot (see the module docstring) can reach the goal in this episode (within ``max_steps``,
    default the scenario's horizon), and when; ``keep_map`` also keeps where it could be when (``Reachability.where``)."""
    sim, peds, _ = crowd_paths(scenario, seed, max_steps)
    start, goal, tol = (
        sim.robot[:2].copy(),
        sim.route.waypoints[-1],
        sim.route.tolerance,
    )  # it stood at its start
    dt, limits = sim.dt, sim.limits
    nx, ny = int(np.ceil(sim.static.width / grid)) + 1, int(np.ceil(sim.static.height / grid)) + 1
    xs, ys = np.arange(nx) * grid, np.arange(ny) * grid
    cells = np.stack(np.meshgrid(xs, ys, indexing="ij"), axis=-1)  # (nx, ny, 2)
    corner = grid / np.sqrt(2.0)  # a cell's centre stands for any point within this of it
    inside = sim.static.inside_obstacle(cells.reshape(-1, 2)).reshape(nx, ny)
    free = (sim.static.distance(cells) > limits.radius - corner) & ~inside
    at_goal = np.hypot(cells[..., 0] - goal[0], cells[..., 1] - goal[1]) <= tol + corner
    contact = (
        limits.radius + sim.ped_radius - corner
    )  # the simulator's contact, judged at its steps as it does
    i0, j0 = int(round(start[0] / grid)), int(round(start[1] / grid))
    space = _Space(free, at_goal, peds, contact, grid, keep_map)
    t, found = _reach(space, (i0, j0), limits, dt, sim.horizon, grid)
    where = (
        None
        if space.first is None
        else ReachMap(grid, space.first, peds[: t + 1], start, np.asarray(goal, dtype=float), float(tol), dt)
    )
    return Reachability(
        scenario.name, int(seed), found, t if found else None, sim.horizon, peds_react(scenario), where
    )


class _Space:
    """Where the relaxed robot may be at a step (free of walls and of the crowd then), the goal, and (``keep_map``)
    the first step each cell was reached."""

    def __init__(
        self,
        free: np.ndarray,
        at_goal: np.ndarray,
        peds: list[np.ndarray],
        contact: float,
        grid: float,
        keep_map: bool,
    ):
        self.free, self.at_goal, self.peds, self.contact, self.grid = free, at_goal, peds, contact, grid
        self.first = np.full(free.shape, -1) if keep_map else None

    def allowed(self, t: int) -> np.ndarray:
        nx, ny = self.free.shape
        return self.free & ~_occupied(self.peds[t], self.contact, self.grid, nx, ny)

    def note(self, reach: np.ndarray, t: int) -> bool:
        """Records cells first reached at step ``t``; whether the goal is reached."""
        if self.first is not None:
            self.first[reach & (self.first < 0)] = t
        return bool((reach & self.at_goal).any())


def _reach(
    space: _Space, cell: tuple[int, int], limits: RobotLimits, dt: float, horizon: int, grid: float
) -> tuple[int, bool]:
    """The relaxed robot's first step at the goal (step, True), or where it stopped (step, False).

    A cell is reachable at step t when it is allowed then and, for every look-back j (``LOOK_BACK`` and the start),
    lies within the farthest the robot can travel from step t - j to t (``_travel``) of a cell reachable at t - j,
    plus sqrt 2 cells: a point's cell centre moves by less than one cell more per axis than the point does, so no
    motion is lost (the verdict is a proof), and the slack is paid once per window, not per step: the relaxed robot
    is at most sqrt 2 cells per look-back window faster than the real one (a straight run from the start: 0.14 m).
    """
    travel = _travel(limits, dt, horizon)
    farthest = (
        limits.v_max * dt * LOOK_BACK[-1] / grid + _SLACK
    )  #: [cells] no look-back bound reaches farther
    reach = np.zeros(space.free.shape, dtype=bool)
    reach[cell] = True
    space.note(reach, 0)
    start = _edt(reach)
    recent: dict[int, np.ndarray] = {0: start}  #: step -> distance [cells] to the cells reachable then
    t, found = 0, False
    for t in range(1, horizon + 1):
        reach = space.allowed(t) & (start < travel[t] / grid + _SLACK)
        for j in LOOK_BACK:
            if t - j > 0:
                reach &= recent[t - j] < (travel[t] - travel[t - j]) / grid + _SLACK
        found = space.note(reach, t)
        if found or not reach.any():
            break
        recent[t] = _edt(reach, within=farthest)
        recent.pop(t - LOOK_BACK[-1], None)
    return t, found


#: [steps] windows over which the relaxed robot's travel is bounded (besides the whole run from its start): the
#: one-step window moves the set, the longer ones keep the per-window slack from adding up to a faster robot
LOOK_BACK = (1, 2, 4, 8, 16)
#: [cells] a cell index moves by less than one cell more than its point, per axis (1e-4: the float32 distances' rounding)
_SLACK = np.sqrt(2.0) + 1e-4


def _travel(limits: RobotLimits, dt: float, horizon: int) -> np.ndarray:
    """(horizon + 1,) the farthest [m] the robot can be from its start after each step, from rest: each step moves
    it at most dt x its speed after that step's acceleration (the simulator's order), capped at v_max (backwards
    too where it may: at most as fast)."""
    speed = np.minimum(limits.v_max, limits.accel * dt * np.arange(1, horizon + 1))
    return np.concatenate([[0.0], np.cumsum(speed * dt)])


def _edt(reach: np.ndarray, within: float = np.inf) -> np.ndarray:
    """Distance [cells] from every cell to the nearest cell of ``reach``, exact up to ``within`` cells (inf beyond
    that and where ``reach`` is empty): worked out on the set's bounding box grown by ``within`` only."""
    from scipy.ndimage import distance_transform_edt

    out = np.full(reach.shape, np.inf, np.float32)
    rows, cols = np.flatnonzero(reach.any(axis=1)), np.flatnonzero(reach.any(axis=0))
    if not len(rows):
        return out
    pad = int(min(np.ceil(within), max(reach.shape)))
    a, b = max(rows[0] - pad, 0), min(rows[-1] + pad + 1, reach.shape[0])
    c, d = max(cols[0] - pad, 0), min(cols[-1] + pad + 1, reach.shape[1])
    out[a:b, c:d] = distance_transform_edt(~reach[a:b, c:d])
    return out


def peds_react(scenario: ResolvedScenario) -> bool:
    """Whether any pedestrian feels the robot (then the recorded crowd is the one around a standing robot)."""
    cfg = scenario.scenario.simulation_config
    if scenario.replay is not None or not cfg.peds_have_robot_repulsion:
        return False
    return cfg.nonreactive_fraction < 1.0 or bool(
        scenario.map.single_pedestrians
    )  # scripted walkers always react


def _occupied(pos: np.ndarray, contact: float, grid: float, nx: int, ny: int) -> np.ndarray:
    """Cells whose centre is within ``contact`` of a pedestrian."""
    occ = np.zeros((nx, ny), dtype=bool)
    r = int(np.ceil(contact / grid))
    di, dj = np.meshgrid(np.arange(-r, r + 1), np.arange(-r, r + 1), indexing="ij")
    for x, y in pos:
        ci, cj = int(round(x / grid)), int(round(y / grid))
        ii, jj = ci + di, cj + dj
        ok = (ii >= 0) & (ii < nx) & (jj >= 0) & (jj < ny)
        ok &= (ii * grid - x) ** 2 + (jj * grid - y) ** 2 < contact**2
        occ[ii[ok], jj[ok]] = True
    return occ
