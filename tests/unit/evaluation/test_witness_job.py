"""core.evaluation.witness_job: what a witness job searches (plan_search), on the builtin classic matrix."""

from __future__ import annotations

from pathlib import Path

import pytest

from foresight.core.errors import ConfigError, NotFoundError
from foresight.core.evaluation.witness_job import MAX_SEARCHES, WitnessConfig, plan_search, run_witness
from foresight.core.runtime.context import StageContext
from foresight.core.runtime.refs import BUILTIN_BUNDLE, BUILTIN_CONFIG_ROOT


def _ctx(tmp_path: Path) -> StageContext:
    return StageContext(workdir=tmp_path, resolve_bundle=lambda b: {BUILTIN_BUNDLE: BUILTIN_CONFIG_ROOT}[b])


def test_a_shorter_horizon_is_searched_within_it(tmp_path: Path) -> None:
    config = dict(scenarios=["crossing_low"], seeds_per_scenario=1, settings={"max_plans": 30})
    whole = run_witness(WitnessConfig(**config), _ctx(tmp_path / "whole"))
    assert whole.matrix == "scenarios/classic_interactions.yaml" and not whole.failed_only
    (found,) = whole.episodes
    assert found.found and found.arrival_s > 6 and (tmp_path / "whole" / found.trace).is_file()
    (cut,) = run_witness(WitnessConfig(**config, max_steps=60), _ctx(tmp_path / "cut")).episodes
    assert (
        not cut.found and cut.plans == 1 and cut.trace is None
    )  # nothing arrives within 6 s: only the route as is


def test_what_cannot_be_searched_is_refused_before_any_search(tmp_path: Path) -> None:
    with pytest.raises(NotFoundError, match="no_such_scenario"):
        plan_search(WitnessConfig(scenarios=["no_such_scenario"]), _ctx(tmp_path))
    with pytest.raises(ConfigError, match=f"over the {MAX_SEARCHES}"):
        plan_search(WitnessConfig(seeds_per_scenario=1000), _ctx(tmp_path))
    # an evaluation is an id resolved by whoever runs the job; a path is not read where local files are refused
    (tmp_path / "episodes.jsonl").write_text("")
    closed = StageContext(workdir=tmp_path, local_files=False)
    with pytest.raises(NotFoundError, match="unknown evaluation run id"):
        plan_search(WitnessConfig(evaluation=str(tmp_path / "episodes.jsonl")), closed)
