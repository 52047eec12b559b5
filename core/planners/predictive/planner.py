"""The predictive planner: forecast -> (v, omega) candidates -> beam search over rollouts -> best command.

Under command latency the decision is made for the moment its command takes effect (``latency``).

One decision: one batched forecaster call; the forecast with the crowd assumptions applied (``crowd``, ``scene``);
first-segment candidates (dense in the near field) rolled out with the simulator's own kinematics
(``core.sim.robot.unicycle_rollout``) and held to the horizon, plus point turns (turn in place, then straight: how a
robot in a corner faces a door) and swerves (turn at speed for a while, then straight: how a robot behind slower
walkers pulls out to pass them); the best ``beam_width`` sequences are extended with a coarser command set
(``search``); the first command of the cheapest sequence seen is returned. Braking (0, 0) is always a candidate, so
the robot can wait, but waiting is no refuge: a pedestrian forecast to walk into a standing robot costs as much as one
the robot drives into, so the search turns away, speeds up or gives way early instead, and waiting where walkers have
lately passed costs too (``traffic``: the next one through a doorway is often not in view yet). Pedestrian terms read
the forecast's spread (a chance margin and the contact probability, see ``cost``); after a few seconds without route
progress the soft margins shrink (``crowd.Stall``), never the contact distance, and the robot commits: pedestrians
standing near it are taken to wait for it, to stay and to step back as it edges forward (``crowd.WaitsForRobot``: a
doorway standoff ends), until one is seen to hold its ground; before that, people lingering by the robot are forecast
to stay (``crowd.Lingers``). What the planner keeps across an episode's decisions is in ``memory``. Deterministic:
no randomness, stable sorts.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from foresight.core.planners.predictive import cost as C
from foresight.core.planners.predictive import holonomic
from foresight.core.planners.predictive.config import PredictivePlannerConfig
from foresight.core.planners.predictive.crowd import CrowdAssumptions
from foresight.core.planners.predictive.forecast_input import planner_forecast
from foresight.core.planners.predictive.geodesic import GeodesicDistance
from foresight.core.planners.predictive.latency import check_latency, look_ahead
from foresight.core.planners.predictive.memory import EpisodeMemory
from foresight.core.planners.predictive.rollout import FrameRollouts, eval_steps, rollout
from foresight.core.planners.predictive.scene import contact_distance, crowd_scene
from foresight.core.planners.predictive.search import BeamSearch
from foresight.core.planners.predictive.traffic import TrafficMap
from foresight.core.predict.forecaster import Forecaster
from foresight.core.sim.observation import Observation
from foresight.core.sim.planner import EpisodeInfo
from foresight.core.sim.robot import RobotLimits


class PredictivePlanner:
    """Planner protocol implementation; ``forecaster`` supplies the pedestrian forecasts (cv or learned)."""

    name = "predictive"

    def __init__(self, config: PredictivePlannerConfig | None, forecaster: Forecaster):
        self.config = config or PredictivePlannerConfig()
        self.forecaster = forecaster
        self._diag: dict[str, Any] | None = None
        self._memory: EpisodeMemory | None = None  #: made fresh by ``reset``
        self._static: C.StaticClearance | None = None  #: kept while the map's static geometry is the same
        self._limits: RobotLimits | None = None
        self._frames: FrameRollouts | None = None  #: kept across episodes of the same robot and dt

    def reset(self, info: EpisodeInfo) -> None:
        fit = getattr(self.forecaster, "fit", None)
        if callable(fit):  # constant velocity fits its grid to the simulator's step
            fit(info.dt)
        self.forecaster.timebase.stride(info.dt)  # ConfigError unless the forecast grid is whole sim steps
        robot = info.scenario.scenario.robot_config
        tb = self.forecaster.timebase
        horizon = tb.horizon * tb.dt + self.config.search.extra_horizon_s
        check_latency(robot.command_latency_s, horizon, info.scenario.name)
        self.forecaster.reset()
        self._limits = RobotLimits.from_config(robot)
        if self._frames is None or self._frames.limits != self._limits or self._frames.dt != info.dt:
            self._frames = FrameRollouts(self._limits, info.dt)  # else its rollouts serve this episode too
        moves_any_way = robot.kinematics == "holonomic"
        self._memory = EpisodeMemory(
            crowd=CrowdAssumptions.fresh(self.config.safety, self._limits),
            search=BeamSearch(self.config, self._limits, moves_any_way, self._frames),
            holonomic=moves_any_way,
        )
        self._diag = None

    @property
    def diagnostics(self) -> dict[str, Any] | None:
        return self._diag

    def plan(self, obs: Observation) -> tuple[float, float]:
        if self._memory is None:
            raise RuntimeError("PredictivePlanner.plan() called before reset(info)")
        mem = self._memory
        t0 = time.perf_counter()
        self.forecaster.observe(obs)
        fc = self.forecaster.forecast()
        observed = obs
        obs, pf = look_ahead(
            obs, planner_forecast(fc, obs, obs.dt), self._limits
        )  # the moment it takes effect
        scene, near, extra = self._scene(obs, pf.positions, pf.sigma, pf.times, pf.ped_ids, pf.weights)
        best_cmds, best_terms, best_total, n_eval, kept, mem.plan = mem.search(obs, scene, near, mem.plan)
        mem.decided = (obs, scene)
        v, w = float(best_cmds[0, 0]), float(best_cmds[0, 1])
        if mem.holonomic:  # the chosen velocity, from the robot's frame to the world's
            v, w = holonomic.to_world(best_cmds[0], float(obs.robot_pose[2]))
        mem.prev = np.array([v, w])
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
            #: under command latency: the state (x, y, heading, v, omega) the rollouts start from, at t + latency
            **({"rollout_start": [*obs.robot_pose, *obs.robot_velocity]} if obs is not observed else {}),
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
        obs, pf = look_ahead(obs, planner_forecast(self.forecaster.forecast(), obs, obs.dt), self._limits)
        scene, _, _ = self._scene(obs, pf.positions, pf.sigma, pf.times, pf.ped_ids, pf.weights)
        idx = eval_steps(scene.times, obs.dt)
        cmds = np.repeat(np.asarray(commands, dtype=float)[:, None, :], int(idx[-1]) + 1, axis=1)
        return self._cost(obs, scene, idx, cmds)

    def price(self, commands: np.ndarray) -> tuple[float, dict[str, float]]:
        """Cost and each term's weighted share (``cost.weighted``) of a command sequence (n, 2) from the last decision's
        state, judged against that decision's forecast: what this planner made of a course it did not choose (a
        witness's). Commands beyond the horizon are dropped; a shorter sequence is held at its last command."""
        if self._memory is None or self._memory.decided is None:
            raise RuntimeError("PredictivePlanner.price() called before plan(obs)")
        obs, scene = self._memory.decided
        idx, S, _ = self._memory.search.steps(scene.times, obs.dt)
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
        if self._memory.holonomic:  # world-frame velocities: the cost reads them in the robot's frame
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
        """The decision's scene (``scene.crowd_scene``); rows of ``positions`` are pedestrians, or modes of them with
        ``weights`` (R,)."""
        mem, limits = self._memory, self._limits
        route = self._route(obs)
        prev = mem.prev
        if mem.holonomic:  # the last command as the cost reads it: in the robot's frame, (speed, bearing)
            prev = holonomic.cost_commands(holonomic.to_local(prev, float(obs.robot_pose[2])), limits)
        traffic = self._lanes(obs, contact_distance(obs, self.config))
        forecast = (positions, sigma, times, fc_ids, weights)
        return crowd_scene(
            self.config, limits, mem.crowd, obs, forecast, route, self._static_field(obs), prev, traffic
        )

    def _lanes(self, obs: Observation, contact: float) -> TrafficMap | None:
        """The episode's traffic map, brought up to date (None while ``weights.lane`` is 0)."""
        if self.config.weights.lane <= 0:
            return None
        mem = self._memory
        if mem.traffic is None:
            mem.traffic = TrafficMap(
                obs.static.width, obs.static.height, contact, memory_s=self.config.safety.crowd.lane_memory_s
            )
        mem.traffic.observe(obs.time, obs.ped_positions, obs.ped_velocities)
        return mem.traffic

    def _route(self, obs: Observation) -> C.RoutePotential:
        """The route potential of the remaining route; rebuilt only when the route (or tolerance) changes."""
        route = np.asarray(obs.route, dtype=float)
        key = (route.tobytes(), route.shape, obs.goal_tolerance)
        mem = self._memory
        if mem.route is None or mem.route[0] != key:
            res = self.config.search.geodesic_resolution
            clearance = obs.robot_radius + self.config.safety.static.margin
            way = None if res <= 0 else (lambda w: GeodesicDistance(obs.static, w, clearance, res))
            mem.route = (
                key,
                C.RoutePotential(
                    route, switch_radius=obs.goal_tolerance, goal_tolerance=obs.goal_tolerance, distance=way
                ),
            )
        return mem.route[1]

    def _static_field(self, obs: Observation) -> C.StaticClearance:
        """One distance field per static geometry object (the simulator keeps one per map)."""
        if self._static is None or self._static.static is not obs.static:
            self._static = C.StaticClearance(obs.static, self.config.safety.static.field_resolution)
        return self._static


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
