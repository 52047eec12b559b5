"""Seed manifests: training and evaluation hard seeds never meet; the mining reproduces the shipped files."""

from __future__ import annotations

import itertools
import re

import pytest

from foresight.core.errors import ConfigError
from foresight.core.jobs.pipeline.seeds import (
    EVALUATION_SEED_MAX,
    TRAINING_SEED_MIN,
    mine_failures,
    parse_seed_range,
    read_manifest_pairs,
)
from foresight.core.runtime.refs import BUILTIN_CONFIG_ROOT
from foresight.core.scenarios.loader import load_matrix
from foresight.core.scenarios.seeds import load_seed_manifest

SEEDS = BUILTIN_CONFIG_ROOT / "seeds"
MATRIX = BUILTIN_CONFIG_ROOT / "scenarios" / "classic_interactions.yaml"
TRAINING = sorted(SEEDS.glob("classic_train_hard*.yaml"))
EVALUATION = sorted(SEEDS.glob("classic_eval_hard*.yaml"))


def test_there_are_training_and_evaluation_manifests() -> None:
    assert {p.name for p in TRAINING} >= {
        "classic_train_hard.yaml",
        "classic_train_hard_quick.yaml",
        "classic_train_hard_smoke.yaml",
    }
    assert {p.name for p in EVALUATION} >= {
        "classic_eval_hard.yaml",
        "classic_eval_hard_quick.yaml",
        "classic_eval_hard_smoke.yaml",
    }


@pytest.mark.parametrize(
    ("train", "evaluation"), list(itertools.product(TRAINING, EVALUATION)), ids=lambda p: p.stem
)
def test_training_and_evaluation_manifests_are_disjoint(train, evaluation) -> None:  # noqa: ANN001
    assert not read_manifest_pairs(train) & read_manifest_pairs(evaluation)


def test_manifests_load_against_the_matrix_and_sit_in_their_seed_ranges() -> None:
    matrix = load_matrix(MATRIX)
    own = {(n, s) for n in matrix.names for s in matrix.get(n).scenario.seeds}
    for path in TRAINING:
        manifest = load_seed_manifest(path, matrix)
        assert len(manifest) > 0
        assert all(seed >= TRAINING_SEED_MIN for _, seed in manifest.pairs()), path
        assert not set(manifest.pairs()) & own  # never an evaluation seed of the matrix
    for path in EVALUATION:
        manifest = load_seed_manifest(path, matrix)
        assert all(seed <= EVALUATION_SEED_MAX for _, seed in manifest.pairs()), path
        assert set(manifest.pairs()) <= own  # mined from the seeds evaluations run


def test_quick_and_smoke_manifests_are_subsets_of_the_full_ones() -> None:
    for kind in ("train", "eval"):
        full = read_manifest_pairs(SEEDS / f"classic_{kind}_hard.yaml")
        for size in ("quick", "smoke"):
            assert read_manifest_pairs(SEEDS / f"classic_{kind}_hard_{size}.yaml") <= full


def test_each_manifest_says_how_it_was_mined() -> None:
    for path in [*TRAINING, *EVALUATION]:
        assert re.search(
            r"^# Mined by: foresight pipeline mine-seeds .*--baseline social_force", path.read_text(), re.M
        )


def test_mining_is_deterministic_and_keeps_to_its_range_and_exclusions() -> None:
    """The same call mines the same seeds (the baseline draws only from the episode seed). The shipped files are
    not compared: they were mined at one simulator version and stay fixed when the simulator changes."""
    names = ["crossing_medium", "doorway_medium"]
    kwargs = dict(seeds=range(20000, 20012), baseline="social_force", per_scenario=2, scenarios=names)
    first = mine_failures(MATRIX, **kwargs)
    assert first == mine_failures(MATRIX, **kwargs)
    assert all(len(v) <= 2 and all(20000 <= s < 20012 for s in v) for v in first.values())
    excluded = {(n, s) for n, v in first.items() for s in v}
    again = mine_failures(MATRIX, **kwargs, exclude=excluded)
    assert not {(n, s) for n, v in again.items() for s in v} & excluded


def test_seed_ranges_parse() -> None:
    assert parse_seed_range("20000:20003") == [20000, 20001, 20002]
    assert parse_seed_range("5, 7") == [5, 7]
    for bad in ("3:3", "x:4", "-1:4"):
        with pytest.raises(ConfigError):
            parse_seed_range(bad)
    with pytest.raises(ConfigError):
        mine_failures(MATRIX, seeds=[1], baseline="predictive")


def test_stress_selection_manifests_are_training_seeds_only() -> None:
    """The pipelines select models on these: subsets of stress_train.yaml, never a stress.yaml seed."""
    stress = load_matrix(BUILTIN_CONFIG_ROOT / "scenarios" / "stress.yaml")
    own = {(n, s) for n in stress.names for s in stress.get(n).scenario.seeds}
    full = read_manifest_pairs(SEEDS / "stress_train.yaml")
    for size, minimum in (("quick", 30), ("smoke", 3)):
        pairs = set(load_seed_manifest(SEEDS / f"stress_train_{size}.yaml", stress).pairs())
        assert len(pairs) >= minimum and pairs <= full and not pairs & own


def test_reference_replication_seeds_are_the_ten_after_the_measured_ones(reference_matrix_path) -> None:  # noqa: ANN001
    """Every scenario of the reference's matrix, 10 seeds each, none of the 10 that ``--seeds-per-scenario 10`` runs
    (where the navigation targets' numbers were measured and the planner tuned), none a training seed."""
    from foresight.core.evaluation.runner import expand_seeds

    matrix = load_matrix(reference_matrix_path)
    manifest = load_seed_manifest(SEEDS / "reference_replication.yaml", matrix)
    assert set(manifest.scenario_names) == set(matrix.names)
    training = set().union(*(read_manifest_pairs(p) for p in TRAINING))
    for s in matrix.scenarios:
        seeds = manifest.seeds[s.name]
        assert len(set(seeds)) == 10 and not set(seeds) & set(expand_seeds(tuple(s.scenario.seeds), 10))
        assert not {(s.name, x) for x in seeds} & training
