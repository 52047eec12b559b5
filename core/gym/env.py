"""``foresight/CrowdNav-v0``: our simulator as a Gymnasium environment (for RL policies).

Observation: a ``Dict`` in the robot frame, built by ``core.sim.policy_observation.policy_observation`` (its
docstring lists the keys); a planner that drives a trained policy (``core.planners.sb3``) builds it the same way.
Action: ``Box`` (v, omega) within the robot's limits (a holonomic robot: (vx, vy) in the world frame); with
``normalize_actions=True`` a ``Box(-1, 1, (2,))`` mapped linearly onto those limits, as Stable-Baselines3 expects.
``render_mode``: ``"rgb_array"`` (``render()`` returns the frame; ``gymnasium.wrappers.RecordVideo`` records it) or
``"human"`` (a window, where a display exists).
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

from foresight.core.errors import ConfigError
from foresight.core.evaluation.episode import record_of
from foresight.core.evaluation.plannerspec import NO_MODEL, ResolvedPlanner
from foresight.core.runtime.refs import BUILTIN_CONFIG_ROOT
from foresight.core.scenarios.loader import load_matrix
from foresight.core.sim.observation import Observation
from foresight.core.sim.policy_observation import (
    ObservationLayout,
    action_bounds,
    command_of,
    policy_observation,
)
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


def _display() -> bool:
    import os

    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def route_length(obs: Observation) -> float:
    """Distance still to go along the route: robot -> current waypoint -> ... -> goal."""
    pts = np.vstack([obs.robot_pose[:2], obs.route])
    return float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum())


class CrowdNavEnv(gym.Env):
    """One robot among the simulated crowd of a scenario matrix; see the module docstring for the spaces."""

    #: "human" only where a display exists (gymnasium's check_env opens every mode listed)
    metadata = {"render_modes": ["rgb_array", *(["human"] if _display() else [])], "render_fps": 10}

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
        normalize_actions: bool = False,
        render_mode: str | None = None,
    ):
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            why = " (human needs a display: DISPLAY is not set)" if render_mode == "human" else ""
            raise ConfigError(
                f"expected one of {self.metadata['render_modes']} or None, got {render_mode!r}{why}",
                item="render_mode",
            )
        self.render_mode = render_mode
        self._view: Any = None
        self.matrix = load_matrix(Path(matrix))
        names = [scenario] if scenario else (scenarios or self.matrix.names)
        self.scenarios = [self.matrix.get(n) for n in names]
        self.max_steps, self.k, self.r = max_steps, int(max_peds), int(route_points)
        self.layout = ObservationLayout(
            max_peds=self.k,
            route_points=self.r,
            occupancy=occupancy,
            occupancy_size=occupancy_size,
            occupancy_resolution=occupancy_resolution,
        )
        self.reward_cfg = (
            reward if isinstance(reward, RewardConfig) else RewardConfig.model_validate(reward or {})
        )
        self.sim = Simulator()
        first = self.sim.reset(
            self.scenarios[0], 0, max_steps=max_steps
        )  # the robot's limits: the action space
        self.command_low, self.command_high = action_bounds(first.robot_limits)
        self.normalize_actions = bool(normalize_actions)
        if self.normalize_actions:
            self.action_space = spaces.Box(-1.0, 1.0, (2,), dtype=np.float32)
        else:
            self.action_space = spaces.Box(self.command_low, self.command_high, dtype=np.float32)
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
        self._last: Observation | None = (
            None  #: the latest observation, kept after the episode ended (render)
        )
        self._scenario = self.scenarios[0]
        self._seed = 0

    def _observe(self, obs: Observation) -> dict[str, np.ndarray]:
        return policy_observation(obs, self.layout)

    # ------------------------------------------------------------------ gymnasium API

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):  # noqa: ANN201
        super().reset(seed=seed)
        self._scenario = self.scenarios[int(self.np_random.integers(len(self.scenarios)))]
        self._seed = int(self.np_random.integers(2**31 - 1))
        self._obs = self._last = self.sim.reset(self._scenario, self._seed, max_steps=self.max_steps)
        if self._view is not None and self._view[0] is not self._scenario:
            self._view = None  # another scenario: another map
        self._left = route_length(self._obs)
        return self._observe(self._obs), {"scenario": self._scenario.name, "seed": self._seed, "step": 0}

    def step(self, action: Any):  # noqa: ANN201
        if self._obs is None:
            raise RuntimeError("call reset() before step()")
        command = command_of(action, self.command_low, self.command_high, self.normalize_actions)
        obs, events = self.sim.step(command)
        self._obs, self._last = obs, obs
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

    def render(self) -> np.ndarray | None:  # type: ignore[override]
        """The current frame as an (H, W, 3) uint8 array (``rgb_array``), or drawn in a window (``human``)."""
        if self.render_mode is None:
            return None
        if self._last is None:
            raise RuntimeError("call reset() before render()")
        if self._view is None:
            from foresight.core.render.live import LiveView

            self._view = (self._scenario, LiveView(self._scenario.map, title=self._scenario.name))
        frame = self._view[1].frame(self._last)
        if self.render_mode == "rgb_array":
            return frame
        self._view[1].show(frame, 1.0 / self.metadata["render_fps"])
        return None

    def close(self) -> None:
        self._view = None
        super().close()
