"""A policy trained in foresight/CrowdNav-v0 is diagnosed and campaigned like any planner (`--planner sb3:FILE`):
a tiny PPO policy (one rollout) saved, then `diagnose --local` and `campaign --local` run it and name it."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from .service import REPO

pytest.importorskip("stable_baselines3")
pytestmark = pytest.mark.slow

TRAIN = """
import gymnasium as gym
from stable_baselines3 import PPO

import foresight.core.gym

env = gym.make("foresight/CrowdNav-v0", scenarios=["crossing_low"], max_steps=50, normalize_actions=True)
PPO("MultiInputPolicy", env, n_steps=64, batch_size=32, seed=0, verbose=0).learn(total_timesteps=64).save("p.zip")
"""
SEEDS = "configs/seeds/classic_eval_hard_smoke.yaml"


def _cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "foresight.cli.main", *args],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=300,
    )


def test_a_trained_policy_is_diagnosed_and_campaigned(tmp_path: Path) -> None:
    done = subprocess.run(
        [sys.executable, "-c", TRAIN], cwd=tmp_path, capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr[-3000:]
    policy = f"sb3:{tmp_path / 'p.zip'}"
    common = [
        "--local",
        "--planner",
        policy,
        "--matrix",
        "configs/scenarios/classic_interactions.yaml",
        "--seeds",
        SEEDS,
        "--max-steps",
        "20",
        "--json",
    ]

    diagnosed = _cli("diagnose", *common, "--no-render", "--out", str(tmp_path / "d"))
    assert diagnosed.returncode == 0, diagnosed.stderr[-3000:]
    result = json.loads(diagnosed.stdout)["result"]
    assert result["planner"]["name"] == "sb3" and result["planner"]["model_id"] == "sb3:p.zip"
    assert result["episodes"] == 6  # every seed of the manifest traced

    (tmp_path / "grid.yaml").write_text("variants:\n  - name: base\n    config: {}\n")
    campaigned = _cli(
        "campaign",
        *common,
        "--grid",
        str(tmp_path / "grid.yaml"),
        "--scenarios",
        "crossing_low",
        "--seeds-per-scenario",
        "1",
        "--out",
        str(tmp_path / "c"),
    )
    assert campaigned.returncode == 0, campaigned.stderr[-3000:]
    (cell,) = json.loads(campaigned.stdout)["result"]["ranked"]
    assert cell["variant"] == "base" and cell["planner"]["name"] == "sb3"
    assert (
        cell["planner"]["checkpoint_sha256"]
        == json.loads(diagnosed.stdout)["result"]["planner"]["checkpoint_sha256"]
    )
