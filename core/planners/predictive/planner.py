"""The predictive planner: forecast -> (v, omega) candidates -> beam search over rollouts -> best command.

One decision: one batched forecaster call; first-segment candidates (dense in the near field)
rolled out with the simulator's own kinematics (``core.sim.robot.unicycle_rollout``) and held to the
horizon, plus point turns (turn in place, then straight: how a robot in a corner faces a door) and swerves
(turn at speed for a while, then straight: how a robot behind slower walkers pulls out to pass them); the
best ``beam_width`` sequences are extended with a coarser command set; the first command of the
cheapest sequence seen is returned. Braking (0, 0) is always a candidate, so the robot can wait, but waiting is no refuge: a pedestrian forecast to walk into a standing robot costs
as much as one the robot drives into, so the search turns away, speeds up or gives way early
instead, and waiting where walkers have lately passed costs too (``traffic``: the next one through a doorway is
often not in view yet). Pedestrian terms read the forecast's spread (a chance margin and the contact probability,
see ``cost``); after a few seconds without route progress the soft margins shrink (stall
assertiveness), never the contact distance, and the robot commits: pedestrians standing near it
are taken to wait for it, to stay and to step back as it edges forward (a doorway standoff ends),
until one is seen to hold its ground; before that, people lingering by the robot are forecast to stay
(``_lingering``: a model that learned from people who make room has them walk off). An option
(``safety.straight_speed``, off by default) also holds walkers closing in on a slow robot to their straight line,
for crowds known not to yield. Deterministic: no randomness, stable sorts.
"""

from __future__ import annotations

import time
from collections import deque
from typing import Any

import numpy as np

from foresight.core.errors import ConfigError
from foresight.core.planners.predictive import cost as C
from foresight.core.planners.predictive import holonomic
from foresight.core.planners.predictive.config import PredictivePlannerConfig
from foresight.core.planners.predictive.forecast_input import planner_forecast
from foresight.core.planners.predictive.geodesic import GeodesicDistance
from foresight.core.planners.predictive.rollout import FrameRollouts, eval_steps, extend_forecast, rollout
from foresight.core.planners.predictive.sampling import (
    branch_commands,
    first_candidates,
    holonomic_branches,
    holonomic_candidates,
    reverse_speeds,
    turn_then_go,
    veer_then_straight,
)
from foresight.core.planners.predictive.traffic import TrafficMap
from foresight.core.predict.forecaster import Forecaster
from foresight.core.sim.observation import Observation
from foresight.core.sim.planner import EpisodeInfo
from foresight.core.sim.robot import RobotLimits, robot_step


class PredictivePlanner:
    """Planner protocol implementation; ``forecaster`` supplies the pedestrian forecasts (cv or learned)."""

    name = "predictive"

    def __init__(self, config: PredictivePlannerConfig | None, forecaster: Forecaster):
        self.config = config or PredictivePlannerConfig()
        self.forecaster = forecaster
        self._diag: dict[str, Any] | None = None
        self._prev = np.zeros(2)
        self._static: C.StaticClearance | None = None
        self._limits: RobotLimits | None = None
        self._frames: FrameRollouts | None = None  #: kept across episodes of the same robot and dt

    def reset(self, info: EpisodeInfo) -> None:
        fit = getattr(self.forecaster, "fit", None)
        if callable(fit):  # constant velocity fits its grid to the simulator's step
            fit(info.dt)
        self.forecaster.timebase.stride(info.dt)  # ConfigError unless the forecast grid is whole sim steps
        robot = info.scenario.scenario.robot_config
        self._holonomic = robot.kinematics == "holonomic"  #: commands are velocities (see ``holonomic``)
        self.forecaster.reset()
        self._phi_hist: deque[tuple[float, float]] = deque()
        self._assert = 0.0
        self._seen: deque[tuple[float, np.ndarray, np.ndarray]] = (
            deque()
        )  #: (time, ids, positions) (``_lingering``)
        self._holds: set[int] = set()  #: pedestrians seen to hold their ground against the robot
        self._probes: dict[
            int, tuple[float, np.ndarray, float]
        ] = {}  #: id -> (since [s], position, gap) under test
        self._reacted: set[int] = (
            set()
        )  #: pedestrians seen to give way to the robot (no straight line for them)
        self._past: deque[tuple[float, np.ndarray, np.ndarray]] = (
            deque()
        )  #: (time, ids, velocities) over REACTION_WINDOW_S
        self._limits = RobotLimits.from_config(robot)
        if self._frames is None or self._frames.limits != self._limits or self._frames.dt != info.dt:
            self._frames = FrameRollouts(self._limits, info.dt)  # else its rollouts serve this episode too
        self._cands: dict[bool | None, np.ndarray] = {}
        self._firsts: dict[tuple, np.ndarray] = {}  #: (near field, steps) -> the first round's sequences
        self._step_cache: dict[tuple, tuple] = {}
        self._route_cache: tuple | None = None
        self._prev = np.zeros(2)
        self._plan: tuple[np.ndarray, np.ndarray] | None = (
            None  #: the last decision's commands (S, 2), states (S, 5)
        )
        self._traffic: TrafficMap | None = None
        self._decided: tuple[Observation, C.Scene] | None = None  #: the last decision's observation and scene
        self._diag = None

    @property
    def diagnostics(self) -> dict[str, Any] | None:
        return self._diag

    def plan(self, obs: Observation) -> tuple[float, float]:
        if self._limits is None:
            raise RuntimeError("PredictivePlanner.plan() called before reset(info)")
        t0 = time.perf_counter()
        self.forecaster.observe(obs)
        fc = self.forecaster.forecast()
        pf = planner_forecast(fc, obs, obs.dt)
        scene, near, extra = self._scene(obs, pf.positions, pf.sigma, pf.times, pf.ped_ids, pf.weights)
        best_cmds, best_terms, best_total, n_eval, kept = self._search(obs, scene, near)
        self._decided = (obs, scene)
        v, w = float(best_cmds[0, 0]), float(best_cmds[0, 1])
        if self._holonomic:  # the chosen velocity, from the robot's frame to the world's
            v, w = holonomic.to_world(best_cmds[0], float(obs.robot_pose[2]))
        self._prev = np.array([v, w])
        self._diag = {
            "command": (v, w),
            "sequence": _segments(best_cmds),
            "cost": float(best_total),
            "terms": {k: float(val) for k, val in best_terms.items()},
            "near_field": near,
            "assertiveness": scene.assertiveness,
            "candidates_evaluated": n_eval,
            "kept_plan": kept,  #: the command carries out the last decision's plan (``search.keep_plan``)
            "forecast_source": fc.source,
            "forecast_extended_steps": extra,
            **({"forecast_modes": fc.n_modes} if fc.n_modes > 1 else {}),
            "predictions": {
                "ped_ids": fc.ped_ids,
                "positions": fc.positions,
                "times": fc.times,
                "sigma": fc.sigma,
            },
            "plan_ms": (time.perf_counter() - t0) * 1e3,
        }
        return v, w

    def score_commands(
        self, obs: Observation, commands: np.ndarray
    ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """Cost (B,) and terms of constant commands (B, 2) held over the horizon (tests, diagnostics)."""
        self.forecaster.observe(obs)
        pf = planner_forecast(self.forecaster.forecast(), obs, obs.dt)
        scene, _, _ = self._scene(obs, pf.positions, pf.sigma, pf.times, pf.ped_ids, pf.weights)
        idx = eval_steps(scene.times, obs.dt)
        cmds = np.repeat(np.asarray(commands, dtype=float)[:, None, :], int(idx[-1]) + 1, axis=1)
        return self._cost(obs, scene, idx, cmds)

    def price(self, commands: np.ndarray) -> tuple[float, dict[str, float]]:
        """Cost and each term's weighted share (``cost.weighted``) of a command sequence (n, 2) from the last decision's
        state, judged against that decision's forecast: what this planner made of a course it did not choose (a
        witness's). Commands beyond the horizon are dropped; a shorter sequence is held at its last command."""
        if self._decided is None:
            raise RuntimeError("PredictivePlanner.price() called before plan(obs)")
        obs, scene = self._decided
        idx, S, _ = self._steps(scene.times, obs.dt)
        cmds = np.asarray(commands, dtype=float).reshape(-1, 2)[:S]
        cmds = np.concatenate([cmds, np.repeat(cmds[-1:], S - len(cmds), axis=0)])[None]
        total, terms = self._cost(obs, scene, idx, cmds)
        return float(total[0]), {k: float(v[0]) for k, v in C.weighted(terms, self.config.weights).items()}

    def _cost(
        self, obs: Observation, scene: C.Scene, idx: np.ndarray, cmds: np.ndarray
    ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """Cost (B,) and terms of command sequences (B, S, 2) rolled out from the robot's state in ``obs``."""
        state0 = np.concatenate([obs.robot_pose, obs.robot_velocity]).astype(float)
        states = rollout(np.repeat(state0[None], len(cmds), axis=0), cmds, self._limits, obs.dt)
        if self._holonomic:  # world-frame velocities: the cost reads them in the robot's frame
            cmds = holonomic.cost_commands(holonomic.to_local(cmds, float(obs.robot_pose[2])), self._limits)
        return C.evaluate(C.Rollouts(states, idx, cmds), scene, self.config)

    # -- decision pieces -------------------------------------------------------------------------
    def _scene(
        self,
        obs: Observation,
        positions: np.ndarray,
        sigma: np.ndarray,
        times: np.ndarray,
        fc_ids: np.ndarray,
        weights: np.ndarray | None = None,
    ) -> tuple[C.Scene, bool, int]:
        """The decision's scene; rows of ``positions`` are pedestrians, or modes of them with ``weights`` (R,)."""
        cfg, limits = self.config, self._limits
        p0 = obs.robot_pose[:2]
        route = self._route(obs)
        phi0 = route.start(p0)
        assertive = self._assertiveness(phi0, obs.time, obs.dt)
        ped_r = (
            obs.ped_radius
        )  # humans of different sizes: the largest present (the cost has one contact distance)
        if obs.ped_radii is not None and len(obs.ped_radii):
            ped_r = max(ped_r, float(obs.ped_radii.max()))
        contact = obs.robot_radius + ped_r + cfg.safety.extra_robot_margin + cfg.safety.extra_ped_margin
        times = np.asarray(times, dtype=float)
        fut = np.asarray(positions, dtype=float).reshape(-1, len(times), 2)
        sigma = np.asarray(sigma, dtype=float).reshape(-1, len(times))
        # ufunc reductions: ndarray.sum/min without their Python wrappers (the same reductions)
        dist = np.sqrt(np.add.reduce((fut - p0) ** 2, axis=-1))  # (N, K) to the robot's current position
        near = (
            bool(dist.size)
            and float(np.minimum.reduce(dist, axis=None)) - contact <= cfg.sampling.near_field_distance
        )
        dt_f = float(times[1] - times[0]) if len(times) > 1 else float(times[0])
        extra_s = cfg.search.extra_horizon_s + (
            cfg.search.horizon_boost_s if cfg.search.adaptive_horizon and near else 0.0
        )
        extra = int(round(extra_s / dt_f))
        speed = abs(float(obs.robot_velocity[0]))  # a robot that may back off drives backwards at negative v
        room = self._waiting_room(fut, times, assertive) + self._receding_room(fut, times, p0, speed)
        waiting = self._waiting(obs, fc_ids, contact)
        yielding = np.zeros(len(fut))
        lingering = self._lingering(obs, fc_ids, contact)
        if (
            lingering.any()
        ):  # lingered by the robot for a while: not making room for it, whatever the model expects
            row = np.argmax(fc_ids[lingering, None] == obs.ped_ids[None, :], axis=1)
            fut = fut.copy()
            fut[lingering] = (
                obs.ped_positions[row, None, :] + times[None, :, None] * obs.ped_velocities[row, None, :]
            )
        if assertive >= COMMIT_ASSERTIVENESS and waiting.any():  # yielded long enough: commit (see _waiting)
            fut, sigma = fut.copy(), sigma.copy()
            fut[waiting], sigma[waiting] = fut[waiting, :1], np.minimum(sigma[waiting, :1], COMMIT_SIGMA)
            yielding[waiting] = cfg.safety.yield_speed
        fut, sigma, times = extend_forecast(fut, sigma, times, extra)
        straight = self._straight_lines(obs, fc_ids, times, p0, speed)
        if len(fut):  # exact culling: pedestrians no rollout can bring within any term's range
            if extra:
                dist = np.sqrt(np.add.reduce((fut - p0) ** 2, axis=-1))
            if straight is not None:  # either way a pedestrian may walk counts
                mask, lines = straight
                dist[mask] = np.minimum(dist[mask], np.sqrt(np.add.reduce((lines - p0) ** 2, axis=-1)))
            gap = dist - contact - _reach(speed, limits, times)
            keep = gap.min(axis=1) <= C.influence_range(
                cfg, float(times[-1]), limits.v_max, float(sigma.max())
            )
            fut, sigma, room, yielding = fut[keep], sigma[keep], room[keep], yielding[keep]
            if weights is not None:
                weights = weights[keep]
            if straight is not None:
                straight = np.flatnonzero(mask[keep]), lines[keep[mask]]
        line_ids, lines = straight or (NO_LINES, np.zeros((0, len(times), 2)))
        scene = C.Scene(
            ped_future=fut,
            ped_sigma=sigma,
            ped_room=room,
            ped_yield=yielding,
            ped_straight=line_ids,
            ped_lines=lines,
            times=times,
            contact=contact,
            robot_radius=obs.robot_radius,
            route=route,
            phi0=phi0,
            assertiveness=assertive,
            static=self._static_field(obs),
            start=np.asarray(obs.robot_pose, dtype=float),
            prev_command=(
                holonomic.cost_commands(holonomic.to_local(self._prev, float(obs.robot_pose[2])), limits)
                if self._holonomic
                else self._prev
            ),
            max_speed=limits.v_max,
            max_turn_rate=limits.w_max,
            traffic=self._lanes(obs, contact),
            ped_weight=weights,
        )
        return scene, near, extra

    def _lanes(self, obs: Observation, contact: float) -> TrafficMap | None:
        """The episode's traffic map, brought up to date (None while ``weights.lane`` is 0)."""
        if self.config.weights.lane <= 0:
            return None
        if self._traffic is None:
            self._traffic = TrafficMap(
                obs.static.width, obs.static.height, contact, memory_s=self.config.safety.lane_memory_s
            )
        self._traffic.observe(obs.time, obs.ped_positions, obs.ped_velocities)
        return self._traffic

    def _waiting(self, obs: Observation, ids: np.ndarray, contact: float) -> np.ndarray:
        """(N,) mask of the forecast pedestrians (``ids``) taken to wait for the robot: standing, not seen to hold ground.

        A pedestrian standing near a robot is often waiting for it and steps back as it edges forward
        (how doorway and corridor standoffs end); one who stands for another reason does not. So the
        robot tests it: a standing pedestrian that stays put for ``yield_test_s`` while the robot closes
        in within ``yield_range`` + ``YIELD_PROBE_SLACK`` of contact holds its ground, and is never
        taken to wait for the robot again this episode.
        """
        s = self.config.safety
        if s.yield_speed <= 0 or len(obs.ped_ids) == 0:
            return np.zeros(len(ids), dtype=bool)
        p = np.asarray(obs.robot_pose[:2], dtype=float)
        gap = np.hypot(*(obs.ped_positions - p).T) - contact
        standing = np.hypot(*np.asarray(obs.ped_velocities).T) < s.waiting_speed
        probes = {}
        for i in np.flatnonzero(standing & (gap <= s.yield_range + YIELD_PROBE_SLACK)).tolist():
            pid, pos, g = int(obs.ped_ids[i]), obs.ped_positions[i], float(gap[i])
            if pid in self._holds:
                continue
            t0, pos0, g0 = self._probes.get(pid, (obs.time, pos, g))
            if obs.time - t0 >= s.yield_test_s - 1e-9:
                if g0 - g >= YIELD_PROBE_CLOSING and np.hypot(*(pos - pos0)) < YIELD_PROBE_CLOSING:
                    self._holds.add(
                        pid
                    )  # the robot came closer, the pedestrian did not move: it holds its ground
                    continue
                t0, pos0, g0 = obs.time, pos, g  # no verdict: test again from here
            probes[pid] = (t0, pos0, g0)
        self._probes = probes
        trusted = [pid for pid in obs.ped_ids[standing].tolist() if pid not in self._holds]
        return _member(ids, trusted)

    def _lingering(self, obs: Observation, ids: np.ndarray, contact: float) -> np.ndarray:
        """(N,) mask of the forecast pedestrians (``ids``) lingering by the robot: within ``yield_range`` of contact
        now and then, and moved less than ``LINGER_DISTANCE`` over the last ``standing_stays_s`` [s] (0 = never)."""
        s = self.config.safety
        if s.standing_stays_s <= 0:
            return np.zeros(len(ids), dtype=bool)
        p = np.asarray(obs.robot_pose[:2], dtype=float)
        self._seen.append((obs.time, obs.ped_ids, obs.ped_positions))
        while len(self._seen) > 1 and self._seen[1][0] <= obs.time - s.standing_stays_s + 1e-9:
            self._seen.popleft()
        t_old, ids_old, pos_old = self._seen[0]
        if obs.time - t_old < s.standing_stays_s - 1e-9 or len(obs.ped_ids) == 0 or len(ids_old) == 0:
            return np.zeros(len(ids), dtype=bool)
        same = obs.ped_ids[:, None] == ids_old[None, :]  # (now, then)
        now, then = obs.ped_positions, pos_old[np.argmax(same, axis=1)]
        near_now = np.hypot(*(now - p).T) - contact <= s.yield_range
        near_then = np.hypot(*(then - p).T) - contact <= s.yield_range
        linger = same.any(axis=1) & near_now & near_then & (np.hypot(*(now - then).T) < LINGER_DISTANCE)
        return _member(ids, obs.ped_ids[linger].tolist()) if linger.any() else np.zeros(len(ids), dtype=bool)

    def _waiting_room(self, fut: np.ndarray, times: np.ndarray, assertive: float) -> np.ndarray:
        """(N,) room [m] each pedestrian is expected to make: ``waiting_room`` x assertiveness for one forecast
        to stand (mean speed over the forecast below ``waiting_speed``: waiting for the robot), else 0."""
        s = self.config.safety
        if assertive <= 0 or len(fut) == 0:
            return np.zeros(len(fut))
        span = float(times[-1] - times[0]) if len(times) > 1 else 1.0
        speed = np.hypot(*(fut[:, -1] - fut[:, 0]).T) / span
        return np.where(speed < s.waiting_speed, assertive * s.waiting_room, 0.0)

    def _receding_room(self, fut: np.ndarray, times: np.ndarray, p0: np.ndarray, v: float) -> np.ndarray:
        """(N,) room [m] of pedestrians walking away from the robot's position (forecast start): ``receding_room``
        x min(1, speed away / ``receding_speed``), 0 for those standing or coming closer, all of it faded out
        as the robot's speed ``v`` rises from half of ``receding_max_speed`` x v_max to all of it."""
        s = self.config.safety
        top = s.receding_max_speed * self._limits.v_max
        slow = min(max(2.0 * (1.0 - v / top), 0.0), 1.0)
        if s.receding_room <= 0 or slow <= 0 or len(fut) == 0 or len(times) < 2:
            return np.zeros(len(fut))
        speed_away = _along((fut[:, 1] - fut[:, 0]) / float(times[1] - times[0]), fut[:, 0] - p0)
        return slow * s.receding_room * np.clip(speed_away / s.receding_speed, 0.0, 1.0)

    def _straight_lines(
        self, obs: Observation, ids: np.ndarray, times: np.ndarray, p0: np.ndarray, v: float
    ) -> tuple[np.ndarray, np.ndarray] | None:
        """(N,) mask of the forecast pedestrians (``ids``) walking towards a slow robot, and their straight lines
        (A, K, 2): where each would be at ``times`` at its current velocity; None for none.

        A forecast of someone walking at the robot may bend away (a turn at a waypoint, a step aside for the
        robot); one who does not see the robot walks straight on into it. While the robot is slow (below
        ``straight_max_speed`` x v_max: standing, creeping, waiting at a door) pedestrians closing in on it at
        ``straight_speed`` [m/s] or more are held to both (the nearer of forecast and straight line counts),
        except those seen to give way to the robot (``_note_reactions``).
        """
        s = self.config.safety
        if s.straight_speed <= 0 or len(ids) == 0:
            return None
        self._note_reactions(obs, p0)
        if v >= s.straight_max_speed * self._limits.v_max:
            return None
        row = np.argmax(ids[:, None] == obs.ped_ids[None, :], axis=1)  # forecast order -> observation order
        pos, vel = obs.ped_positions[row], obs.ped_velocities[row]
        mask = _along(vel, p0 - pos) >= s.straight_speed  # closing in
        if self._reacted:
            mask &= ~_member(ids, self._reacted)
        if not mask.any():
            return None
        return mask, pos[mask, None, :] + times[None, :, None] * vel[mask, None, :]

    def _note_reactions(self, obs: Observation, p0: np.ndarray) -> None:
        """Marks pedestrians seen to give way: within ``REACTION_RANGE`` of contact, their velocity changed by at
        least ``REACTION_DV`` [m/s] away from the robot over the last ``REACTION_WINDOW_S`` (slowed down on their way
        to it, or turned off). Someone who sees the robot and makes way for it is taken to go on doing so."""
        self._past.append((obs.time, obs.ped_ids, obs.ped_velocities))
        while self._past[0][0] < obs.time - REACTION_WINDOW_S - 1e-9:
            self._past.popleft()
        t_old, ids_old, vel_old = self._past[0]
        if obs.time - t_old < REACTION_WINDOW_S - 1e-9 or len(obs.ped_ids) == 0 or len(ids_old) == 0:
            return
        same = obs.ped_ids[:, None] == ids_old[None, :]  # (now, then)
        seen = np.logical_or.reduce(same, axis=1)
        dv = obs.ped_velocities - vel_old[np.argmax(same, axis=1)]
        away = obs.ped_positions - p0
        gave_way = _along(dv, away) >= REACTION_DV
        near = (
            np.sqrt(np.add.reduce(away * away, axis=1)) - obs.robot_radius - obs.ped_radius <= REACTION_RANGE
        )
        self._reacted.update(obs.ped_ids[seen & near & gave_way].tolist())

    def _assertiveness(self, phi0: float, now: float, dt: float) -> float:
        """0..1: ramps up while route progress over the last ``stall_after_s`` is below ``stall_progress``.

        A robot that waits for pedestrians who wait for it (doorways, corridors, oncoming streams)
        stalls forever; many pedestrians make room for a robot that edges forward, so after a stall
        the soft pedestrian margins shrink (``stall_margin_relief``), while contact stays contact. It
        ramps down at the same rate once progress resumes (no reset: creeping must not switch it off at once).
        """
        s = self.config.safety
        self._phi_hist.append((now, phi0))
        while len(self._phi_hist) > 1 and self._phi_hist[1][0] <= now - s.stall_after_s:
            self._phi_hist.popleft()
        t_old, phi_old = self._phi_hist[0]
        stalled = now - t_old >= s.stall_after_s - 1e-9 and phi_old - phi0 < s.stall_progress
        step = dt / s.stall_ramp_s
        self._assert = min(max(self._assert + (step if stalled else -step), 0.0), 1.0)  # = np.clip on a float
        return self._assert

    def _route(self, obs: Observation) -> C.RoutePotential:
        """The route potential of the remaining route; rebuilt only when the route (or tolerance) changes."""
        route = np.asarray(obs.route, dtype=float)
        key = (route.tobytes(), route.shape, obs.goal_tolerance)
        if self._route_cache is None or self._route_cache[0] != key:
            res = self.config.search.geodesic_resolution
            clearance = obs.robot_radius + self.config.safety.static_margin
            way = None if res <= 0 else (lambda w: GeodesicDistance(obs.static, w, clearance, res))
            self._route_cache = (
                key,
                C.RoutePotential(
                    route, switch_radius=obs.goal_tolerance, goal_tolerance=obs.goal_tolerance, distance=way
                ),
            )
        return self._route_cache[1]

    def _candidates(self, near: bool | None) -> np.ndarray:
        """First-segment commands (near field or not), or the later-segment set for ``None``; cached per episode."""
        if near not in self._cands and self._holonomic:
            cfg = self.config
            self._cands[near] = (
                holonomic_branches(cfg.search, self._limits, cfg.max_speed_ratio)
                if near is None
                else holonomic_candidates(cfg.sampling, self._limits, cfg.max_speed_ratio, near)
            )
        if near not in self._cands:
            cfg = self.config
            self._cands[near] = (
                branch_commands(
                    cfg.search,
                    self._limits,
                    cfg.max_speed_ratio,
                    reverse_speeds(cfg.sampling, self._limits, cfg.max_speed_ratio),
                )
                if near is None
                else first_candidates(cfg.sampling, self._limits, cfg.max_speed_ratio, near)
            )
        return self._cands[near]

    def _first_sequences(self, near: bool, steps: int, dt: float) -> np.ndarray:
        """The first round's sequences (C + P + V, steps, 2): the first-segment candidates held to the horizon, then the
        point turns (``sampling.turn_then_go``) and the swerves (``sampling.veer_turn_rates``); cached per episode,
        read-only."""
        key = (near, steps)
        if key not in self._firsts:
            cfg = self.config
            held = np.repeat(self._candidates(near)[:, None, :], steps, axis=1)
            if self._holonomic:  # it moves any way at once: no point turns or swerves to add
                held.flags.writeable = False
                self._firsts[key] = held
                return held
            turns = turn_then_go(cfg.sampling, self._limits, steps, dt, cfg.max_speed_ratio)
            veers = veer_then_straight(cfg.sampling, self._limits, steps, dt, cfg.max_speed_ratio)
            seqs = np.concatenate([held, turns, veers])
            seqs.flags.writeable = False
            self._firsts[key] = seqs
        return self._firsts[key]

    def _static_field(self, obs: Observation) -> C.StaticClearance:
        """One distance field per static geometry object (the simulator keeps one per map)."""
        if self._static is None or self._static.static is not obs.static:
            self._static = C.StaticClearance(obs.static, self.config.safety.static_field_resolution)
        return self._static

    def _search(
        self, obs: Observation, scene: C.Scene, near: bool
    ) -> tuple[np.ndarray, dict, float, int, bool]:
        """Beam search; returns the best sequence's commands (S, 2), its terms, its cost, #evaluations and whether it
        is the last decision's plan carried on."""
        cfg = self.config
        sim_dt = obs.dt
        idx, S, bounds = self._steps(scene.times, sim_dt)
        state0 = np.concatenate([obs.robot_pose, obs.robot_velocity]).astype(float)
        cmds = self._first_sequences(near, S, sim_dt)  # (C + P, S, 2)
        states = self._frames(state0[None], cmds, ("first", near, S))
        kept = self._kept_plan(state0, S, sim_dt) if cfg.search.keep_plan and not self._holonomic else None
        if kept is not None:
            cmds, states = np.concatenate([cmds, kept[0][None]]), np.concatenate([states, kept[1][None]])
        total, terms = C.evaluate(C.Rollouts(states, idx, self._costed(cmds)), scene, cfg)
        evals = [
            (cmds, states, total, terms)
        ]  # (commands, states, totals, terms) of each evaluation, in order
        n_eval = len(cmds)
        branch = self._candidates(None)
        M = len(branch)
        for b in bounds:
            keep = np.argsort(_joined(evals, 2), kind="stable")[: cfg.search.beam_width]
            p_cmds, p_states = _joined(evals, 0)[keep], _joined(evals, 1)[keep]
            new_cmds = np.repeat(p_cmds, M, axis=0)
            new_cmds[:, b:] = np.tile(branch, (len(keep), 1))[:, None, :]
            tail = self._frames(p_states[:, b - 1], new_cmds[:M, b:], ("branch", b, S))
            new_states = np.concatenate([np.repeat(p_states[:, :b], M, axis=0), tail], axis=1)
            t_new, terms_new = C.evaluate(C.Rollouts(new_states, idx, self._costed(new_cmds)), scene, cfg)
            n_eval += len(new_cmds)
            evals.append((new_cmds, new_states, t_new, terms_new))
        best = int(np.argmin(_joined(evals, 2)))
        e = 0
        while best >= len(evals[e][2]):  # find the evaluation that holds ``best``
            best -= len(evals[e][2])
            e += 1
        cmds, states, total, terms = evals[e]
        self._plan = cmds[best], states[best]
        carried_on = (
            kept is not None and e == 0 and best == len(cmds) - 1
        )  # the kept plan is the first round's last
        return cmds[best], {k: v[best] for k, v in terms.items()}, float(total[best]), n_eval, carried_on

    def _costed(self, cmds: np.ndarray) -> np.ndarray:
        """The commands as the cost reads them: themselves, or a holonomic robot's as (speed, bearing)."""
        return holonomic.cost_commands(cmds, self._limits) if self._holonomic else cmds

    def _kept_plan(self, state0: np.ndarray, S: int, dt: float) -> tuple[np.ndarray, np.ndarray] | None:
        """The last decision's sequence one step on, its last command held, and its rollout (``search.keep_plan``).

        The robot carried out the plan's first command with the rollout's own kinematics, so it stands where the
        plan's first state is and the rest of that rollout is this plan's, but for one more step at the end;
        anything else (the first decision, another horizon, a robot moved otherwise) gets no kept plan."""
        if self._plan is None or len(self._plan[0]) != S:
            return None
        cmds, states = self._plan
        if np.max(np.abs(states[0, [0, 1, 3, 4]] - state0[[0, 1, 3, 4]])) > 1e-6:
            return None
        cmds = np.concatenate([cmds[1:], cmds[-1:]])
        last = robot_step(states[-1], cmds[-1], self._limits, dt)
        return cmds, np.concatenate([states[1:], last[None]])

    def _steps(self, times: np.ndarray, sim_dt: float) -> tuple[np.ndarray, int, list[int]]:
        """Rollout step of each forecast time, rollout length and segment boundaries; cached per time grid."""
        key = (times.tobytes(), sim_dt)
        cached = self._step_cache.get(key)
        if cached is None:
            idx = eval_steps(times, sim_dt)
            S = int(idx[-1]) + 1
            cached = self._step_cache[key] = (idx, S, _boundaries(self.config.search.segments_s, sim_dt, S))
        return cached


#: a pedestrian whose velocity changed by REACTION_DV [m/s] away from the robot within REACTION_WINDOW_S [s], within
#: REACTION_RANGE [m] of contact, is seen to give way to the robot (``_note_reactions``)
REACTION_DV = 0.1
REACTION_WINDOW_S = 2.0
REACTION_RANGE = 3.0
#: stall assertiveness from which the robot, having yielded, commits to edging past pedestrians who wait for it
#: (reference defaults, 69 episodes: 0.5 -> 0.928 but a hard seed lost behind a slow group; 0.8 -> 0.913, 7/7)
COMMIT_ASSERTIVENESS = 0.8
#: the spread [m] it then allows a waiting pedestrian's position: it trusts it to stand (and tests that, below)
COMMIT_SIGMA = 0.1
#: a standing pedestrian is under test from this far beyond ``yield_range`` [m]; it holds its ground if the robot
#: closed in by at least ``YIELD_PROBE_CLOSING`` [m] during the test while it moved less than that
YIELD_PROBE_SLACK = 0.3
YIELD_PROBE_CLOSING = 0.1
LINGER_DISTANCE = (
    0.5  #: [m] a pedestrian by the robot that moved less over ``standing_stays_s`` lingers there
)


NO_LINES = np.zeros(0, dtype=np.int64)  #: no pedestrian held to a straight line


def _member(ids: np.ndarray, pool) -> np.ndarray:
    """(N,) mask: which ``ids`` are in ``pool`` (an iterable of ints). np.isin by one comparison table: its sorting
    machinery cost ~50 us per decision at these sizes."""
    return np.logical_or.reduce(ids[:, None] == np.array(list(pool), dtype=np.int64), axis=1)


def _along(vectors: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """(N,) component of each vector (N, 2) along its direction (N, 2) [same unit], e.g. a walking speed towards
    the robot."""
    norm = np.sqrt(np.add.reduce(directions * directions, axis=1))
    return np.add.reduce(vectors * directions, axis=1) / np.maximum(norm, 1e-6)


def _reach(v0: float, limits: RobotLimits, times: np.ndarray) -> np.ndarray:
    """Farthest the robot can travel [m] by each time (K,) from speed v0 >= 0 (a magnitude, either way) under its
    acceleration and speed limits (a robot that may drive backwards speeds up backwards at its braking rate)."""
    rate = limits.accel if limits.v_min >= 0 else max(limits.accel, limits.decel)
    top = max(limits.v_max, -limits.v_min)
    t_acc = max(0.0, top - v0) / rate
    ta = np.minimum(times, t_acc)
    return v0 * ta + 0.5 * rate * ta**2 + top * np.maximum(0.0, times - t_acc)


def _boundaries(segments_s: tuple[float, ...], sim_dt: float, S: int) -> list[int]:
    """Simulator-step indices where segments 2.. start (strictly inside the horizon)."""
    out, acc = [], 0
    for d in segments_s:
        acc += max(1, int(round(d / sim_dt)))
        if acc >= S:
            break
        out.append(acc)
    if not out and segments_s:
        raise ConfigError(
            f"segments {segments_s} s leave no second segment inside the {S * sim_dt:.1f} s horizon",
            item="search.segments_s",
        )
    return out


def _joined(evals: list[tuple], field: int) -> np.ndarray:
    """One field of every evaluation so far, in order (the first one's own array while it is alone: the default
    search has one branching round, so its states and commands are never copied into a pool)."""
    return evals[0][field] if len(evals) == 1 else np.concatenate([e[field] for e in evals])


def _segments(cmds: np.ndarray) -> list[tuple[int, float, float]]:
    """Run-length encoding of a command sequence: (steps, v, omega) per constant segment.

    A loop over the (S, 2) rows as Python floats: at a few dozen steps cheaper than array ops."""
    out: list[tuple[int, float, float]] = []
    for v, w in cmds.tolist():
        if out and out[-1][1] == v and out[-1][2] == w:
            out[-1] = (out[-1][0] + 1, out[-1][1], out[-1][2])
        else:
            out.append((1, v, w))
    return out
