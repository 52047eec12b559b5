"""``foresight/CrowdNav-v0``: passes gymnasium's env checker, resets deterministically, ends like an evaluation."""

from __future__ import annotations

import warnings

import gymnasium as gym
import numpy as np
from gymnasium.utils.env_checker import check_env

import foresight.core.gym  # noqa: F401 - registers the environment


def _rollout(env: gym.Env, seed: int, action: np.ndarray, steps: int) -> list[np.ndarray]:
    obs, _ = env.reset(seed=seed)
    out = [np.concatenate([v.ravel() for v in obs.values()])]
    for _ in range(steps):
        obs, _, terminated, truncated, _ = env.step(action)
        out.append(np.concatenate([v.ravel() for v in obs.values()]))
        if terminated or truncated:
            break
    return out


def test_check_env_passes_with_and_without_occupancy() -> None:
    for occupancy in (False, True):
        env = gym.make("foresight/CrowdNav-v0", scenario="crossing_low", occupancy=occupancy)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # advice (normalised action box), not failures
            check_env(env.unwrapped)
        assert env.observation_space.contains(env.reset(seed=0)[0])


def test_reset_with_a_seed_is_deterministic_and_seeds_differ() -> None:
    env = gym.make("foresight/CrowdNav-v0", scenarios=["crossing_low", "head_on_corridor_high"])
    action = np.array([0.8, 0.1], dtype=np.float32)
    a, b = _rollout(env, 7, action, 20), _rollout(env, 7, action, 20)
    assert len(a) == len(b) and all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    c = _rollout(env, 8, action, 20)
    assert len(c) != len(a) or not all(np.array_equal(x, y) for x, y in zip(a, c, strict=True))


def test_action_space_is_the_robot_limits_and_truncation_at_the_horizon() -> None:
    env = gym.make("foresight/CrowdNav-v0", scenario="crossing_low", max_steps=15)
    assert env.action_space.low.tolist() == [0.0, -1.0] and env.action_space.high.tolist() == [2.0, 1.0]
    env.reset(seed=1)
    rewards = []
    for _ in range(15):
        _, reward, terminated, truncated, info = env.step(np.zeros(2, dtype=np.float32))
        rewards.append(reward)
    assert truncated and not terminated and info["outcome"] == "timeout"
    assert info["record"]["outcome"] == "timeout" and info["record"]["steps"] == 15
    assert np.allclose(rewards, -0.01, atol=0.02)  # standing still: the time cost, no progress


def test_reaching_the_goal_terminates_with_the_success_bonus() -> None:
    env = gym.make("foresight/CrowdNav-v0", scenario="crossing_low")
    obs, _ = env.reset(seed=3)
    total, info, done = 0.0, {}, False
    while not done:
        goal = obs["route"][0]
        action = np.array([1.2, np.clip(1.5 * np.arctan2(goal[1], goal[0]), -1, 1)], dtype=np.float32)
        obs, reward, terminated, truncated, info = env.step(action)
        total, done = total + reward, terminated or truncated
    assert terminated and info["outcome"] == "success" and info["record"]["outcome"] == "success"
    assert total > 10.0  # progress along the route plus the bonus


def test_make_vec_runs_several_environments() -> None:
    envs = gym.make_vec(
        "foresight/CrowdNav-v0", num_envs=2, vectorization_mode="sync", scenario="crossing_low"
    )
    obs, _ = envs.reset(seed=0)
    assert obs["peds"].shape == (2, 8, 4)
    obs, reward, *_ = envs.step(np.tile(np.array([0.5, 0.0], dtype=np.float32), (2, 1)))
    assert reward.shape == (2,)
    envs.close()
