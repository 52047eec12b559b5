"""Goal updates of the crowd each step: route following with respawn, crowded zones, scripted single peds.

Each behaviour checks its trigger with a few vectorised operations per step and only drops into
Python for the (rare) groups whose trigger fired: a waypoint reached, a respawn, a wait ending.
"""

from __future__ import annotations

import math

import numpy as np

from foresight.core.maps.model import DEFAULT_HOLD_TIMEOUT_S, ROLE_OFFSETS, MapDef, SinglePedestrian
from foresight.core.sim.forces import as_complex, as_xy, group_centroids
from foresight.core.sim.population import Population
from foresight.core.sim.zones import Validator, sample_free


class CrowdArrays:
    """The mutable pedestrian state shared by the behaviours and the integrator.

    Stored as complex x + iy arrays (N,) for the force kernels; ``pos``/``vel``/``goal`` are
    writable (N, 2) float views of the same memory, so updates through either are seen by both.
    """

    def __init__(self, pop: Population):
        self.z = as_complex(pop.pos).copy()  #: (N,) complex positions [m]
        self.zv = as_complex(pop.vel).copy()  #: (N,) complex velocities [m/s]
        self.zgoal = as_complex(pop.goal).copy()  #: (N,) complex goals [m]
        self.vmax = pop.vmax.copy()  #: (N,) [m/s]
        self.group = pop.group  #: (N,) group index
        self.group_size = pop.group_size  #: (G,)
        self.robot_response = pop.robot_response  #: (N,) robot-repulsion multiplier per ped, None = all 1
        self.ids = np.arange(len(self.pos), dtype=np.int64)  #: (N,) true ids; respawns get new ones
        self.next_id = len(self.pos)

    @property
    def pos(self) -> np.ndarray:
        """(N, 2) [m], a view of ``z``."""
        return as_xy(self.z)

    @property
    def vel(self) -> np.ndarray:
        """(N, 2) [m/s], a view of ``zv``."""
        return as_xy(self.zv)

    @property
    def goal(self) -> np.ndarray:
        """(N, 2) [m], a view of ``zgoal``."""
        return as_xy(self.zgoal)

    def centroids(self) -> np.ndarray:
        """Group centroids (G,) complex [m]."""
        return group_centroids(self.z, self.group, self.group_size)

    def renew_ids(self, rows: np.ndarray) -> None:
        self.ids[rows] = np.arange(self.next_id, self.next_id + len(rows))
        self.next_id += len(rows)


class RouteFollowing:
    """Group-centroid navigator over each route; at the last waypoint the group respawns at the route's start."""

    def __init__(self, pop: Population, map_def: MapDef, threshold: float, zone_mode: str):
        self.routes = map_def.ped_routes
        self.spawn_zones = map_def.ped_spawn_zones
        kmax = max((len(r.waypoints) for r in self.routes), default=1)
        self.table = np.zeros((len(self.routes), kmax, 2))  #: (R, Kmax, 2) padded waypoints
        self.last = np.array([len(r.waypoints) - 1 for r in self.routes], dtype=np.intp)  #: (R,)
        for i, r in enumerate(self.routes):
            self.table[i, : len(r.waypoints)] = r.waypoints
        self.groups = pop.route_groups  #: (Gr,)
        self.route = pop.route_of_group  #: (Gr,)
        self.wp = pop.route_wp.copy()  #: (Gr,)
        self.members = [np.nonzero(pop.group == g)[0] for g in self.groups]
        self.end = self.table[self.route, self.last[self.route]]  #: (Gr, 2) constant
        self.thr2 = threshold**2
        self.zone_mode = zone_mode

    def step(
        self, crowd: CrowdArrays, centroids: np.ndarray, rng: np.random.Generator, valid: Validator
    ) -> bool:
        """Advance navigators and respawn finished groups; True when positions changed (a respawn)."""
        if len(self.groups) == 0:
            return False
        c = as_xy(centroids)[self.groups]
        at_end = ((c - self.end) ** 2).sum(axis=1) <= self.thr2
        cur = self.table[self.route, self.wp]
        near = (((c - cur) ** 2).sum(axis=1) <= self.thr2) & ~at_end
        if near.any():
            for k in np.nonzero(near)[0]:
                self.wp[k] = min(self.wp[k] + 1, self.last[self.route[k]])
                crowd.goal[self.members[k]] = self.table[self.route[k], self.wp[k]]
        moved = False
        if at_end.any():
            for k in np.nonzero(at_end)[0]:
                moved |= self._respawn(k, crowd, rng, valid)
        return moved

    def restart_all(self, crowd: CrowdArrays, rng: np.random.Generator, valid: Validator) -> None:
        """Every group to its route's spawn zone, heading for the first waypoint (``peds_reset_follow_route_at_start``).

        Ids are kept: at reset no pedestrian has been seen yet.
        """
        ids = crowd.ids.copy()
        for k in range(len(self.groups)):
            self._respawn(k, crowd, rng, valid)
        crowd.ids[:], crowd.next_id = ids, len(ids)

    def _respawn(self, k: int, crowd: CrowdArrays, rng: np.random.Generator, valid: Validator) -> bool:
        """New positions in the route's spawn zone, goal = first waypoint, new ids; velocities kept (reference).

        When the zone has no room (the robot stands in it), the group waits at the route's end and
        tries again next step instead of spawning onto the robot. Returns whether it respawned.
        """
        route = self.routes[self.route[k]]
        rows = self.members[k]
        pts = sample_free(
            self.spawn_zones[route.spawn_id], len(rows), rng, self.zone_mode, valid, required=False
        )
        if pts is None:
            return False
        crowd.pos[rows] = pts
        self.wp[k] = 0
        crowd.goal[rows] = self.table[self.route[k], 0]
        crowd.renew_ids(rows)
        return True


class CrowdedZones:
    """Groups wander inside their zone: a new goal in the zone whenever the centroid comes within the threshold."""

    def __init__(
        self, pop: Population, map_def: MapDef, threshold: float, zone_mode: str, always_valid: Validator
    ):
        self.zones = map_def.ped_crowded_zones
        self.groups = pop.zone_groups
        self.zone = pop.zone_of_group
        self.members = [np.nonzero(pop.group == g)[0] for g in self.groups]
        self.first = np.array([m[0] for m in self.members], dtype=np.intp)  #: (Gz,) a member row per group
        self.thr2 = threshold**2
        self.zone_mode = zone_mode
        self.valid = always_valid

    def step(self, crowd: CrowdArrays, centroids: np.ndarray, rng: np.random.Generator) -> None:
        if len(self.groups) == 0:
            return
        reached = ((as_xy(centroids)[self.groups] - crowd.goal[self.first]) ** 2).sum(axis=1) <= self.thr2
        for k in np.nonzero(reached)[0]:
            g = sample_free(self.zones[self.zone[k]], 1, rng, self.zone_mode, self.valid)[0]
            crowd.goal[self.members[k]] = g


class SingleScripts:
    """Scripted pedestrians: start delay, goal or trajectory (0.2 m waypoint threshold) with timed waits, roles, holds.

    Event-driven: per step only a timer check and a distance check against the watched waypoints,
    plus one vectorised goal update for peds whose goal moves (robot-relative roles, ``join``) and
    one for peds held in place (``wait`` role, proximity holds). Phases per ped: DELAY (held at
    start), MOVE (towards trajectory waypoint ``index``), WAIT (held at it for a timed wait), HOLD
    (held at the waypoint before ``hold_ref_point`` until the robot comes within
    ``hold_until_robot_within_m`` of that point or ``hold_timeout_s`` passes), TRACK (goal follows
    the robot or the joined ped every step), STAY (``wait`` role: held for good), DONE (goal set for
    good; the desired force brakes there, no respawn). See docs/scenarios.md for the role semantics.
    """

    NEVER = np.iinfo(np.int64).max
    DELAY, MOVE, WAIT, DONE, HOLD, TRACK, STAY = range(7)

    def __init__(self, singles: list[SinglePedestrian], first_row: int, dt: float, threshold: float):
        self.singles = singles
        self.rows = np.arange(first_row, first_row + len(singles))
        m = len(singles)
        self.dt = dt
        self.thr2 = threshold**2
        self.phase = np.full(m, self.DONE)  #: (M,)
        self.target = np.zeros((m, 2))  #: (M, 2) current trajectory waypoint [m]
        self.wake = np.full(m, self.NEVER, dtype=np.int64)  #: (M,) step at which a delay/wait/hold ends
        self.index = np.zeros(m, dtype=np.intp)  #: (M,) current trajectory waypoint index
        self.waits = [{w.waypoint_index: w.wait_s for w in sp.wait_at} for sp in singles]
        self.hold_index = np.array([hold_waypoint(sp) for sp in singles], dtype=np.intp).reshape(
            m
        )  #: -1 = none
        self.hold_ref = np.array([sp.hold_ref_point or (0.0, 0.0) for sp in singles], dtype=float).reshape(
            m, 2
        )
        self.hold_r2 = np.array([(sp.hold_until_robot_within_m or 0.0) ** 2 for sp in singles]).reshape(m)
        self.released_by: dict[
            str, str
        ] = {}  #: ped id -> "robot_proximity" | "timeout", for holds that released
        self.offset = np.zeros((m, 2))  #: (M, 2) robot-frame (forward, lateral) offsets of tracking peds [m]
        self.follow_ped = np.full(
            m, -1, dtype=np.intp
        )  #: (M,) row of the ped a ``join`` ped walks to (-2 = nearest)
        ids = {sp.id: first_row + k for k, sp in enumerate(singles)}
        for k, sp in enumerate(singles):
            if tracks_robot(sp):
                self.offset[k] = sp.role_offset or ROLE_OFFSETS[sp.role]
            elif sp.role == "join":
                self.follow_ped[k] = ids[sp.role_target_id] if sp.role_target_id else -2
        self.robot_rel = np.array([tracks_robot(sp) for sp in singles], dtype=bool).reshape(m)
        for k, sp in enumerate(singles):
            if sp.start_delay_s > 0:
                self.phase[k] = self.DELAY
                self.wake[k] = self._steps(sp.start_delay_s)
            else:
                self._begin(k, None)
        self.next_wake, self.any_moving, self.any_held, self.any_tracking = self.NEVER, False, False, False
        if m:
            self._refresh()

    def _steps(self, seconds: float) -> int:
        return int(round(seconds / self.dt))

    def _begin(self, k: int, crowd: CrowdArrays | None) -> None:
        """Start ped k's script once its start delay (if any) is over."""
        sp = self.singles[k]
        if sp.role == "wait":
            self.phase[k] = self.STAY
        elif self.robot_rel[k] or sp.role == "join":
            self.phase[k] = self.TRACK
        elif sp.goal is not None:
            if crowd is not None:
                crowd.goal[self.rows[k]] = sp.goal
            self.phase[k] = self.DONE
        elif sp.trajectory:
            self._move(k, 0, crowd)

    def _move(self, k: int, index: int, crowd: CrowdArrays | None) -> None:
        """Head for trajectory waypoint ``index``, or finish when the trajectory is exhausted."""
        traj = self.singles[k].trajectory
        if index >= len(traj):
            self.phase[k] = self.DONE
            return
        self.phase[k], self.index[k] = self.MOVE, index
        self.target[k] = traj[index]
        if crowd is not None:
            crowd.goal[self.rows[k]] = traj[index]

    def step(self, crowd: CrowdArrays, step: int, robot: np.ndarray | None = None) -> None:
        """Advance the scripts by one step; ``robot`` = (x, y, heading, ...) at the start of the step."""
        if len(self.rows) == 0:
            return
        if step >= self.next_wake:
            for k in np.nonzero(self.wake <= step)[0]:
                self.wake[k] = self.NEVER
                self._wake(k, crowd, step)
            self._refresh()
        if self.any_moving:
            d2 = ((crowd.pos[self.rows] - self.target) ** 2).sum(axis=1)
            hits = np.nonzero((self.phase == self.MOVE) & (d2 <= self.thr2))[0]
            if len(hits):
                for k in hits:
                    self._reached(k, crowd, step)
                self._refresh()
        if self.any_held:
            self._held(crowd, step, robot)
        if self.any_tracking:
            self._track(crowd, robot)

    def _refresh(self) -> None:
        """Cache the earliest wake-up step and which per-step updates are needed."""
        self.next_wake = int(self.wake.min())
        self.any_moving = bool((self.phase == self.MOVE).any())
        self.any_held = bool(((self.phase == self.HOLD) | (self.phase == self.STAY)).any())
        self.any_tracking = bool((self.phase == self.TRACK).any())

    def _wake(self, k: int, crowd: CrowdArrays, step: int) -> None:
        if self.phase[k] == self.WAIT:
            self._after_arrival(k, crowd, step)
        elif self.phase[k] == self.HOLD:
            self._release(k, crowd, "timeout")
        else:
            self._begin(k, crowd)

    def _reached(self, k: int, crowd: CrowdArrays, step: int) -> None:
        wait = self.waits[k].get(int(self.index[k]), 0.0)
        if wait > 0:
            row = self.rows[k]
            crowd.goal[row] = crowd.pos[row]
            crowd.vel[row] = 0.0
            self.phase[k] = self.WAIT
            self.wake[k] = step + self._steps(wait)
        else:
            self._after_arrival(k, crowd, step)

    def _after_arrival(self, k: int, crowd: CrowdArrays, step: int) -> None:
        """At a waypoint (its wait done): hold there when it is the hold waypoint, else go on."""
        if self.index[k] == self.hold_index[k]:
            self.phase[k] = self.HOLD
            self.wake[k] = step + self._steps(self.singles[k].hold_timeout_s or DEFAULT_HOLD_TIMEOUT_S)
            self.hold_index[k] = -1  # a hold engages once
        else:
            self._move(k, int(self.index[k]) + 1, crowd)

    def _release(self, k: int, crowd: CrowdArrays, reason: str) -> None:
        self.released_by[self.singles[k].id] = reason
        self.wake[k] = self.NEVER
        self._move(k, int(self.index[k]) + 1, crowd)

    def _held(self, crowd: CrowdArrays, step: int, robot: np.ndarray | None) -> None:
        """Hold peds in place (goal := position, velocity := 0); release proximity holds the robot reached."""
        hold = self.phase == self.HOLD
        if robot is not None and hold.any():
            near = hold & (((self.hold_ref - robot[:2]) ** 2).sum(axis=1) <= self.hold_r2)
            if near.any():
                for k in np.nonzero(near)[0]:
                    self._release(k, crowd, "robot_proximity")
                self._refresh()
        rows = self.rows[(self.phase == self.HOLD) | (self.phase == self.STAY)]
        crowd.goal[rows] = crowd.pos[rows]
        crowd.vel[rows] = 0.0

    def _track(self, crowd: CrowdArrays, robot: np.ndarray | None) -> None:
        """Goals of TRACK peds: the robot pose plus their offset, or the ped they join."""
        track = self.phase == self.TRACK
        rel = track & self.robot_rel
        if rel.any() and robot is not None:
            c, s = math.cos(robot[2]), math.sin(robot[2])
            fwd, lat = self.offset[rel, 0], self.offset[rel, 1]
            crowd.goal[self.rows[rel]] = robot[:2] + np.stack([fwd * c - lat * s, fwd * s + lat * c], axis=1)
        for k in np.nonzero(track & ~self.robot_rel)[0]:
            row, other = self.rows[k], self.follow_ped[k]
            if other == -2:  # no target named: the nearest other pedestrian
                d2 = ((crowd.pos - crowd.pos[row]) ** 2).sum(axis=1)
                d2[row] = np.inf
                other = int(np.argmin(d2)) if len(d2) > 1 else row
            crowd.goal[row] = crowd.pos[other]


def tracks_robot(sp: SinglePedestrian) -> bool:
    """Whether a ped's goal follows the robot: follow/accompany always, lead only without a goal or trajectory."""
    return sp.role in ("follow", "accompany") or (sp.role == "lead" and sp.goal is None and not sp.trajectory)


def hold_waypoint(sp: SinglePedestrian) -> int:
    """Trajectory index where a proximity hold engages (the one before ``hold_ref_point``), -1 for none."""
    if sp.hold_until_robot_within_m is None or sp.hold_ref_point is None:
        return -1
    for k, q in enumerate(sp.trajectory):
        if math.dist(q, sp.hold_ref_point) <= 1e-6:
            return max(0, k - 1)
    return -1
