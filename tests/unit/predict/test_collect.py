import shutil

import numpy as np
import pytest

from foresight.core.errors import ConfigError
from foresight.core.predict.dataset import load_dataset
from foresight.core.runtime.context import StageContext
from foresight.core.runtime.refs import BUILTIN_CONFIG_ROOT
from foresight.core.training.collect import CollectConfig, MixConfig, episode_list, run_collect, run_mix


def _ctx(path):
    return StageContext(workdir=path, resolve_bundle=lambda ident: BUILTIN_CONFIG_ROOT)


def test_base_seeds_are_derived_deterministically():
    class M:
        names = ["a", "b"]

        def get(self, n):
            return n

    jobs = episode_list(CollectConfig(seeds_per_scenario=2, base_seed=7), M())
    assert jobs == [("a", 7, "base"), ("a", 8, "base"), ("b", 100007, "base"), ("b", 100008, "base")]


def test_collect_and_mix_from_the_simulator(tmp_path):
    cfg = CollectConfig(
        scenarios=["crossing_high"],
        seeds_per_scenario=3,
        max_steps=80,
        check_quality=False,
        val_fraction=0.34,
    )
    res = run_collect(cfg, _ctx(tmp_path / "base"))
    ds = load_dataset(tmp_path / "base" / res.dataset)
    assert [e.seed for e in ds.meta.episodes] == [50_000, 50_001, 50_002]
    assert sum(e.split == "val" for e in ds.meta.episodes) == 1
    assert ds.meta.source == "sim" and ds.meta.frame_convention == "robot" and len(ds) > 0
    assert np.all(ds.target_mask <= ds.mask[..., None])
    hard_root = tmp_path / "bundle"
    hard_root.mkdir()
    (hard_root / "hard.yaml").write_text("crossing_high: [5, 6]\n")
    for sub in ("scenarios", "maps"):
        shutil.copytree(BUILTIN_CONFIG_ROOT / sub, hard_root / sub)
    hard_cfg = CollectConfig(
        hard_seeds="hard.yaml", max_steps=80, check_quality=False, val_fraction=0.5, output="hard.npz"
    )
    ctx = StageContext(workdir=tmp_path / "hard", resolve_bundle=lambda ident: hard_root)
    run_collect(hard_cfg, ctx)
    hard = load_dataset(tmp_path / "hard" / "hard.npz")
    assert [(e.scenario, e.seed, e.role) for e in hard.meta.episodes] == [
        ("crossing_high", 5, "hardcase"),
        ("crossing_high", 6, "hardcase"),
    ]
    mix = run_mix(
        MixConfig(
            base=str(tmp_path / "base" / res.dataset),
            hardcase=str(tmp_path / "hard" / "hard.npz"),
            hardcase_repeat=2,
        ),
        _ctx(tmp_path / "mix"),
    )
    mixed = load_dataset(tmp_path / "mix" / mix.dataset)
    assert len(mixed) == len(ds) + 2 * len(hard.split_indices("train")) + len(hard.split_indices("val"))
    assert [r["role"] for r in mixed.meta.lineage] == ["base", "hardcase"]


def test_planner_policy_needs_a_name(tmp_path):
    with pytest.raises(ConfigError, match="planner.name"):
        run_collect(
            CollectConfig(scenarios=["crossing_high"], seeds_per_scenario=1, policy="planner", planner={}),
            _ctx(tmp_path),
        )


def test_evaluation_episodes_are_refused(tmp_path):
    root = tmp_path / "bundle"
    for sub in ("scenarios", "maps"):
        shutil.copytree(BUILTIN_CONFIG_ROOT / sub, root / sub)
    (root / "eval.yaml").write_text("crossing_high: [50001]\n")
    cfg = CollectConfig(scenarios=["crossing_high"], seeds_per_scenario=2, evaluation_seeds="eval.yaml")
    with pytest.raises(ConfigError, match="evaluation episodes"):
        run_collect(cfg, StageContext(workdir=tmp_path / "out", resolve_bundle=lambda ident: root))
