"""Campaign ranking order, resume (finished cells are not run again), gate pass/fail as results."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from foresight.core.errors import ConfigError
from foresight.core.evaluation.aggregate import BootstrapConfig, summarise
from foresight.core.evaluation.campaign import rank, ranking_key, run_campaign
from foresight.core.evaluation.campaign_result import CellResult
from foresight.core.evaluation.config import CampaignConfig
from foresight.core.evaluation.evaluation_result import PlannerProvenance
from foresight.core.evaluation.integrity import check_integrity
from foresight.core.runtime.context import StageContext
from foresight.core.runtime.refs import BUILTIN_CONFIG_ROOT

from .traces import record

BOOT = BootstrapConfig(samples=50)


def _cell(name: str, hard: list, glob: list, ok: bool = True) -> CellResult:
    h, g = summarise(hard, BOOT), summarise(glob, BOOT)
    prov = PlannerProvenance(
        name="predictive", variant=name, config={}, config_hash="h", model_id="cv", checkpoint_sha256="cv"
    )
    return CellResult(
        key=name,
        fingerprint="f",
        checkpoint="cv",
        variant=name,
        planner=prov,
        hard=h,
        global_=g,
        integrity=check_integrity([]),
        ranking_key=ranking_key(h, g, ok),
        episodes_file="x",
    )


def test_ranking_is_lexicographic_in_the_reference_order() -> None:
    ok, fail = record("a_low", 1), record("a_low", 1, "timeout", speed=0.5)
    near, far = record("a_low", 1, ped_y=1.0), record("a_low", 1, ped_y=3.0)
    slow = record("a_low", 1, ped_y=3.0, speed=0.5)
    cells = [
        _cell("global_only", [fail], [ok, ok]),  # worse hard success, better global
        _cell("hard_best", [ok], [ok, fail]),  # hard success dominates
        _cell("hard_best_close", [near], [ok, fail]),  # same successes, lower hard clearance
        _cell("hard_best_far", [far], [ok, fail]),  # same, higher hard clearance
        _cell("far_slow", [far], [ok, slow]),  # ...
        _cell("broken", [ok], [ok, ok], ok=False),  # integrity violations rank last
    ]
    order = [c.variant for c in rank(cells)]
    assert order == ["far_slow", "hard_best_far", "hard_best", "hard_best_close", "global_only", "broken"]


def test_global_speed_breaks_the_last_tie() -> None:
    fast, slow = record("a_low", 1, ped_y=3.0), record("a_low", 1, ped_y=3.0, speed=0.5)
    cells = [_cell("slow", [fast], [slow]), _cell("fast", [fast], [fast])]
    assert [c.variant for c in rank(cells)] == ["fast", "slow"]


@pytest.fixture()
def bundle(tmp_path: Path) -> Path:
    root = tmp_path / "bundle"
    shutil.copytree(BUILTIN_CONFIG_ROOT, root)
    (root / "hard.yaml").write_text("crossing_high: [3]\n")
    return root


def _config(**kw) -> CampaignConfig:
    base = dict(
        bundle="t",
        seed_manifest="hard.yaml",
        scenarios=["crossing_low", "head_on_corridor_high"],
        seeds_per_scenario=1,
        max_steps=15,
        checkpoints=["cv"],
        variants=[{"name": "base", "config": {}}, {"name": "careful", "config": {"max_speed_ratio": 0.5}}],
    )
    base.update(kw)
    return CampaignConfig.model_validate(base)


def _ctx(root: Path, work: Path) -> StageContext:
    work.mkdir(parents=True, exist_ok=True)
    return StageContext(workdir=work, resolve_bundle=lambda _b: root)


def test_campaign_runs_ranks_and_resumes(bundle: Path, tmp_path: Path) -> None:
    work = tmp_path / "run"
    first = run_campaign(_config(), _ctx(bundle, work))
    assert (first.cells_run, first.cells_resumed) == (2, 0)
    assert first.hard_episodes == 1 and first.global_episodes == 2
    summary = json.loads((work / "campaign_summary.json").read_text())
    assert summary["best"]["variant"] == first.ranked[0].variant
    assert "global" in summary["ranked"][0] and summary["ranked"][0]["planner"]["config"]
    assert (work / "campaign_report.md").read_text().startswith("# Planner campaign")
    # every cell is compared pair by pair with the baseline (first) variant on the same episodes
    careful = next(c for c in first.ranked if c.variant == "careful")
    base = next(c for c in first.ranked if c.variant == "base")
    assert base.vs_baseline is None and careful.baseline == base.key
    hard = careful.vs_baseline["hard"]["success"]
    assert hard.method == "paired" and hard.n_pairs == 1 and not hard.significant  # 1 pair: never marked
    assert careful.vs_baseline["global"]["min_clearance"].n_pairs == 2
    # and names the episodes that ended otherwise: those where one side succeeded are McNemar's discordant pairs
    assert set(careful.changed_vs_baseline) == {"hard", "global"} and base.changed_vs_baseline is None
    for suite, changed_eps in careful.changed_vs_baseline.items():
        flips = [e for e in changed_eps if (e.a == "success") != (e.b == "success")]
        assert len(flips) == sum(careful.vs_baseline[suite]["success"].discordant or (0, 0))
    assert "Paired against the baseline cell" in (work / "campaign_report.md").read_text()
    # each cell is a run folder like an evaluation's: its episodes and every one's trace, so it compares locally
    from foresight.core.evaluation.compare import compare, load_run
    from foresight.core.render.episode_trace import read_compact, trace_name

    assert first.suites == {
        "hard": [("crossing_high", 3)],
        "global": [("crossing_low", 1000), ("head_on_corridor_high", 1200)],
    }
    for cell in first.ranked:
        label, recs = load_run(work / cell.run_dir)
        assert label == cell.variant and {(r.scenario, r.seed) for r in recs} == {
            *first.suites["hard"],
            *first.suites["global"],
        }
        for r in recs:
            assert (
                len(read_compact(work / cell.run_dir / trace_name(r.scenario, r.seed))["frames"])
                == r.steps + 1
            )
    local = compare(
        {"base": load_run(work / base.run_dir)[1], "careful": load_run(work / careful.run_dir)[1]}, "base"
    )
    assert local.changed["careful"] == [
        *careful.changed_vs_baseline["global"],
        *careful.changed_vs_baseline["hard"],
    ]
    again = run_campaign(_config(), _ctx(bundle, work))
    assert (again.cells_run, again.cells_resumed) == (0, 2)
    assert [c.model_dump() for c in again.ranked] == [c.model_dump() for c in first.ranked]
    changed = _config(
        variants=[{"name": "base", "config": {}}, {"name": "careful", "config": {"max_speed_ratio": 0.4}}]
    )
    third = run_campaign(changed, _ctx(bundle, work))
    assert (third.cells_run, third.cells_resumed) == (1, 1)  # only the changed variant runs again


def test_gate_pass_and_fail_are_results(bundle: Path, tmp_path: Path) -> None:
    work = tmp_path / "run"
    ok = run_campaign(
        _config(gate={"baseline_variant": "base", "max_clearance_regression": 100.0}), _ctx(bundle, work)
    )
    assert ok.status == "passed" and ok.exit_code == 0 and ok.gate is not None
    # demanding +50 points of global success over the baseline cannot pass: a result with exit code 2
    bad = run_campaign(
        _config(gate={"baseline_variant": "base", "min_global_success_delta": 0.5}), _ctx(bundle, work)
    )
    assert bad.status == "failed_gate" and bad.exit_code == 2
    assert bad.cells_resumed == 2  # the gate is re-evaluated on finished cells
    data = json.loads((work / "campaign_summary.json").read_text())
    assert data["gate"]["passed"] is False and data["status"] == "failed_gate"
    # a significant paired gain cannot be shown on 2 global episodes: the gate says so instead of passing
    gain = run_campaign(
        _config(
            gate={
                "baseline_variant": "base",
                "max_clearance_regression": 100.0,
                "require_significant_gain": "global",
            }
        ),
        _ctx(bundle, work),
    )
    check = next(c for c in gain.gate.checks if c.name == "global_significant_success_gain")
    assert not check.passed and gain.status == "failed_gate"


def test_unknown_baseline_and_bad_grid_fail_before_running(bundle: Path, tmp_path: Path) -> None:
    with pytest.raises(ConfigError):
        run_campaign(_config(gate={"baseline_variant": "nope"}), _ctx(bundle, tmp_path / "a"))
    (bundle / "grid.yaml").write_text("variants:\n  - name: x\n    params: {predictive_unknown_key: 1}\n")
    with pytest.raises(ConfigError):
        run_campaign(_config(variants=None, grid="grid.yaml"), _ctx(bundle, tmp_path / "b"))
    assert not (tmp_path / "b" / "cells").exists()


def test_config_diff_is_key_by_key() -> None:
    from foresight.core.evaluation.plannerspec import config_diff

    a = {"w": {"goal": 1.0, "ttc": 0.3}, "speed": 1.0, "only_a": 1}
    b = {"w": {"goal": 1.0, "ttc": 0.5}, "speed": 1.0}
    assert config_diff(a, b) == {"w.ttc": (0.3, 0.5), "only_a": (1, None)}


def test_a_variant_written_with_the_planners_old_keys_overrides_a_base_in_todays_keys() -> None:
    """Stored campaign specs name the predictive planner's settings by their flat keys of before the nesting; a
    base planner config in today's keys (a spec that went through validation once) still takes each override."""
    from foresight.core.evaluation.config import GridVariant, variant_spec
    from foresight.core.evaluation.plannerspec import planner_spec

    base = planner_spec(
        planner_spec(name="predictive", config={"safety": {"pedestrians": {"confidence": 2.0}}})
    )
    base = planner_spec(base.model_dump())  # every key set, as after a round trip through a stored spec
    old = GridVariant(
        name="v", config={"safety": {"confidence": 0.5, "yield_speed": 0.0}, "weights": {"ttc": 9}}
    )
    spec = variant_spec(base, old, None)
    assert spec.config.safety.pedestrians.confidence == 0.5 and spec.config.safety.crowd.yielding.speed == 0.0
    assert (
        spec.config.weights.pedestrians.ttc == 9.0 and spec.config.safety.pedestrians.collision_margin == 0.1
    )
    with pytest.raises(ConfigError) as exc:
        variant_spec(base, GridVariant(name="w", config={"safety": {"confidance": 0.5}}), None)
    assert exc.value.item == "planner.predictive.config.safety.confidance"
