import numpy as np
import pytest

from foresight.core.errors import ConfigError
from foresight.core.predict.dataset import DatasetMeta, EpisodeRecord, load_dataset, save_dataset
from foresight.core.predict.mixing import assign_splits, dataset_from_episodes, mix_datasets
from foresight.core.predict.quality import check_quality
from foresight.core.predict.samples import samples_from_trace
from foresight.core.predict.timebase import PLANNER_TIMEBASE
from foresight.core.version import code_version
from tests.unit.predict.helpers import scripted_episode


def _dataset(n_episodes=6, seed=0, role="base", max_agents=4):
    splits = assign_splits(n_episodes, 0.34, seed)
    eps = []
    for i in range(n_episodes):
        trace, _, wps = scripted_episode(steps=60, seed=seed * 100 + i)
        eps.append(
            (
                EpisodeRecord(f"scn{i % 2}", 100 + i, splits[i], role),
                samples_from_trace(trace, PLANNER_TIMEBASE, max_agents, wps),
            )
        )
    meta = DatasetMeta(PLANNER_TIMEBASE, max_agents, "robot", "sim", [], generator={"seed": seed})
    return dataset_from_episodes(eps, meta)


def test_episode_split_is_disjoint_and_seeded():
    s = assign_splits(10, 0.2, 3)
    assert s.count("val") == 2 and s == assign_splits(10, 0.2, 3)
    assert assign_splits(2, 0.01, 0).count("val") == 1
    ds = _dataset()
    tr, va = ds.split_indices("train"), ds.split_indices("val")
    assert len(tr) and len(va) and not set(ds.episode[tr]) & set(ds.episode[va])
    assert len(tr) + len(va) == len(ds)


def test_save_load_round_trip_with_metadata(tmp_path):
    ds = _dataset()
    rec = save_dataset(ds, tmp_path / "d.npz")
    back = load_dataset(tmp_path / "d.npz")
    np.testing.assert_array_equal(back.state, ds.state)
    assert back.meta.timebase == PLANNER_TIMEBASE and back.meta.code_version == code_version()
    assert back.meta.episodes[0].scenario == "scn0" and back.meta.episodes[0].seed == 100
    assert (tmp_path / "d.json").is_file() and rec["summary"]["samples"] == len(ds)
    assert len(back.meta.generator_config_hash) == 16 and back.meta.feature_names[0] == "px[-4]"


def test_load_rejects_wrong_schema(tmp_path):
    ds = _dataset(n_episodes=2)
    ds.meta.schema_version = "other/9"
    save_dataset(ds, tmp_path / "d.npz")
    with pytest.raises(ConfigError, match="schema"):
        load_dataset(tmp_path / "d.npz")


def test_mix_oversamples_train_rows_only_after_split():
    base, hard = _dataset(seed=0), _dataset(seed=1, role="hardcase")
    mixed = mix_datasets(base, hard, hardcase_repeat=3)
    hard_val = len(hard.split_indices("val"))
    hard_train = len(hard.split_indices("train"))
    assert len(mixed) == len(base) + 3 * hard_train + hard_val
    va = mixed.split_indices("val")
    assert len(va) == len(base.split_indices("val")) + hard_val  # no duplicates in validation
    assert len(np.unique(mixed.state[va].reshape(len(va), -1), axis=0)) == len(va)
    assert not set(mixed.episode[va]) & set(mixed.episode[mixed.split_indices("train")])
    assert mixed.meta.episodes[-1].role == "hardcase"


def test_mix_rejects_incompatible():
    with pytest.raises(ConfigError, match="max_agents"):
        mix_datasets(_dataset(max_agents=4), _dataset(max_agents=3), 2)


def test_degenerate_data_fails_fast():
    ds = _dataset()
    check_quality(ds, "d.npz")
    zero = ds.subset(np.arange(len(ds)))
    zero.target_mask = np.zeros_like(zero.target_mask)
    with pytest.raises(ConfigError, match="no usable targets"):
        check_quality(zero, "d.npz")
    still = ds.subset(np.arange(len(ds)))
    still.target = np.ones_like(still.target)
    with pytest.raises(ConfigError, match="constant"):
        check_quality(still, "d.npz")
    with pytest.raises(ConfigError, match="samples"):
        check_quality(ds.subset(np.arange(3)), "d.npz")
