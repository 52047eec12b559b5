"""What the predictive planner assumes about the crowd beyond its forecast, one named object per assumption.

Each reads the observations of one episode (some keep what they saw across decisions) and says which forecast
pedestrians it applies to, or how much room they make; ``planner.PredictivePlanner._scene`` applies them to the
forecast. ``CrowdAssumptions`` holds one of each for an episode.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

import numpy as np

from foresight.core.planners.predictive.config import CrowdConfig, SafetyConfig, StallConfig
from foresight.core.sim.observation import Observation
from foresight.core.sim.robot import RobotLimits

#: a pedestrian whose velocity changed by REACTION_DV [m/s] away from the robot within REACTION_WINDOW_S [s], within
#: REACTION_RANGE [m] of contact, is seen to give way to the robot (``GivesWay``)
REACTION_DV = 0.1
REACTION_WINDOW_S = 2.0
REACTION_RANGE = 3.0
#: stall assertiveness from which the robot, having yielded, commits to edging past pedestrians who wait for it:
#: lower commits sooner but left the robot behind slow groups (see the planner history in the docs)
COMMIT_ASSERTIVENESS = 0.8
#: the spread [m] it then allows a waiting pedestrian's position: it trusts it to stand (and tests that, below)
COMMIT_SIGMA = 0.1
#: a standing pedestrian is under test from this far beyond ``beside_distance`` [m]; it holds its ground if
#: the robot closed in by at least ``YIELD_PROBE_CLOSING`` [m] during the test while it moved less than that
YIELD_PROBE_SLACK = 0.3
YIELD_PROBE_CLOSING = 0.1
LINGER_DISTANCE = 0.5  #: [m] a pedestrian by the robot that moved less over ``lingering_s`` lingers there


@dataclass
class Stall:
    """0..1 assertiveness: ramps up while route progress over the last ``after_s`` is below ``progress``.

    A robot that waits for pedestrians who wait for it (doorways, corridors, oncoming streams)
    stalls forever; many pedestrians make room for a robot that edges forward, so after a stall
    the soft pedestrian margins shrink (``margin_relief``), while contact stays contact. It
    ramps down at the same rate once progress resumes (no reset: creeping must not switch it off at once).
    """

    config: StallConfig
    level: float = 0.0
    history: deque[tuple[float, float]] = field(default_factory=deque)  #: (time, route potential)

    def __call__(self, phi0: float, now: float, dt: float) -> float:
        s = self.config
        self.history.append((now, phi0))
        while len(self.history) > 1 and self.history[1][0] <= now - s.after_s:
            self.history.popleft()
        t_old, phi_old = self.history[0]
        stalled = now - t_old >= s.after_s - 1e-9 and phi_old - phi0 < s.progress
        step = dt / s.ramp_s
        self.level = min(max(self.level + (step if stalled else -step), 0.0), 1.0)  # = np.clip on a float
        return self.level


@dataclass
class WaitsForRobot:
    """(N,) mask of the forecast pedestrians (``ids``) taken to wait for the robot: standing, not seen to hold ground.

    A pedestrian standing near a robot is often waiting for it and steps back as it edges forward
    (how doorway and corridor standoffs end); one who stands for another reason does not. So the
    robot tests it: a standing pedestrian that stays put for ``yielding.test_s`` while the robot closes
    in within ``beside_distance`` + ``YIELD_PROBE_SLACK`` of contact holds its ground, and is never
    taken to wait for the robot again this episode.
    """

    crowd: CrowdConfig
    holds: set[int] = field(default_factory=set)  #: pedestrians seen to hold their ground against the robot
    probes: dict[int, tuple[float, np.ndarray, float]] = field(
        default_factory=dict
    )  #: id -> (since [s], pos, gap)

    def __call__(self, obs: Observation, ids: np.ndarray, contact: float) -> np.ndarray:
        s = self.crowd
        if s.yielding.speed <= 0 or len(obs.ped_ids) == 0:
            return np.zeros(len(ids), dtype=bool)
        p = np.asarray(obs.robot_pose[:2], dtype=float)
        gap = np.hypot(*(obs.ped_positions - p).T) - contact
        standing = np.hypot(*np.asarray(obs.ped_velocities).T) < s.standing_speed
        probes = {}
        for i in np.flatnonzero(standing & (gap <= s.beside_distance + YIELD_PROBE_SLACK)).tolist():
            pid, pos, g = int(obs.ped_ids[i]), obs.ped_positions[i], float(gap[i])
            if pid in self.holds:
                continue
            t0, pos0, g0 = self.probes.get(pid, (obs.time, pos, g))
            if obs.time - t0 >= s.yielding.test_s - 1e-9:
                if g0 - g >= YIELD_PROBE_CLOSING and np.hypot(*(pos - pos0)) < YIELD_PROBE_CLOSING:
                    self.holds.add(
                        pid
                    )  # the robot came closer, the pedestrian did not move: it holds its ground
                    continue
                t0, pos0, g0 = obs.time, pos, g  # no verdict: test again from here
            probes[pid] = (t0, pos0, g0)
        self.probes = probes
        trusted = [pid for pid in obs.ped_ids[standing].tolist() if pid not in self.holds]
        return member(ids, trusted)


@dataclass
class Lingers:
    """(N,) mask of the forecast pedestrians (``ids``) lingering by the robot: within ``beside_distance`` of
    contact now and then, and moved less than ``LINGER_DISTANCE`` over the last ``lingering_s`` [s] (0 =
    never).

    They are forecast to stay: a model that learned from people who make room has them walk off."""

    crowd: CrowdConfig
    seen: deque[tuple[float, np.ndarray, np.ndarray]] = field(
        default_factory=deque
    )  #: (time, ids, positions)

    def __call__(self, obs: Observation, ids: np.ndarray, contact: float) -> np.ndarray:
        s = self.crowd
        if s.lingering_s <= 0:
            return np.zeros(len(ids), dtype=bool)
        p = np.asarray(obs.robot_pose[:2], dtype=float)
        self.seen.append((obs.time, obs.ped_ids, obs.ped_positions))
        while len(self.seen) > 1 and self.seen[1][0] <= obs.time - s.lingering_s + 1e-9:
            self.seen.popleft()
        t_old, ids_old, pos_old = self.seen[0]
        if obs.time - t_old < s.lingering_s - 1e-9 or len(obs.ped_ids) == 0 or len(ids_old) == 0:
            return np.zeros(len(ids), dtype=bool)
        same = obs.ped_ids[:, None] == ids_old[None, :]  # (now, then)
        now, then = obs.ped_positions, pos_old[np.argmax(same, axis=1)]
        near_now = np.hypot(*(now - p).T) - contact <= s.beside_distance
        near_then = np.hypot(*(then - p).T) - contact <= s.beside_distance
        linger = same.any(axis=1) & near_now & near_then & (np.hypot(*(now - then).T) < LINGER_DISTANCE)
        return member(ids, obs.ped_ids[linger].tolist()) if linger.any() else np.zeros(len(ids), dtype=bool)


@dataclass
class GivesWay:
    """Pedestrians seen to give way: within ``REACTION_RANGE`` of contact, their velocity changed by at least
    ``REACTION_DV`` [m/s] away from the robot over the last ``REACTION_WINDOW_S`` (slowed down on their way to it,
    or turned off). Someone who sees the robot and makes way for it is taken to go on doing so."""

    reacted: set[int] = field(default_factory=set)
    past: deque[tuple[float, np.ndarray, np.ndarray]] = field(
        default_factory=deque
    )  #: (time, ids, velocities)

    def note(self, obs: Observation, p0: np.ndarray) -> None:
        self.past.append((obs.time, obs.ped_ids, obs.ped_velocities))
        while self.past[0][0] < obs.time - REACTION_WINDOW_S - 1e-9:
            self.past.popleft()
        t_old, ids_old, vel_old = self.past[0]
        if obs.time - t_old < REACTION_WINDOW_S - 1e-9 or len(obs.ped_ids) == 0 or len(ids_old) == 0:
            return
        same = obs.ped_ids[:, None] == ids_old[None, :]  # (now, then)
        seen = np.any(same, axis=1)
        dv = obs.ped_velocities - vel_old[np.argmax(same, axis=1)]
        away = obs.ped_positions - p0
        gave_way = along(dv, away) >= REACTION_DV
        near = np.sqrt(np.sum(away * away, axis=1)) - obs.robot_radius - obs.ped_radius <= REACTION_RANGE
        self.reacted.update(obs.ped_ids[seen & near & gave_way].tolist())


@dataclass
class WalksStraight:
    """(N,) mask of the forecast pedestrians (``ids``) walking towards a slow robot, and their straight lines
    (A, K, 2): where each would be at ``times`` at its current velocity; None for none.

    A forecast of someone walking at the robot may bend away (a turn at a waypoint, a step aside for the
    robot); one who does not see the robot walks straight on into it. While the robot is slow (below
    ``straight.max_robot_speed`` x v_max: standing, creeping, waiting at a door) pedestrians closing in on it
    at ``straight.speed`` [m/s] or more are held to both (the nearer of forecast and straight line counts),
    except those seen to give way to the robot (``GivesWay``). Off by default: for crowds known not to yield.
    """

    crowd: CrowdConfig
    limits: RobotLimits
    gives_way: GivesWay = field(default_factory=GivesWay)

    def __call__(
        self, obs: Observation, ids: np.ndarray, times: np.ndarray, p0: np.ndarray, v: float
    ) -> tuple[np.ndarray, np.ndarray] | None:
        s = self.crowd.straight
        if s.speed <= 0 or len(ids) == 0:
            return None
        self.gives_way.note(obs, p0)
        if v >= s.max_robot_speed * self.limits.v_max:
            return None
        row = np.argmax(ids[:, None] == obs.ped_ids[None, :], axis=1)  # forecast order -> observation order
        pos, vel = obs.ped_positions[row], obs.ped_velocities[row]
        mask = along(vel, p0 - pos) >= s.speed  # closing in
        if self.gives_way.reacted:
            mask &= ~member(ids, self.gives_way.reacted)
        if not mask.any():
            return None
        return mask, pos[mask, None, :] + times[None, :, None] * vel[mask, None, :]


@dataclass(frozen=True)
class WaitingRoom:
    """(N,) room [m] each pedestrian is expected to make: ``waiting_room`` x assertiveness for one forecast
    to stand (mean speed over the forecast below ``standing_speed``: waiting for the robot), else 0."""

    crowd: CrowdConfig

    def __call__(self, fut: np.ndarray, times: np.ndarray, assertive: float) -> np.ndarray:
        s = self.crowd
        if assertive <= 0 or len(fut) == 0:
            return np.zeros(len(fut))
        span = float(times[-1] - times[0]) if len(times) > 1 else 1.0
        speed = np.hypot(*(fut[:, -1] - fut[:, 0]).T) / span
        return np.where(speed < s.standing_speed, assertive * s.waiting_room, 0.0)


@dataclass(frozen=True)
class RecedingRoom:
    """(N,) room [m] of pedestrians walking away from the robot's position (forecast start): ``receding.room``
    x min(1, speed away / ``receding.speed``), 0 for those standing or coming closer, all of it faded out
    as the robot's speed ``v`` rises from half of ``receding.max_robot_speed`` x v_max to all of it."""

    crowd: CrowdConfig
    limits: RobotLimits

    def __call__(self, fut: np.ndarray, times: np.ndarray, p0: np.ndarray, v: float) -> np.ndarray:
        s = self.crowd.receding
        top = s.max_robot_speed * self.limits.v_max
        slow = min(max(2.0 * (1.0 - v / top), 0.0), 1.0)
        if s.room <= 0 or slow <= 0 or len(fut) == 0 or len(times) < 2:
            return np.zeros(len(fut))
        speed_away = along((fut[:, 1] - fut[:, 0]) / float(times[1] - times[0]), fut[:, 0] - p0)
        return slow * s.room * np.clip(speed_away / s.speed, 0.0, 1.0)


@dataclass
class CrowdAssumptions:
    """One of each assumption for an episode (those that remember start it with nothing seen)."""

    stall: Stall
    waits: WaitsForRobot
    lingers: Lingers
    walks_straight: WalksStraight
    waiting_room: WaitingRoom
    receding_room: RecedingRoom

    @classmethod
    def fresh(cls, safety: SafetyConfig, limits: RobotLimits) -> CrowdAssumptions:
        return cls(
            stall=Stall(safety.stall),
            waits=WaitsForRobot(safety.crowd),
            lingers=Lingers(safety.crowd),
            walks_straight=WalksStraight(safety.crowd, limits),
            waiting_room=WaitingRoom(safety.crowd),
            receding_room=RecedingRoom(safety.crowd, limits),
        )


def member(ids: np.ndarray, pool) -> np.ndarray:
    """(N,) mask: which ``ids`` are in ``pool`` (an iterable of ints). np.isin by one comparison table: its sorting
    machinery cost ~50 us per decision at these sizes."""
    return np.any(ids[:, None] == np.array(list(pool), dtype=np.int64), axis=1)


def along(vectors: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """(N,) component of each vector (N, 2) along its direction (N, 2) [same unit], e.g. a walking speed towards
    the robot."""
    norm = np.sqrt(np.sum(directions * directions, axis=1))
    return np.sum(vectors * directions, axis=1) / np.maximum(norm, 1e-6)
