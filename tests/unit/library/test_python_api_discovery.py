"""The Python API as a notebook finds it: completion offers evaluate/simulate, and a result without ``out`` names
its files where they are."""

from __future__ import annotations

import json
from pathlib import Path

import foresight


def test_dir_offers_the_lazy_functions() -> None:
    assert {"evaluate", "simulate", "__version__"} <= set(dir(foresight))


def test_artifacts_of_a_run_without_out_are_paths_that_exist() -> None:
    result = foresight.evaluate("social_force", scenarios=["crossing_low"], seeds=1, max_steps=20)
    episodes = Path(result.artifacts["episodes"])
    assert episodes.is_absolute() and episodes.is_file() and Path(result.artifacts["summary"]).is_file()
    assert json.loads(episodes.read_text().splitlines()[0])["planner"] == "social_force"
