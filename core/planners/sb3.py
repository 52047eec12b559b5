"""Planner ``sb3``: a policy trained with Stable-Baselines3 in ``foresight/CrowdNav-v0``, driven like any planner.

Its observation is the env's, built by the same function (``core.sim.policy_observation``); its shape (nearest
pedestrians, route points, occupancy grid) and whether actions are normalised to [-1, 1] are read from the saved
policy's own spaces, so a policy runs as it was trained. The policy file (SB3's ``.zip``) is named in the config:
a path inside a config bundle (``bundle``, default ``builtin``: upload a folder holding it) or, in-process
(``--local``, ``foresight.evaluate``), a local file. Its sha256 is recorded as the episode's checkpoint checksum.
Needs the ``sb3`` extra (``pip install 'foresight[sb3]'``); docs/tutorials/sb3.md trains one.
"""

from __future__ import annotations

import threading
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from foresight.core.errors import ConfigError
from foresight.core.runtime.refs import BUILTIN_BUNDLE, Ident, resolve_in_bundle
from foresight.core.sim.observation import Observation
from foresight.core.sim.planner import EpisodeInfo
from foresight.core.sim.policy_observation import (
    ObservationLayout,
    action_bounds,
    command_of,
    policy_observation,
)

ALGORITHMS = ("PPO", "A2C", "SAC", "TD3", "DDPG")


class SB3Config(BaseModel):
    """Which policy file, how it was trained, how it acts."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    policy: str = Field(min_length=1, max_length=500)  #: a path in ``bundle`` (in-process: also a local file)
    bundle: Ident = BUILTIN_BUNDLE
    algorithm: Literal["PPO", "A2C", "SAC", "TD3", "DDPG"] = "PPO"
    deterministic: bool = True  #: the policy's mean action (False: sample, as in training)
    occupancy_resolution: float = Field(
        default=0.5, gt=0
    )  #: the env's, when the policy sees an occupancy grid


def policy_file(config: SB3Config, ctx: Any) -> tuple[str, Path]:
    """(the id records name it by, its file): a local file in-process, else the bundle's."""
    local = Path(config.policy).expanduser()
    if getattr(ctx, "local_files", False) and local.is_file():
        return f"sb3:{local.name}", local.resolve()
    try:
        path = resolve_in_bundle(ctx.resolve_bundle(config.bundle), config.policy)
    except ValueError as exc:
        raise ConfigError(str(exc), item="planner.config.policy") from None
    if not path.is_file():
        raise ConfigError(
            f"no file {config.policy!r} in config bundle {config.bundle!r}", item="planner.config.policy"
        )
    return f"sb3:{config.bundle}/{config.policy}", path


_POLICIES: dict[tuple[str, str, str], Any] = {}  #: (path, sha256, algorithm) -> loaded policy, per process
_LOCK = threading.Lock()


def load_policy(path: str, sha256: str, algorithm: str = "PPO") -> Any:
    """The saved policy, loaded once per process and file content, on the CPU."""
    key = (path, sha256, algorithm)
    with _LOCK:
        if key not in _POLICIES:
            try:
                import stable_baselines3
            except ImportError:
                raise ConfigError(
                    "planner sb3 needs the sb3 extra: pip install 'foresight[sb3]'", item="planner"
                ) from None
            try:
                _POLICIES[key] = getattr(stable_baselines3, algorithm).load(path, device="cpu")
            except Exception as exc:  # noqa: BLE001 - SB3 raises many kinds for a file that is not its zip
                raise ConfigError(
                    f"not a Stable-Baselines3 {algorithm} policy ({exc})", item="planner.config.policy"
                ) from None
    return _POLICIES[key]


def layout_of(model: Any, occupancy_resolution: float) -> tuple[ObservationLayout, bool]:
    """(the observation layout, whether actions are normalised) the policy was trained with, from its spaces."""
    spaces = model.observation_space.spaces
    missing = {"robot", "goal", "route", "peds", "ped_mask"} - set(spaces)
    if missing:
        raise ConfigError(
            f"the policy was not trained on foresight/CrowdNav-v0 observations (no {sorted(missing)})",
            item="planner.config.policy",
        )
    occupancy = spaces.get("occupancy")
    layout = ObservationLayout(
        max_peds=int(spaces["peds"].shape[0]),
        route_points=int(spaces["route"].shape[0]),
        occupancy=occupancy is not None,
        occupancy_size=int(occupancy.shape[0]) if occupancy is not None else 16,
        occupancy_resolution=occupancy_resolution,
    )
    box = model.action_space
    normalized = bool(np.allclose(box.low, -1.0) and np.allclose(box.high, 1.0))
    return layout, normalized


class SB3Planner:
    """Each step: the env's observation of the simulator's, the policy's action, the robot's command."""

    name = "sb3"

    def __init__(self, config: SB3Config, model: Any):
        if model is None:
            raise ConfigError("planner sb3 needs its policy (resolve the planner spec first)", item="planner")
        self.config, self.model = config, model
        self.layout, self.normalized = layout_of(model, config.occupancy_resolution)
        self._bounds: tuple[np.ndarray, np.ndarray] | None = None

    def reset(self, info: EpisodeInfo) -> None:
        self._bounds = None

    def plan(self, obs: Observation) -> tuple[float, float]:
        if self._bounds is None:
            self._bounds = action_bounds(obs.robot_limits)
        action, _ = self.model.predict(
            policy_observation(obs, self.layout), deterministic=self.config.deterministic
        )
        return command_of(action, *self._bounds, self.normalized)

    @property
    def diagnostics(self) -> dict[str, Any] | None:
        return None

    def finish(self, outcome: str) -> None:
        pass
