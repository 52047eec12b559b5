"""Cost of rolled-out robot trajectories (lower is better), vectorised over candidates x peds x steps.

Pedestrian terms compare robot and forecast positions at the SAME instants (the forecast's time
grid) with the TRUE contact distance r_robot + r_ped (+ optional extra margins): the reference
compared 0.2 s robot steps with 0.1 s forecast steps and used 0.25 m radii for a 1.0 m robot.
Static terms use the distance to obstacle edges and map bounds at every simulator step of the
rollout (the reference had no static term at all; walls were its biggest failure class).
Progress is measured along the route (waypoints), not straight to the goal, so the robot follows
the route around obstacles between it and the goal, and the way to each waypoint is measured around
the walls (``geodesic``), so a robot pushed off its route behind a wall is not stuck there.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from foresight.core.planners.predictive.clearance import near_pairs, pair_clearance, reactive_clearance
from foresight.core.planners.predictive.config import PredictivePlannerConfig, WeightsConfig
from foresight.core.sim.geometry import SegmentSet, grid_distance, grid_interpolate
from foresight.core.sim.observation import StaticGeometry
from foresight.core.sim.robot import wrap_angle

TERMS = (
    "progress",
    "collision",
    "risk",
    "near_miss",
    "ttc",
    "progress_risk",
    "hard_clearance",
    "static",
    "static_collision",
    "velocity",
    "turn",
    "smoothness",
    "heading",
    "lane",
)


class RoutePotential:
    """Remaining route length [m] from a point: distance to the active waypoint plus the route after it.

    The active waypoint advances along a rollout as the simulator does (within ``switch_radius``),
    so passing a waypoint is never penalised; the final goal counts as reached inside ``goal_tolerance``.
    """

    def __init__(
        self,
        route: np.ndarray,
        switch_radius: float,
        goal_tolerance: float,
        lookahead: int = 3,
        distance: Callable[[np.ndarray], Callable[[np.ndarray], np.ndarray]] | None = None,
    ):
        """``distance(waypoint)``: a function measuring the way to that waypoint from points (..., 2), e.g.
        around the walls (``geodesic``); default the straight line. Waypoint switches and the goal test
        are the simulator's, by straight-line distance, either way."""
        full = np.asarray(route, dtype=float).reshape(-1, 2)
        seg = np.linalg.norm(np.diff(full, axis=0), axis=1)
        after = np.concatenate([np.cumsum(seg[::-1])[::-1], [0.0]])  # (K,) route length after waypoint j
        self.waypoints = full[:lookahead]  #: (J, 2) the active waypoint and the next ones
        self.after = after[:lookahead]  #: (J,)
        self.goal = full[-1]
        self.switch_radius = switch_radius
        self.goal_tolerance = goal_tolerance
        self._goal_is_last = (
            len(full) <= lookahead
        )  #: the last waypoint looked at is the goal (its distances reused)
        self._ways = [None if distance is None else distance(w) for w in self.waypoints]

    def __call__(self, pts: np.ndarray, credit: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Potential (B,) [m] at the end of rollouts ``pts`` (B, T, 2), the active waypoint (B, 2) there and the
        step of arrival (B,): the first step inside the goal tolerance, T where none is.

        Waypoint j becomes active from the first step inside ``switch_radius`` of waypoint j - 1 (once
        j - 1 was active); the potential is zero if any step came inside the goal tolerance (the
        episode ends there, whichever waypoint is active, as in the simulator), less ``credit`` [m] for
        every step of the rollout left after the first such step: an earlier arrival is worth more.
        """
        d = _distance(pts, self.waypoints[0])  # (B, T) to the active waypoint
        phi = self._way(0, pts[:, -1], d[:, -1]) + self.after[0]
        idx = np.zeros(len(pts), dtype=np.int64)
        reached = np.ones(d.shape, dtype=bool)  # (B, T) waypoint j - 1 active at that step
        for j in range(1, len(self.waypoints)):
            reached = np.logical_or.accumulate(reached & (d <= self.switch_radius), axis=1)
            d = _distance(pts, self.waypoints[j])
            end = reached[:, -1]
            if self._ways[j] is None or np.any(end):  # a way is measured only where it is needed
                phi = np.where(end, self._way(j, pts[:, -1], d[:, -1]) + self.after[j], phi)
            idx += end
        goal_d = d if self._goal_is_last else _distance(pts, self.goal)  # d: to the last waypoint looked at
        inside = goal_d <= self.goal_tolerance
        done = np.any(inside, axis=1)
        first = np.argmax(inside, axis=1)
        at_goal = -credit * (inside.shape[1] - 1 - first) if credit else 0.0
        return np.where(done, at_goal, phi), self.waypoints[idx], np.where(done, first, inside.shape[1])

    def start(self, p0: np.ndarray) -> float:
        """Potential at the current position (the active waypoint is the observation's)."""
        x, y = float(p0[0]), float(p0[1])
        if math.hypot(x - self.goal[0], y - self.goal[1]) <= self.goal_tolerance:
            return 0.0
        if self._ways[0] is not None:
            return float(self._ways[0](np.array([x, y]))) + float(self.after[0])
        return math.hypot(x - self.waypoints[0, 0], y - self.waypoints[0, 1]) + float(self.after[0])

    def _way(self, j: int, end: np.ndarray, straight: np.ndarray) -> np.ndarray:
        """Way [m] from rollout end points (B, 2) to waypoint j: its distance function's, else ``straight``."""
        return straight if self._ways[j] is None else self._ways[j](end)


def _distance(pts: np.ndarray, point: np.ndarray) -> np.ndarray:
    """Euclidean distance (...) from points (..., 2) to one point (2,)."""
    return np.sqrt((pts[..., 0] - point[0]) ** 2 + (pts[..., 1] - point[1]) ** 2)


class StaticClearance:
    """Distance [m] to the nearest obstacle edge or map bound; points outside the map get -1.

    ``resolution`` > 0 tabulates ``static.distance`` once per map on a grid and interpolates
    bilinearly, subtracting the interpolation error bound (resolution / sqrt 2, the distance is
    1-Lipschitz) so the estimate never exceeds the true distance; 0 queries ``static.distance``
    directly on every rolled-out point.
    """

    def __init__(self, static: StaticGeometry, resolution: float):
        self.static = static
        self.width, self.height = float(static.width), float(static.height)
        self.resolution = resolution
        if resolution > 0:
            self.field = distance_field(static, resolution)
            self.bound = resolution / np.sqrt(2.0)

    def __call__(self, pts: np.ndarray) -> np.ndarray:
        x, y = pts[..., 0], pts[..., 1]
        if self.resolution <= 0:
            d = np.asarray(self.static.distance(pts), dtype=float)
        else:
            d = grid_interpolate(self.field, self.resolution, x, y) - self.bound
        # rollouts rarely leave the map: four reductions decide that no point is outside (then d is the answer)
        if (
            np.min(x, axis=None) >= 0
            and np.max(x, axis=None) <= self.width
            and np.min(y, axis=None) >= 0
            and np.max(y, axis=None) <= self.height
        ):
            return d
        outside = (x < 0) | (x > self.width) | (y < 0) | (y > self.height)
        return np.where(outside, -1.0, d)


_FIELDS: OrderedDict[tuple, np.ndarray] = OrderedDict()  # per-process cache: maps repeat across episodes


def distance_field(static: StaticGeometry, resolution: float) -> np.ndarray:
    """static.distance on the grid i*resolution, j*resolution over the map, (nx, ny), cached by geometry content."""
    segs = np.ascontiguousarray(static.segments, dtype=float)
    key = (segs.tobytes(), float(static.width), float(static.height), resolution)
    if key in _FIELDS:
        _FIELDS.move_to_end(key)
        return _FIELDS[key]
    nx = int(np.ceil(static.width / resolution)) + 1
    ny = int(np.ceil(static.height / resolution)) + 1
    field = grid_distance(SegmentSet(segs), np.arange(nx) * resolution, np.arange(ny) * resolution)
    _FIELDS[key] = field
    while len(_FIELDS) > 16:
        _FIELDS.popitem(last=False)
    return field


@dataclass(frozen=True)
class Scene:
    """Everything one decision's costs need besides the rollouts."""

    ped_future: np.ndarray  #: (N, K, 2) forecast positions at ``times`` [m] (relevant peds only)
    ped_sigma: np.ndarray  #: (N, K) per-axis std of those positions [m]
    #: (N,) room [m] added to each pedestrian's clearance: expected of one waiting for the robot
    #: (``crowd.waiting_room``) or allowed one walking away from a slow robot (``crowd.receding``)
    ped_room: np.ndarray
    ped_yield: np.ndarray  #: (N,) speed [m/s] at which each pedestrian is assumed to step away from the robot
    ped_straight: (
        np.ndarray
    )  #: (A,) pedestrians (indices) also held to a straight line: the nearer one counts
    ped_lines: np.ndarray  #: (A, K, 2) their straight lines at ``times`` (current position and velocity) [m]
    times: np.ndarray  #: (K,) seconds ahead [s]
    contact: float  #: centre distance of contact: robot radius + ped radius + extra margins [m]
    robot_radius: float  #: true robot radius [m] (static clearance)
    route: RoutePotential
    phi0: float  #: route potential at the robot's position now [m]
    assertiveness: float  #: 0..1 after a stall (shrinks the soft pedestrian margins)
    static: StaticClearance
    start: np.ndarray  #: (3,) x, y, heading now
    prev_command: np.ndarray  #: (2,) last command (v, omega)
    max_speed: float
    max_turn_rate: float
    traffic: Callable[[np.ndarray], np.ndarray] | None = (
        None  #: walkers lately passing at points (``traffic``)
    )
    #: (N,) probability of each row when rows are modes of a multi-modal forecast; None: one mode each (weight 1)
    ped_weight: np.ndarray | None = None

    @cached_property
    def time_steps(self) -> np.ndarray:
        """(K,) seconds between successive forecast times (the first from now)."""
        return np.diff(np.concatenate([[0.0], self.times]))


@dataclass(frozen=True)
class Rollouts:
    """Rolled-out robot states for B candidate sequences."""

    states: np.ndarray  #: (B, S, 5) x, y, heading, v, omega after each simulator step
    eval_index: np.ndarray  #: (K,) simulator step index of each forecast time
    commands: np.ndarray  #: (B, S, 2) commanded (v, omega) per simulator step


def pedestrian_terms(
    pos: np.ndarray,
    speed: np.ndarray,
    scene: Scene,
    cfg: PredictivePlannerConfig,
    gone: np.ndarray | None = None,
) -> dict[str, np.ndarray]:
    """Collision, risk, near-miss, TTC and hard-clearance terms (B,) and the minimum clearance (B,) [m].

    ``pos`` (B, K, 2) and ``speed`` (B, K) are the robot's at the forecast times; each forecast
    position is the mean of an isotropic Gaussian of std ``scene.ped_sigma`` (N, K). The collision
    margin is a chance constraint: ``confidence`` standard deviations (the pedestrian stays beyond
    it along the line of centres with probability Phi(confidence)) plus a base and a speed margin;
    ``risk`` is the expected number of contact steps, the sum of P(contact) = Phi(-clearance / sigma).
    A robot standing still is held to the same terms as a moving one: a pedestrian who does not see
    the robot walks into it all the same. Rows may be modes of one pedestrian (``scene.ped_weight``): the collision,
    near-miss and TTC excesses and the contact probability are then weighted by each mode's probability (their
    expectation over the mixture); the hard clearance holds against every mode kept. After a stall the soft margins shrink by
    ``stall.margin_relief`` x assertiveness, and a pedestrian forecast to stand (waiting for the
    robot) is expected to make room; the contact with a walking pedestrian never shrinks. ``gone`` (B, K): steps
    after the rollout's arrival at the goal, which meet nobody.
    """
    B = pos.shape[0]
    s, beside = cfg.safety.pedestrians, cfg.safety.crowd.beside_distance
    fut, sigma = scene.ped_future, scene.ped_sigma
    if fut.shape[0] == 0:
        z = np.zeros(B)
        return {
            "collision": z,
            "risk": z,
            "near_miss": z,
            "ttc": z,
            "hard_clearance": z,
            "min_clearance": np.full(B, np.inf),
        }
    relief = 1.0 - cfg.safety.stall.margin_relief * scene.assertiveness
    K = fut.shape[1]
    band = relief * max(s.near_distance, s.ttc_distance)
    soft = relief * (s.collision_margin + s.speed_clearance_gain * speed)  # (B, K)
    chance = s.confidence * sigma  # (N, K)
    # beyond every margin + band and RISK_CUTOFF sigmas a (pedestrian, step, rollout) adds exact zeros to every
    # term below, so only the entries inside are gathered (a few % of them in a crowd) and summed per rollout
    reach = np.maximum(chance + band + np.max(soft, axis=None), RISK_CUTOFF * sigma)  # (N, K)
    room = scene.ped_room
    has_room = np.any(room != 0, axis=None)
    # only the (pedestrian, step) pairs some rollout may bring within range of a term (``clearance``): beyond the
    # cut-off a pair adds exact zeros to the sums and cannot be the nearest that the hard clearance and
    # progress_risk read (both zero beyond their distances). Pedestrians stepping away from the robot or also held
    # to straight lines keep every step (their clearance is not the plain one the bound is for).
    cut = np.maximum(reach, max(relief * s.hard_clearance_distance, s.progress_risk_distance))
    if has_room:
        cut = cut - room[:, None]
    whole = scene.ped_yield > 0
    whole[scene.ped_straight] = True
    rows = np.flatnonzero(whole)
    if len(rows):
        cut[rows] = np.inf
    pairs = near_pairs(pos, fut, scene.contact, cut)
    clear = pair_clearance(pos, fut, pairs, scene.contact)  # (P, B)
    if len(rows):  # their pairs are whole blocks of K steps, in order
        sub = reactive_clearance(
            pos, fut[rows], scene.contact, scene.time_steps, scene.ped_yield[rows], beside
        )
        a = scene.ped_straight
        if len(a):
            j = np.searchsorted(rows, a)
            lines = reactive_clearance(
                pos, scene.ped_lines, scene.contact, scene.time_steps, scene.ped_yield[a], beside
            )
            sub[j] = np.minimum(sub[j], lines)
        at = np.searchsorted(pairs, rows * K)
        clear[(at[:, None] + np.arange(K)).reshape(-1)] = sub.reshape(-1, B)
    if has_room:
        clear += room.take(pairs // K)[:, None].astype(np.float32)
    if gone is not None:
        clear[gone.T.take(pairs % K, axis=0)] = np.inf
    # the nearest over pedestrians and steps: max over steps of (d - min over pedestrians) is d - the min over both
    nearest = np.min(clear, axis=0) if len(pairs) else np.full(B, np.inf, dtype=np.float32)
    hard = np.maximum(relief * s.hard_clearance_distance - nearest, 0.0)
    inside = np.flatnonzero(
        clear < reach.reshape(-1).take(pairs).astype(np.float32)[:, None]
    )  # np.nonzero's (p, b), ~7x faster at these sizes
    p, b = np.divmod(inside, B)
    c = clear.reshape(-1).take(inside).astype(float)
    # what depends on the (pedestrian, step) pair alone is gathered per pair first (P), then per entry
    k_pair = pairs % K
    sig = sigma.reshape(-1).take(pairs).take(p)
    k = k_pair.take(p)
    excess = soft.reshape(-1).take(b * K + k) + s.confidence * sig - c  # > 0 inside the collision margin
    disc_pair = (s.discount ** np.arange(len(scene.times))).take(k_pair)
    ttc = np.maximum(excess + relief * s.ttc_distance, 0.0) / scene.times.take(k_pair).take(p)
    if scene.ped_weight is not None:  # rows are modes: each term below is its expectation over the mixture
        w_pair = scene.ped_weight.take(pairs // K)
        disc, ttc = (disc_pair * w_pair).take(p), ttc * w_pair.take(p)
    else:
        disc = disc_pair.take(p)

    def per_rollout(values: np.ndarray) -> np.ndarray:
        # each rollout's entries in (pedestrian, step) order, whatever the layout: the same sums
        return np.bincount(b, values, minlength=B)

    return {
        "collision": per_rollout(np.maximum(excess, 0.0) * disc),
        "risk": per_rollout(contact_probability(c / sig) * disc),
        "near_miss": per_rollout(np.maximum(excess + relief * s.near_distance, 0.0) * disc),
        "ttc": per_rollout(ttc),
        "hard_clearance": hard,
        "min_clearance": nearest,
    }


RISK_CUTOFF = 3.0  #: clearances beyond this many sigmas count as no risk (P < 0.0013, rounded to 0)


def contact_probability(z: np.ndarray) -> np.ndarray:
    """P(contact) = Phi(-z) for a clearance of z standard deviations, 0 from ``RISK_CUTOFF`` on.

    Phi by its logistic approximation 1 / (1 + exp(1.702 z)) (error < 0.01): no SciPy in the hot path.
    """
    return np.where(z < RISK_CUTOFF, 1.0 / (1.0 + np.exp(1.702 * np.minimum(z, RISK_CUTOFF))), 0.0)


def influence_range(
    cfg: PredictivePlannerConfig, horizon_s: float, max_speed: float, max_sigma: float
) -> float:
    """Clearance [m] beyond which a pedestrian adds exactly zero to every pedestrian term."""
    s = cfg.safety.pedestrians
    margin = s.collision_margin + s.confidence * max_sigma + s.speed_clearance_gain * max_speed
    bands = margin + max(s.near_distance, s.ttc_distance, s.hard_clearance_distance, s.progress_risk_distance)
    return max(bands, RISK_CUTOFF * max_sigma)


def evaluate(
    roll: Rollouts, scene: Scene, cfg: PredictivePlannerConfig
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Total cost (B,) and every term (B,) for the rollouts; ``progress`` is in metres (counted negatively).

    Everything is read at the forecast times; static clearance too (the robot moves at most
    v_max * dt_forecast = 0.4 m between them, covered by ``static.margin`` plus the field's bound).
    """
    s, wt = cfg.safety, cfg.weights
    ev = roll.states.take(roll.eval_index, axis=1)  # (B, K, 5); take: a fancy index on axis 1 is ~4x slower
    pos = ev[..., :2]
    speed = np.abs(ev[..., 3])
    early = (
        scene.max_speed * float(scene.times[1] - scene.times[0])
        if cfg.search.arrival_credit and len(scene.times) > 1
        else 0.0
    )
    phi_end, target, arrival = scene.route(pos, early)
    K = len(roll.eval_index)
    # the episode ends on arrival: what a rollout would meet after it never happens (None while no rollout arrives)
    gone = (np.arange(K) > arrival[:, None]) if cfg.search.ends_at_goal and np.min(arrival) < K else None
    terms = pedestrian_terms(pos, speed, scene, cfg, gone)
    progress = scene.phi0 - phi_end
    min_c = terms.pop("min_clearance")
    terms["progress"] = progress
    terms["progress_risk"] = np.maximum(0.0, progress) * np.maximum(
        0.0, s.pedestrians.progress_risk_distance - min_c
    )
    sc = scene.static(pos) - scene.robot_radius  # (B, K)
    if gone is not None:
        sc[gone] = np.inf
    # means below: np.add.reduce / K is what ndarray.mean computes, without its wrapper
    terms["static_collision"] = np.sum(sc < s.static.margin, axis=1, dtype=float)
    terms["static"] = np.mean(np.maximum(0.0, s.static.margin + s.static.soft_distance - sc), axis=1)
    cmd = roll.commands.take(roll.eval_index, axis=1)  # (B, K, 2)
    terms["velocity"] = np.mean(np.abs(cmd[..., 0]), axis=1) / scene.max_speed
    terms["turn"] = np.mean(np.abs(cmd[..., 1]), axis=1) / scene.max_turn_rate
    terms["smoothness"] = (
        np.abs(roll.commands[:, 0, 0] - scene.prev_command[0]) / scene.max_speed
        + np.abs(roll.commands[:, 0, 1] - scene.prev_command[1]) / scene.max_turn_rate
    )
    # mean (not terminal) heading error: a terminal error lets every decision postpone turning in place
    bearing = np.arctan2(target[:, None, 1] - pos[..., 1], target[:, None, 0] - pos[..., 0])  # (B, K)
    terms["heading"] = np.mean(np.abs(wrap_angle(bearing - ev[..., 2])), axis=1) / np.pi
    # waiting in a lane: the walkers lately through the rollout's end point, in full for a robot ending at rest
    terms["lane"] = (
        scene.traffic(pos[:, -1]) * np.maximum(0.0, 1.0 - speed[:, -1] / scene.max_speed)
        if scene.traffic is not None
        else np.zeros(len(pos))
    )
    if gone is not None:
        terms["lane"] = np.where(arrival < K, 0.0, terms["lane"])  # nobody waits in a lane after arriving
    parts = weighted(terms, wt)
    total = parts["progress"]
    for name in TERMS[1:]:
        total += parts[name]
    return total, terms


def weighted(terms: dict[str, np.ndarray], wt: WeightsConfig) -> dict[str, np.ndarray]:
    """Each term's share of the total cost: its weight times it (progress counted negatively, at the goal weight)."""
    w = wt.by_term()
    return {name: (-w[name] if name == "progress" else w[name]) * terms[name] for name in TERMS}
