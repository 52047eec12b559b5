"""Could any robot have made it? Space-time reachability against the crowd as it actually walks.

Where pedestrians do not react to the robot (``peds_have_robot_repulsion: false``, replays), their paths
do not depend on what the robot does, so an episode is a question with an answer: is there a motion
from the start to the goal, within the robot's top speed and the episode's steps, that touches no one
and no wall? This module answers it for a *relaxed* robot: holonomic, any acceleration, its contact
distance shortened by the grid's and the time step's slack. Everything the real robot can do, the
relaxed one can, so "unreachable" is a proof that no planner could have succeeded; "reachable" is an
upper bound (a real differential-drive robot may still not make it).

The crowd is recorded once with the robot standing at its start: where pedestrians react to it
(``Reachability.peds_react``) the verdict is for that crowd, an approximation; and even where nobody
does, a group respawns, a scripted walker waiting for the robot is released and a replayed person is
admitted as they would be for a robot standing there.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from foresight.core.scenarios.model import ResolvedScenario
from foresight.core.sim.simulator import Simulator

GRID = 0.1  #: [m] cell size of the reachable set


@dataclass(frozen=True, eq=False)
class ReachMap:
    """Where the relaxed robot could be when: what a picture of the verdict shows (``core.render.reachability``)."""

    grid: float  #: [m] cell size; cell (i, j) is centred at (i grid, j grid)
    reached_at: np.ndarray  #: (nx, ny) first step each cell was reachable, -1 never (up to the verdict's step)
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
    peds_react: bool  #: pedestrians feel the robot: their paths were recorded around a standing one (approximate)
    where: ReachMap | None = field(default=None, compare=False, repr=False)  #: with ``keep_map`` only


def crowd_paths(scenario: ResolvedScenario, seed: int,
                max_steps: int | None = None) -> tuple[Simulator, list[np.ndarray]]:
    """The pedestrians' positions (N_t, 2) at steps 0..horizon around a robot that stands at its start (contacts
    with it do not end the recording)."""
    sim = Simulator()
    obs = sim.reset(scenario, int(seed), max_steps=max_steps)
    out = [np.asarray(obs.ped_positions, dtype=float)]
    while sim.t < sim.horizon:
        sim.done = False  # a pedestrian walking into the standing robot does not end the recording
        obs, _ = sim.step((0.0, 0.0))
        out.append(np.asarray(obs.ped_positions, dtype=float))
    return sim, out


def reachability(scenario: ResolvedScenario, seed: int, grid: float = GRID,
                 max_steps: int | None = None, keep_map: bool = False) -> Reachability:
    """Whether a relaxed robot (see the module docstring) can reach the goal in this episode (within ``max_steps``,
    default the scenario's horizon), and when; ``keep_map`` also keeps where it could be when (``Reachability.where``)."""
    sim, peds = crowd_paths(scenario, seed, max_steps)
    start, goal, tol = sim.robot[:2].copy(), sim.route.waypoints[-1], sim.route.tolerance  # it stood at its start
    dt, limits = sim.dt, sim.limits
    nx, ny = int(np.ceil(sim.static.width / grid)) + 1, int(np.ceil(sim.static.height / grid)) + 1
    xs, ys = np.arange(nx) * grid, np.arange(ny) * grid
    cells = np.stack(np.meshgrid(xs, ys, indexing="ij"), axis=-1)  # (nx, ny, 2)
    corner = grid / np.sqrt(2.0)  # a cell's centre stands for any point within this of it
    inside = sim.static.inside_obstacle(cells.reshape(-1, 2)).reshape(nx, ny)
    free = (sim.static.distance(cells) > limits.radius - corner) & ~inside
    at_goal = np.hypot(cells[..., 0] - goal[0], cells[..., 1] - goal[1]) <= tol + corner
    # reach per step in cells: the speed the robot can have by then from rest (its acceleration limit), half a cell
    # more so that the lattice walk keeps up with any straight line (at most 12 % faster than v_max at 0.1 m cells
    # and 0.2 m steps; more would add up to a faster robot over the steps)
    discs: dict[float, list[tuple[int, int]]] = {}
    contact = limits.radius + sim.ped_radius - corner  # the simulator's contact, judged at its steps as it does
    reach = np.zeros((nx, ny), dtype=bool)
    i0, j0 = int(round(start[0] / grid)), int(round(start[1] / grid))
    reach[max(i0 - 1, 0):i0 + 2, max(j0 - 1, 0):j0 + 2] = True
    first = np.where(reach, 0, -1) if keep_map else None
    t, found = 0, False
    for t in range(1, sim.horizon + 1):
        cells_per_step = round(min(limits.v_max, limits.accel * t * dt) * dt / grid + 0.5, 6)
        move = discs.setdefault(cells_per_step, _disc(cells_per_step))
        reach = _dilate(reach, move) & free & ~_occupied(peds[t], contact, grid, nx, ny)
        if first is not None:
            first[reach & (first < 0)] = t
        found = bool((reach & at_goal).any())
        if found or not reach.any():
            break
    where = None if first is None else ReachMap(grid, first, peds[:t + 1], start, np.asarray(goal, dtype=float),
                                                float(tol), dt)
    return Reachability(scenario.name, int(seed), found, t if found else None, sim.horizon, peds_react(scenario), where)


def peds_react(scenario: ResolvedScenario) -> bool:
    """Whether any pedestrian feels the robot (then the recorded crowd is the one around a standing robot)."""
    cfg = scenario.scenario.simulation_config
    if scenario.replay is not None or not cfg.peds_have_robot_repulsion:
        return False
    return cfg.nonreactive_fraction < 1.0 or bool(scenario.map.single_pedestrians)  # scripted walkers always react


def _disc(radius_cells: float) -> list[tuple[int, int]]:
    """Integer offsets within ``radius_cells`` of the origin."""
    r = int(np.floor(radius_cells))
    return [(i, j) for i in range(-r, r + 1) for j in range(-r, r + 1) if i * i + j * j <= radius_cells**2]


def _dilate(mask: np.ndarray, offsets: list[tuple[int, int]]) -> np.ndarray:
    """Cells within one of ``offsets`` of a set cell."""
    out = mask.copy()
    nx, ny = mask.shape
    for i, j in offsets:
        if i == 0 and j == 0:
            continue
        out[max(i, 0):nx + min(i, 0), max(j, 0):ny + min(j, 0)] |= mask[max(-i, 0):nx - max(i, 0), max(-j, 0):ny - max(j, 0)]
    return out


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
