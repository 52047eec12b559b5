"""``foresight/CrowdNav-v0``: our simulator as a Gymnasium environment (for RL policies).

Observation (a ``Dict``, robot frame: x ahead, y to the left; metres, seconds, radians):
  ``robot``      (3,)    v [m/s], omega [rad/s], robot radius [m]
  ``goal``       (3,)    goal x, y, distance
  ``route``      (R, 2)  the next R route waypoints (current first), padded with the goal
  ``peds``       (K, 4)  the nearest K pedestrians: x, y, vx, vy (velocity relative to the ground, robot frame)
  ``ped_mask``   (K,)    1 where a ``peds`` row holds a pedestrian, 0 for padding
  ``occupancy``  (S, S)  optional: 1 where a cell centre (a square grid of ``occupancy_resolution`` m around the
                         robot, robot frame) lies within half a cell of a wall or outside the map
Action: ``Box`` (v, omega) within the robot's limits (a holonomic robot: (vx, vy) in the world frame).
Reward (:class:`RewardConfig`): route progress per metre, minus a time cost per step, plus a success bonus or a
collision penalty at the end. ``terminated`` on a collision or at the goal, ``truncated`` at the scenario's
horizon. ``info``: ``outcome`` and ``step`` every step; at the end ``record``, the episode's evaluation record
(metrics and failure taxonomy, the same as ``foresight evaluate`` computes). ``reset(seed=...)`` is deterministic:
the seed picks the scenario (when several) and the episode seed.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from pydantic import BaseModel, ConfigDict

from foresight.core.evaluation.episode import record_of
from foresight.core.evaluation.plannerspec import NO_MODEL, ResolvedPlanner
from foresight.core.runtime.refs import BUILTIN_CONFIG_ROOT
from foresight.core.scenarios.loader import load_matrix
from foresight.core.sim.observation import Observation
from foresight.core.sim.simulator import Simulator

DEFAULT_MATRIX = BUILTIN_CONFIG_ROOT / "scenarios" / "classic_interactions.yaml"
AGENT = ResolvedPlanner(
    name="gym", variant=None, config={}, config_hash=NO_MODEL, model_id=NO_MODEL, checkpoint_sha256=NO_MODEL
)  #: how the records name the policy being trained


class RewardConfig(BaseModel):
    """Reward terms; the defaults favour reaching the goal without contact over speed."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    progress: float = 1.0  #: per metre of route progress (negative when moving away)
    step: float = -0.01  #: every step (a time cost)
    success: float = 10.0  #: on reaching the goal
    collision: float = -10.0  #: on any collision (pedestrian, wall, out of bounds)


def _rotation(heading: float) -> np.ndarray:
    c, s = np.cos(heading), np.sin(heading)
    return np.array([[c, s], [-s, c]])  # world -> robot frame


def route_length(obs: Observation) -> float:
    """Distance still to go along the route: robot -> current waypoint -> ... -> goal."""
    pts = np.vstack([obs.robot_pose[:2], obs.route])
    return float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum())


class CrowdNavEnv(gym.Env):
    """One robot among the simulated crowd of a scenario matrix; see the module docstring for the spaces."""

    metadata = {"render_modes": []}

    def __init__(
        self,
        scenario: str | None = None,
        matrix: str | Path = DEFAULT_MATRIX,
        scenarios: list[str] | None = None,
        max_steps: int | None = None,
        max_peds: int = 8,
        route_points: int = 4,
        occupancy: bool = False,
        occupancy_size: int = 16,
        occupancy_resolution: float = 0.5,
        reward: RewardConfig | dict[str, Any] | None = None,
    ):
        self.matrix = load_matrix(Path(matrix))
        names = [scenario] if scenario else (scenarios or self.matrix.names)
        self.scenarios = [self.matrix.get(n) for n in names]
        self.max_steps, self.k, self.r = max_steps, int(max_peds), int(route_points)
        self.occupancy = occupancy
        self.grid = (np.arange(occupancy_size) - (occupancy_size - 1) / 2) * occupancy_resolution
        self.cell = float(occupancy_resolution)
        self.reward_cfg = (
            reward if isinstance(reward, RewardConfig) else RewardConfig.model_validate(reward or {})
        )
        self.sim = Simulator()
        first = self.sim.reset(
            self.scenarios[0], 0, max_steps=max_steps
        )  # the robot's limits: the action space
        lim = first.robot_limits
        if lim.get("holonomic", 0.0):
            low, high = [-lim["v_max"], -lim["v_max"]], [lim["v_max"], lim["v_max"]]
        else:
            low, high = [lim["v_min"], -lim["w_max"]], [lim["v_max"], lim["w_max"]]
        self.action_space = spaces.Box(
            np.array(low, np.float32), np.array(high, np.float32), dtype=np.float32
        )
        inf = np.float32(1e4)  # [m], [m/s]: beyond any map
        obs_spaces = {
            "robot": spaces.Box(-inf, inf, (3,), np.float32),
            "goal": spaces.Box(-inf, inf, (3,), np.float32),
            "route": spaces.Box(-inf, inf, (self.r, 2), np.float32),
            "peds": spaces.Box(-inf, inf, (self.k, 4), np.float32),
            "ped_mask": spaces.Box(0.0, 1.0, (self.k,), np.float32),
        }
        if occupancy:
            obs_spaces["occupancy"] = spaces.Box(0.0, 1.0, (occupancy_size, occupancy_size), np.float32)
        self.observation_space = spaces.Dict(obs_spaces)
        self._obs: Observation | None = None
        self._scenario = self.scenarios[0]
        self._seed = 0

    # ------------------------------------------------------------------ observation

    def _observe(self, obs: Observation) -> dict[str, np.ndarray]:
        rot, here = _rotation(float(obs.robot_pose[2])), obs.robot_pose[:2]
        goal = rot @ (obs.goal - here)
        route = np.vstack([obs.route, np.repeat(obs.goal[None], self.r, axis=0)])[: self.r]
        peds, mask = np.zeros((self.k, 4)), np.zeros(self.k)
        if len(obs.ped_positions):
            rel = obs.ped_positions - here
            nearest = np.argsort(np.hypot(rel[:, 0], rel[:, 1]), kind="stable")[: self.k]
            n = nearest.size
            peds[:n, :2] = rel[nearest] @ rot.T
            peds[:n, 2:] = obs.ped_velocities[nearest] @ rot.T
            mask[:n] = 1.0
        out = {
            "robot": np.array([obs.robot_velocity[0], obs.robot_velocity[1], obs.robot_radius]),
            "goal": np.array([goal[0], goal[1], np.hypot(*goal)]),
            "route": (route - here) @ rot.T,
            "peds": peds,
            "ped_mask": mask,
        }
        if self.occupancy:
            gx, gy = np.meshgrid(self.grid, self.grid, indexing="xy")
            world = here + np.stack([gx, gy], axis=-1) @ rot  # robot frame -> world
            out["occupancy"] = (obs.static.distance(world) < self.cell / 2).astype(float)
        return {k: v.astype(np.float32) for k, v in out.items()}

    # ------------------------------------------------------------------ gymnasium API

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):  # noqa: ANN201
        super().reset(seed=seed)
        self._scenario = self.scenarios[int(self.np_random.integers(len(self.scenarios)))]
        self._seed = int(self.np_random.integers(2**31 - 1))
        self._obs = self.sim.reset(self._scenario, self._seed, max_steps=self.max_steps)
        self._left = route_length(self._obs)
        return self._observe(self._obs), {"scenario": self._scenario.name, "seed": self._seed, "step": 0}

    def step(self, action: Any):  # noqa: ANN201
        if self._obs is None:
            raise RuntimeError("call reset() before step()")
        a = np.clip(np.asarray(action, dtype=float), self.action_space.low, self.action_space.high)
        obs, events = self.sim.step((float(a[0]), float(a[1])))
        self._obs = obs
        left = route_length(obs)
        cfg = self.reward_cfg
        reward = cfg.progress * (self._left - left) + cfg.step
        self._left = left
        terminated = events.collision is not None or events.goal_reached
        truncated = events.timeout and not terminated
        info: dict[str, Any] = {"outcome": events.outcome, "step": int(obs.step)}
        if events.collision is not None:
            reward += cfg.collision
        elif events.goal_reached:
            reward += cfg.success
        if terminated or truncated:
            record, _ = record_of(self._scenario, self._seed, self.sim, AGENT, outcome=events.outcome)
            info["record"] = record.model_dump(mode="json")
            self._obs = None
        return self._observe(obs), float(reward), bool(terminated), bool(truncated), info
