"""The env as an RL loop needs it: frames for RecordVideo (``render_mode="rgb_array"``), a normalised [-1, 1]
action space mapped onto the robot's limits, and the observation a planner rebuilds with the same public function."""

from __future__ import annotations

import warnings
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from gymnasium.wrappers import RecordVideo

import foresight.core.gym  # noqa: F401 - registers the environment
from foresight.core.errors import ConfigError
from foresight.core.sim.policy_observation import policy_observation


def test_rgb_array_frames_recorded_by_record_video(tmp_path: Path) -> None:
    env = gym.make("foresight/CrowdNav-v0", scenario="crossing_low", max_steps=25, render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3 and frame.shape[0] > 100
    moved = [frame]
    for _ in range(10):
        env.step(np.array([1.0, 0.0], dtype=np.float32))
        moved.append(env.render())
    assert not np.array_equal(moved[0], moved[-1])  # the robot and the crowd move between frames

    video = RecordVideo(
        gym.make("foresight/CrowdNav-v0", scenario="crossing_low", max_steps=25, render_mode="rgb_array"),
        str(tmp_path / "videos"),
        disable_logger=True,
    )
    video.reset(seed=1)
    done = False
    while not done:
        _, _, terminated, truncated, _ = video.step(video.action_space.sample())
        done = terminated or truncated
    video.close()
    (mp4,) = (tmp_path / "videos").glob("*.mp4")
    assert mp4.stat().st_size > 1000 and mp4.read_bytes()[4:8] == b"ftyp"


def test_unknown_render_mode_is_refused() -> None:
    with pytest.raises(ConfigError, match="render_mode"):
        gym.make("foresight/CrowdNav-v0", scenario="crossing_low", render_mode="ascii")


def test_normalised_actions_map_onto_the_robots_limits() -> None:
    plain = gym.make("foresight/CrowdNav-v0", scenario="crossing_low").unwrapped
    norm = gym.make("foresight/CrowdNav-v0", scenario="crossing_low", normalize_actions=True).unwrapped
    assert np.all(norm.action_space.low == -1) and np.all(norm.action_space.high == 1)
    with warnings.catch_warnings():
        warnings.simplefilter(
            "error"
        )  # check_env warns about an action box that is not symmetric and normalised
        check_env(norm)
    low, high = plain.action_space.low, plain.action_space.high
    for a_norm, a_plain in (([1, 1], high), ([-1, -1], low), ([0, 0], (low + high) / 2)):
        plain.reset(seed=3)
        norm.reset(seed=3)
        o1 = plain.step(np.array(a_plain, dtype=np.float32))[0]
        o2 = norm.step(np.array(a_norm, dtype=np.float32))[0]
        assert all(np.allclose(o1[k], o2[k]) for k in o1)


def test_the_envs_observation_is_the_public_functions() -> None:
    env = gym.make("foresight/CrowdNav-v0", scenario="crossing_low", occupancy=True, max_peds=5).unwrapped
    obs, _ = env.reset(seed=2)
    again = policy_observation(env._last, env.layout)
    assert obs.keys() == again.keys() and all(np.array_equal(obs[k], again[k]) for k in obs)
