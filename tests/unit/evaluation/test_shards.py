"""Sharded evaluations and campaigns in core: the shards' merge equals the unsharded run, number for number."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import pytest
from pydantic import ValidationError

from foresight.core.errors import CoreError
from foresight.core.evaluation.campaign import run_campaign
from foresight.core.evaluation.config import (
    CampaignConfig,
    CampaignShardConfig,
    EvaluationConfig,
    EvaluationShardConfig,
)
from foresight.core.evaluation.runner import read_records, run_evaluation
from foresight.core.evaluation.shards import (
    merge_campaign_shards,
    merge_evaluation_shards,
    merge_records,
    read_shard,
    run_campaign_shard,
    run_evaluation_shard,
    shard_items,
)
from foresight.core.stages.context import StageContext
from foresight.core.stages.refs import BUILTIN_CONFIG_ROOT
from tests.results import without

#: wall-clock values: planner timing, run time, the code version (the git head moves while tests run)
NOISE = {"wall_s", "code_version", "fingerprint", "plan_ms_mean", "plan_ms_p95"}


def _strip(data: Any) -> Any:
    return without(data, NOISE)


def _ctx(root: Path, work: Path) -> StageContext:
    work.mkdir(parents=True, exist_ok=True)
    return StageContext(workdir=work, resolve_bundle=lambda _b: root)


def test_shard_slices_are_disjoint_and_cover_the_work_list() -> None:
    slices = [shard_items(10, i, 4) for i in range(4)]
    assert slices == [[0, 4, 8], [1, 5, 9], [2, 6], [3, 7]]
    assert shard_items(2, 3, 4) == []  # more shards than episodes: an empty shard
    with pytest.raises(ValidationError, match="shard index 4 is not below the shard count 4"):
        EvaluationShardConfig.model_validate({"shards": 4, "shard": {"index": 4, "count": 4}})
    with pytest.raises(ValidationError, match="shard count 3 differs from shards 4"):
        EvaluationShardConfig.model_validate({"shards": 4, "shard": {"index": 0, "count": 3}})
    with pytest.raises(ValidationError, match="shards"):
        EvaluationConfig.model_validate({"shards": 65})


def test_merged_evaluation_shards_equal_the_unsharded_evaluation(tmp_path: Path) -> None:
    base = dict(scenarios=["crossing_low", "head_on_corridor_high"], seeds_per_scenario=3, max_steps=30,
                planner={"name": "goal"})
    whole = run_evaluation(EvaluationConfig.model_validate(base), _ctx(BUILTIN_CONFIG_ROOT, tmp_path / "whole"))
    sharded = {**base, "shards": 4}
    parts = []
    for i in range(4):
        cfg = EvaluationShardConfig.model_validate({**sharded, "shard": {"index": i, "count": 4}})
        part = run_evaluation_shard(cfg, _ctx(BUILTIN_CONFIG_ROOT, tmp_path / f"shard{i}"))
        assert part.items == shard_items(6, i, 4) and part.episodes == len(part.items)
        parts.append(read_shard(tmp_path / f"shard{i}"))
    merged = merge_evaluation_shards(EvaluationConfig.model_validate(sharded), parts[::-1],  # any order
                                     _ctx(BUILTIN_CONFIG_ROOT, tmp_path / "merged"))
    a, b = whole.model_dump(mode="json"), merged.model_dump(mode="json")
    assert b["config"].pop("shards") == 4 and a["config"].pop("shards") == 1
    assert _strip(b) == _strip(a)
    assert merged.episodes == 6 and merged.aggregates.per_scenario[0].key == "crossing_low"
    r1 = read_records(tmp_path / "whole" / "episodes.jsonl")
    r2 = read_records(tmp_path / "merged" / "episodes.jsonl")
    assert [r.comparable() for r in r2] == [r.comparable() for r in r1]
    on_disk = json.loads((tmp_path / "merged" / "evaluation.json").read_text())
    assert on_disk["success_rate"] == whole.success_rate and on_disk["taxonomy"] == whole.taxonomy

    with pytest.raises(CoreError, match="shards miss 2 of 6 episodes"):
        merge_records(parts[1:], [(r.scenario, r.seed) for r in r1], parts[0][0].fingerprint, "evaluate")
    other = {**sharded, "max_steps": 31}
    with pytest.raises(CoreError, match="ran another work list"):
        merge_evaluation_shards(EvaluationConfig.model_validate(other), parts, _ctx(BUILTIN_CONFIG_ROOT, tmp_path / "x"))


@pytest.fixture()
def bundle(tmp_path: Path) -> Path:
    root = tmp_path / "bundle"
    shutil.copytree(BUILTIN_CONFIG_ROOT, root)
    (root / "hard.yaml").write_text("crossing_high: [3]\n")
    return root


def test_merged_campaign_shards_equal_the_unsharded_campaign(bundle: Path, tmp_path: Path) -> None:
    base = dict(bundle="t", seed_manifest="hard.yaml", scenarios=["crossing_low", "head_on_corridor_high"],
                seeds_per_scenario=1, max_steps=15, checkpoints=["cv"], gate={"baseline_variant": "base"},
                variants=[{"name": "base", "config": {}}, {"name": "careful", "config": {"max_speed_ratio": 0.5}}])
    whole = run_campaign(CampaignConfig.model_validate(base), _ctx(bundle, tmp_path / "whole"))
    sharded = {**base, "shards": 4}
    parts = []
    for i in range(4):  # 2 cells x 3 episodes: 6 items over 4 shards, cells split across shards
        cfg = CampaignShardConfig.model_validate({**sharded, "shard": {"index": i, "count": 4}})
        run_campaign_shard(cfg, _ctx(bundle, tmp_path / f"shard{i}"))
        parts.append(read_shard(tmp_path / f"shard{i}"))
    merged = merge_campaign_shards(CampaignConfig.model_validate(sharded), parts, _ctx(bundle, tmp_path / "merged"))
    a, b = whole.model_dump(mode="json", by_alias=True), merged.model_dump(mode="json", by_alias=True)
    assert b["config"].pop("shards") == 4 and a["config"].pop("shards") == 1
    assert _strip(b) == _strip(a)
    assert (merged.cells_run, merged.cells_resumed) == (2, 0) and merged.gate is not None
    assert [c.variant for c in merged.ranked] == [c.variant for c in whole.ranked]
    for cell in whole.ranked:  # the cell files an unsharded run writes (the report's A/B reads them)
        r1 = read_records(tmp_path / "whole" / cell.episodes_file)
        r2 = read_records(tmp_path / "merged" / cell.episodes_file)
        assert [r.comparable() for r in r2] == [r.comparable() for r in r1]
    assert (tmp_path / "merged" / "campaign_report.md").read_text() == (tmp_path / "whole" / "campaign_report.md").read_text()
