"""The simulator: reset a resolved scenario with a seed, then step it with (v, omega) commands.

Order of one step (reference §1.6, §10.1): pedestrian behaviours (goal updates, respawns) ->
pedestrian forces with the robot at its old pose -> pedestrian integration -> robot kinematics ->
waypoint update -> collision, goal and timeout checks on the new positions -> trace row ->
observation. All randomness comes from generators spawned from
``SeedSequence([seed, stable hash of the scenario name])``; no global RNG is touched, so the same
(scenario, seed, commands) gives a bit-identical trace.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
from collections.abc import Callable

import numpy as np

from foresight.core.errors import CoreError
from foresight.core.scenarios.model import ResolvedScenario
from foresight.core.sim.attention import reaction_ranges
from foresight.core.sim.behaviours import CrowdArrays, CrowdedZones, RouteFollowing, SingleScripts
from foresight.core.sim.collision import StaticChecker, ped_contact, radii_contact
from foresight.core.sim.crowd import CrowdDynamics
from foresight.core.sim.generated_crowd import GeneratedCrowd
from foresight.core.sim.geometry import StaticMap
from foresight.core.sim.latency import CommandDelay
from foresight.core.sim.navigation import RobotRoute, sample_robot_route
from foresight.core.sim.observation import Events, Observation
from foresight.core.sim.orca_agents import OrcaCrowdDynamics, obstacle_polygons
from foresight.core.sim.params import CrowdParams, ForceParams
from foresight.core.sim.planner import EpisodeInfo
from foresight.core.sim.population import build_population, check_crowd
from foresight.core.sim.replay import ReplayCrowd
from foresight.core.sim.robot import RobotLimits, robot_step
from foresight.core.sim.trace import Trace
from foresight.core.sim.visibility import visible
from foresight.core.version import code_version

_NO_EVENT = Events()


def stable_hash(text: str) -> int:
    """A 64-bit hash of a string that is the same in every process (unlike ``hash``)."""
    return int.from_bytes(hashlib.sha256(text.encode()).digest()[:8], "little")


def episode_generators(name: str, seed: int, n: int) -> list[np.random.Generator]:
    """n independent generators for one (scenario, seed) episode."""
    ss = np.random.SeedSequence([int(seed) & 0xFFFFFFFFFFFFFFFF, stable_hash(name)])
    return [np.random.Generator(np.random.PCG64(s)) for s in ss.spawn(n)]


def stopping_zone_clear(
    pts: np.ndarray, robot: np.ndarray, clear: float, decel: float, cone_deg: float
) -> np.ndarray:
    """(K,) True for points (K, 2) outside the moving robot's stopping zone.

    The zone: points within ``cone_deg`` of the robot's direction of travel (its heading, reversed
    when driving backwards) and within ``clear`` + v^2 / (2 decel) of its centre, v = the robot's
    speed (state column 3). A pedestrian (re)spawned there is inside the distance the robot needs
    to brake, so contact would be unavoidable whatever the planner does. A standing robot has no
    zone (``clear`` alone applies, in ``Simulator._free``).
    """
    v = float(robot[3])
    pts = np.asarray(pts, dtype=float).reshape(-1, 2)
    if v == 0.0 or decel <= 0:
        return np.ones(len(pts), dtype=bool)
    reach = clear + v * v / (2.0 * decel)
    heading = float(robot[2]) + (0.0 if v > 0 else math.pi)
    rel = pts - np.asarray(robot[:2], dtype=float)
    dist = np.hypot(rel[:, 0], rel[:, 1])
    along = rel[:, 0] * math.cos(heading) + rel[:, 1] * math.sin(heading)
    in_cone = along >= dist * math.cos(math.radians(cone_deg))
    return ~(in_cone & (dist <= reach))


class Simulator:
    """Social-force crowd plus one robot on a static map; ``reset`` then ``step`` until ``Events.done``."""

    def __init__(self, force_params: ForceParams | None = None, crowd_params: CrowdParams | None = None):
        self.force_params = force_params or ForceParams()
        self.crowd_params = crowd_params or CrowdParams()
        self._static_cache: tuple[object, StaticMap] | None = None
        self._trace: Trace | None = None
        self.done = True

    @property
    def trace(self) -> Trace:
        if self._trace is None:
            raise CoreError("no episode yet: call reset() first")
        return self._trace

    def _static(self, scenario: ResolvedScenario) -> StaticMap:
        if self._static_cache is None or self._static_cache[0] is not scenario.map:
            self._static_cache = (scenario.map, StaticMap(scenario.map))
        return self._static_cache[1]

    def reset(
        self,
        scenario: ResolvedScenario,
        seed: int,
        *,
        max_steps: int | None = None,
        check: Callable[[], None] | None = None,
    ) -> Observation:
        """Start an episode: robot route, crowd, empty trace; returns the observation at step 0. The crowd's
        size is checked before anything is spawned; ``check`` (cancellation, deadline) is called while it spawns."""
        cfg, rcfg, map_def = scenario.scenario.simulation_config, scenario.scenario.robot_config, scenario.map
        self.horizon = int(max_steps if max_steps is not None else cfg.max_episode_steps)
        check_crowd(scenario, self.horizon, self.crowd_params)
        self.scenario, self.seed, self.cfg = scenario, int(seed), cfg
        self.static = self._static(scenario)
        self.dt = cfg.dt
        self.limits = RobotLimits.from_config(rcfg)
        self.limits_dict = self.limits.as_dict()
        latency = rcfg.command_latency_s
        self.delay = CommandDelay(latency, self.dt) if latency > 0 else None
        self.ped_radius = cfg.ped_radius
        robot_rng, pop_rng, spread_rng, self.rng, attention_rng = episode_generators(scenario.name, seed, 5)
        if cfg.route_spawn_seed is not None:
            spread_rng = episode_generators(scenario.name, cfg.route_spawn_seed, 4)[2]
        margin = (
            self.crowd_params.robot_spawn_margin
            if cfg.robot_spawn_clearance is None
            else cfg.robot_spawn_clearance
        )
        self.clear = self.limits.radius + cfg.ped_radius + margin  # no pedestrian (re)spawns nearer the robot
        singles = np.array([sp.start for sp in map_def.single_pedestrians], dtype=float).reshape(-1, 2)
        # the robot starts clear of scripted peds and, where the zone allows, not touching a wall
        self.route: RobotRoute = (
            self._generated_route(scenario, seed)
            if scenario.scenario.crowd_generator is not None
            else self._sampled_route(scenario, robot_rng, singles)
        )
        self.route.waypoints.flags.writeable = False
        self.robot = np.array([*self.route.start, self.route.heading, 0.0, 0.0])
        if scenario.scenario.crowd_generator is not None:
            self._reset_generated(scenario, seed)
            self._record()
            return self._observation()
        self.generated = None
        pop = build_population(
            map_def,
            cfg,
            self.crowd_params,
            pop_rng,
            spread_rng,
            lambda pts: self._free(pts, self.robot[None, :2]),
            check,
        )
        pop.pos = self.static.push_off_edges(pop.pos, 2 * self.crowd_params.wall_clearance)
        self.replay = (
            ReplayCrowd(scenario.replay, self.horizon, self.dt) if scenario.replay is not None else None
        )
        if self.replay is not None and pop.n:
            raise CoreError(f"{scenario.name}: a replay scenario has only its recorded pedestrians")
        params, robot_radius, _ = self._robot_repulsion()
        reach = reaction_ranges(pop.n, cfg, params.robot_cutoff(robot_radius), attention_rng)
        self._build_crowd(pop, map_def, reach)
        self._trace = Trace(
            self.horizon,
            pop.n if self.replay is None else self.replay.n,
            dt=self.dt,
            scenario=scenario.name,
            seed=seed,
            meta={
                "code_version": code_version(),
                "map": map_def.name,
                "n_peds": pop.n,
                "n_nonreactive": int((reach == 0).sum()),
                # what a picture of the trace draws: the goal, its tolerance, the robot's body
                "goal": [float(v) for v in self.route.goal],
                "goal_tolerance": float(self.route.tolerance),
                "robot_radius": float(self.limits.radius),
            },
        )
        if self.replay is not None:  # no recorded pedestrian appears where the robot stands
            self.replay.admit(0, self.robot[:2], self.clear)
            self._trace.meta["replay_withheld"] = self.replay.withheld  # the list grows as the episode runs
        self.static_check = StaticChecker(self.static, self.limits.radius)
        self.t = 0
        self.done = False
        self.min_ped_distance = np.inf
        self._record()
        return self._observation()

    def episode_info(self, extra: dict | None = None) -> EpisodeInfo:
        """What a planner may know of the episode just reset: its scenario, seed, step and true radii."""
        return EpisodeInfo(
            scenario=self.scenario,
            seed=self.seed,
            dt=self.dt,
            robot_radius=self.limits.radius,
            ped_radius=self.ped_radius,
            extra=dict(extra or {}),
        )

    def _generated_route(self, scenario: ResolvedScenario, seed: int) -> RobotRoute:
        """CrowdNav's crowd (``core.sim.generated_crowd``), drawn first: its generator places the robot too."""
        cfg, gen = self.cfg, scenario.scenario.crowd_generator
        self.generated = GeneratedCrowd(
            gen,
            cfg.orca,
            seed,
            self.limits.radius,
            cfg.ped_radius,
            self.dt,
            obstacle_polygons(scenario.map.obstacles),
        )
        g = self.generated
        return RobotRoute(
            start=g.robot_start + g.centre,
            heading=math.pi / 2,
            waypoints=(g.robot_goal + g.centre)[None, :].copy(),
            tolerance=self.limits.radius + cfg.goal_radius,
        )

    def _reset_generated(self, scenario: ResolvedScenario, seed: int) -> None:
        g, n = self.generated, self.generated.gen.human_num
        self.crowd, self.replay, self.has_groups = g, None, False
        self._trace = Trace(
            self.horizon,
            n,
            dt=self.dt,
            scenario=scenario.name,
            seed=seed,
            meta={
                "code_version": code_version(),
                "map": scenario.map.name,
                "n_peds": n,
                "n_nonreactive": 0 if self.cfg.orca.robot_visible else n,
                "goal": [float(v) for v in self.route.goal],
                "goal_tolerance": float(self.route.tolerance),
                "robot_radius": float(self.limits.radius),
                "pedestrian_model": "orca",
            },
        )
        self.static_check = StaticChecker(self.static, self.limits.radius)
        self.t = 0
        self.done = False
        self.min_ped_distance = np.inf

    def _sampled_route(self, scenario: ResolvedScenario, robot_rng, singles: np.ndarray) -> RobotRoute:
        cfg, map_def = self.cfg, scenario.map
        return sample_robot_route(
            map_def,
            robot_rng,
            self.limits.radius + cfg.goal_radius,
            cfg.zone_sampling,
            start_ok=lambda pts: self._free(pts, singles) & (self.static.distance(pts) > self.limits.radius),
            goal_ok=lambda pts: ~self.static.inside_obstacle(pts),
            start_fallback=lambda pts: self._free(pts, singles),
        )

    def _free(self, pts: np.ndarray, avoid: np.ndarray) -> np.ndarray:
        """Accept points outside obstacles and farther than collision distance + margin from ``avoid`` (K, 2)."""
        ok = ~self.static.inside_obstacle(pts)
        if len(avoid):
            d2 = ((pts[:, None, :] - avoid[None, :, :]) ** 2).sum(axis=2).min(axis=1)
            ok &= d2 > self.clear**2
        return ok

    def _respawn_ok(self, pts: np.ndarray) -> np.ndarray:
        """``_free`` of the robot, and out of its stopping zone ahead (``stopping_zone_clear``)."""
        ok = self._free(pts, self.robot[None, :2])
        if ok.any():
            ok &= stopping_zone_clear(
                pts, self.robot, self.clear, self.limits.decel, self.crowd_params.robot_spawn_cone_deg
            )
        return ok

    def _robot_repulsion(self) -> tuple[ForceParams, float, bool]:
        """Force parameters, robot radius in the force, and whether peds feel the robot at all.

        A scenario's ``prf_config`` (robot_sf's calibration) replaces the factor, activation range and radius.
        """
        cfg = self.cfg
        params, robot_radius, repulsion = self.force_params, self.limits.radius, cfg.peds_have_robot_repulsion
        if cfg.prf_config is not None:
            prf = cfg.prf_config
            params = dataclasses.replace(
                params, robot_factor=prf.force_multiplier, robot_activation=prf.activation_threshold
            )
            robot_radius, repulsion = prf.robot_radius, repulsion and prf.is_active
        return params, robot_radius, repulsion

    def _build_crowd(self, pop, map_def, robot_reach: np.ndarray) -> None:
        cfg, cp = self.cfg, self.crowd_params
        self.crowd = CrowdArrays(pop)
        self.routes = RouteFollowing(pop, map_def, cp.route_threshold, cfg.zone_sampling)
        self.zones = CrowdedZones(
            pop, map_def, cp.route_threshold, cfg.zone_sampling, lambda pts: ~self.static.inside_obstacle(pts)
        )
        self.singles = SingleScripts(pop.singles, pop.n - len(pop.singles), self.dt, cp.single_threshold)
        self.has_groups = len(self.routes.groups) + len(self.zones.groups) > 0
        params, robot_radius, repulsion = self._robot_repulsion()
        self.dynamics = CrowdDynamics(
            self.crowd,
            self.static.walls,
            params,
            cp,
            dt=self.dt,
            robot_radius=robot_radius,
            obstacle_forces=cfg.peds_have_obstacle_forces,
            robot_repulsion=repulsion,
            semi_implicit=cfg.pedestrian_integration_scheme == "semi_implicit_euler",
            robot_reach=robot_reach,
        )
        if cfg.pedestrian_model == "orca":  # the same behaviours, ORCA agents instead of forces
            self.dynamics = OrcaCrowdDynamics(
                self.crowd, cfg.orca, self.dt, cfg.ped_radius, self.limits.radius, map_def.obstacles
            )
        if cfg.peds_reset_follow_route_at_start:
            self.routes.restart_all(self.crowd, self.rng, self._respawn_ok)

    def step(self, command) -> tuple[Observation, Events]:
        """Apply one command ((v [m/s], omega [rad/s]); (vx, vy) for a holonomic robot) for dt; with
        ``robot_config.command_latency_s`` the robot executes the commands in effect now (``core.sim.latency``)."""
        if self.done:
            raise CoreError("the episode is over (or was never started): call reset()")
        cmd = np.asarray(command, dtype=float).reshape(2)
        if not (math.isfinite(cmd[0]) and math.isfinite(cmd[1])):
            raise CoreError(f"non-finite command {tuple(cmd)} at step {self.t} of {self.scenario.name}")
        cent = None
        before = None
        if self.generated is not None:
            before = self.robot[:2].copy(), self.generated.pos.copy(), self.generated.vel.copy(), self.dt
            v, th = float(self.robot[3]), float(self.robot[2])
            self.generated.step(self.robot, np.array([v * math.cos(th), v * math.sin(th)]))
        elif self.has_groups:
            cent = self.crowd.centroids()
            if self.routes.step(self.crowd, cent, self.rng, self._respawn_ok):
                cent = None  # a group respawned: positions changed
            self.zones.step(self.crowd, cent if cent is not None else self.crowd.centroids(), self.rng)
        if self.generated is None:
            self.singles.step(self.crowd, self.t, self.robot)
            if isinstance(self.dynamics, OrcaCrowdDynamics):
                v, th = float(self.robot[3]), float(self.robot[2])
                self.dynamics.robot_vel = np.array([v * math.cos(th), v * math.sin(th)])
            self.dynamics.step(complex(self.robot[0], self.robot[1]), cent)
        if self.delay is None:
            self.robot = robot_step(self.robot, cmd, self.limits, self.dt)
        else:  # the commands in effect during this step (core.sim.latency)
            for piece, duration in self.delay.push(cmd):
                self.robot = robot_step(self.robot, piece, self.limits, duration)
        reached = self.route.advance(self.robot)
        self._trace.record_command(self.t, cmd)
        self.t += 1
        if self.replay is not None:  # no recorded pedestrian appears where the robot stands
            self.replay.admit(self.t, self.robot[:2], self.clear)
        self._record()
        events = self._events(reached, before)
        if events.done:
            self.done = True
            self._trace.outcome = events.outcome or ""
        return self._observation(), events

    def _events(self, reached: bool, before: tuple | None = None) -> Events:
        xy = self.robot[:2]
        peds = self.crowd.pos if self.replay is None else self.replay.present_pos(self.t)
        if self.generated is None:
            contact, dmin = ped_contact(xy, self.limits.radius, peds, self.ped_radius)
        else:  # each human's own radius; CrowdNav's swept test where the scenario asks for it
            swept = before if self.cfg.collision_check == "swept" else None
            contact, dmin = radii_contact(xy, self.limits.radius, peds, self.generated.radius, swept)
        self.min_ped_distance = min(self.min_ped_distance, dmin)
        if contact is None:
            contact = self.static_check.check(xy)
        if contact is not None:
            tr = self._trace
            tr.collision_step, tr.collision_kind, tr.collision_point = self.t, contact.kind, contact.point
            return Events(collision=contact.kind)
        if reached:
            return Events(goal_reached=True)
        if self.t >= self.horizon:
            return Events(timeout=True)
        return _NO_EVENT

    def _record(self) -> None:
        c, r, t = self.crowd, self.replay, self.t
        if r is None:
            self._trace.record_state(t, self.robot, c.ids, c.pos, c.vel)
        else:
            self._trace.record_state(t, self.robot, r.ids[t], r.pos[t], r.vel[t])

    def _observation(self) -> Observation:
        robot, ids, pos, vel = self._trace.row(self.t)
        if self.replay is not None:  # planners see the pedestrians present now, never an empty slot
            here = self.replay.present[self.t]
            ids, pos, vel = ids[here], pos[here], vel[here]
        radii = None
        if self.generated is not None and self.generated.randomized:
            radii = self.generated.radius.copy()
        vis = self.scenario.scenario.observation_visibility
        if vis is not None and vis.active:
            seen = visible(robot, pos, vis, self.scenario.map.obstacle_segments)
            ids, pos, vel = ids[seen], pos[seen], vel[seen]
            radii = None if radii is None else radii[seen]
        route, pending = self.route, (None, None) if self.delay is None else self.delay.pending()
        return Observation(
            step=self.t,
            time=self.t * self.dt,
            dt=self.dt,
            robot_pose=robot[:3],
            robot_velocity=robot[3:],
            robot_radius=self.limits.radius,
            waypoint=route.waypoints[route.index],
            goal=route.waypoints[-1],
            route=route.waypoints[route.index :],
            goal_tolerance=route.tolerance,
            ped_ids=ids,
            ped_positions=pos,
            ped_velocities=vel,
            ped_radius=self.ped_radius,
            static=self.static,
            robot_limits=self.limits_dict,
            ped_radii=radii,
            pending_commands=pending[0],
            pending_durations=pending[1],
        )
