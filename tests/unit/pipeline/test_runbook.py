"""The runbook with a fake run_child: wiring between stages, the gate verdict, the summary, resume."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from foresight.core.errors import ConfigError
from foresight.core.evaluation.runner import write_records
from foresight.core.jobs.pipeline.config import (
    GatesSection,
    PipelineConfig,
    load_pipeline_config,
    stage_config,
)
from foresight.core.jobs.pipeline.runbook import ChildRun, StageFailed, check_seed_separation, run_pipeline
from foresight.core.runtime.context import Cancelled, StageContext
from foresight.core.runtime.refs import BUILTIN_BUNDLE, BUILTIN_CONFIG_ROOT
from tests.conftest import REPO
from tests.unit.evaluation.traces import record
from tests.unit.reports import data

SMOKE = BUILTIN_CONFIG_ROOT / "pipelines" / "smoke.yaml"
SECTIONS = [
    "## Verdict",
    "## Stages",
    "## Gates",
    "## Best campaign variant",
    "## Promoted model",
    "## Artifacts",
]


def _ctx(tmp_path: Path, cancelled: list[bool] | None = None) -> StageContext:
    flag = cancelled if cancelled is not None else [False]
    return StageContext(
        workdir=tmp_path, resolve_bundle=lambda ident: BUILTIN_CONFIG_ROOT, is_cancelled=lambda: flag[0]
    )


class FakeChildren:
    """Records every call; results are complete stage results (the runbook validates them as their models)."""

    def __init__(
        self,
        *,
        evaluation_passes: bool = True,
        training_passes: bool = True,
        fail: str | None = None,
        root: Path | None = None,
        outcomes: dict[str, list[str]] | None = None,
    ):
        self.calls: list[tuple[str, str, dict[str, Any]]] = []
        self.keys: dict[str, str | None] = {}
        self.verdicts: dict[str, dict[str, Any]] = {}
        self.done: dict[str, ChildRun] = {}
        self.evaluation_passes = evaluation_passes
        self.training_passes = training_passes
        self.fail = fail
        self.root = root
        #: evaluate-kind stage -> its episodes' outcomes (written as records, so the paired gates can read them)
        self.outcomes = {"evaluate": ["success"] * 6, **(outcomes or {})}

    # the registry the pipeline resolves its incumbent in
    def model_rows(self) -> list[dict[str, Any]]:
        return [INCUMBENT_ROW]

    def model_row(self, ident: str) -> dict[str, Any] | None:
        return INCUMBENT_ROW if ident in ("default", INCUMBENT_ROW["id"]) else None

    def record_promotion(self, model_id: str, verdict: dict[str, Any]) -> None:
        self.verdicts[model_id] = verdict

    def _folder(self, stage: str) -> Path | None:
        if self.root is None:
            return None
        folder = self.root / stage
        folder.mkdir(parents=True, exist_ok=True)
        outcomes = self.outcomes.get(stage, self.outcomes["evaluate"])
        write_records(folder / "episodes.jsonl", [record("s_low", i, o) for i, o in enumerate(outcomes)])
        return folder

    def __call__(
        self, stage: str, kind: str, spec: dict[str, Any], progress: Any, cache_key: str | None = None
    ) -> ChildRun:
        if stage in self.done:  # resume: a succeeded child is returned, not run again
            run = self.done[stage]
            return ChildRun(
                result=run.result, ident=run.ident, job_id=run.job_id, resumed=True, folder=run.folder
            )
        self.calls.append((stage, kind, spec))
        self.keys[stage] = cache_key
        progress(0.5, "half way")
        if stage == self.fail:
            raise RuntimeError(f"{stage} exploded")
        run = ChildRun(
            result=self.result(stage, kind, spec), ident=f"id-{stage}", job_id=f"job-{stage}", wall_s=1.0
        )
        if kind == "register":
            run.ident = spec["model_id"]
        if kind == "evaluate":
            run.folder = self._folder(stage)
        self.done[stage] = run
        return run

    def result(self, stage: str, kind: str, spec: dict[str, Any]) -> dict[str, Any]:
        if kind == "collect" or kind == "mix":
            return {
                "dataset": f"{stage}.npz",
                "sha256": "0" * 64,
                "summary": data.dataset_summary(10, 2),
                "outcomes": {"success": 2},
            }
        if kind == "train":
            return {
                "checkpoint": "model.pt",
                "summary": "no/training_summary.json",
                "best_epoch": 2,
                "val_ade": 0.3,
                "val_fde": 0.6,
                "cv_val_ade": 0.4,
                "cv_val_fde": 0.8,
                "selection_mode": "proxy",
                "gates_passed": self.training_passes,
            }
        if kind == "evaluate":
            return data.evaluation(failures=not self.evaluation_passes)
        if kind == "diagnose":
            return data.diagnostics(6, 3)
        if kind == "planner_check":
            return {"passed": True, "checks": [{"name": "finite", "passed": True}], "planner": "predictive"}
        if kind == "campaign":
            result = data.campaign(gate_passed=True)
            for cell in result["ranked"]:
                cell["checkpoint"] = spec["checkpoints"][0]
            return result
        return {"model_id": spec.get("model_id"), "status": spec.get("to", spec.get("status"))}


INCUMBENT_ROW = {
    "id": "shipped-v1",
    "sha256": "ab" * 32,
    "status": "default",
    "lineage": {},
    "created_at": 0.0,
}


def _smoke() -> PipelineConfig:
    """The smoke pipeline with its gates as every other shipped pipeline's (smoke's are relaxed: never promoted)."""
    config = load_pipeline_config(SMOKE)
    return config.model_copy(update={"gates": GatesSection(require=config.gates.require)})


def _fake(tmp_path: Path, **kw: Any) -> FakeChildren:
    return FakeChildren(root=tmp_path / "runs", **kw)


def test_stages_run_in_order_and_outputs_feed_the_next_stage(tmp_path: Path) -> None:
    config = _smoke()
    fake = _fake(tmp_path)
    result = run_pipeline(config, _ctx(tmp_path), fake, run_id="0123456789abcdef", registry=fake)
    assert [c[0] for c in fake.calls] == [
        "collect",
        "hardcase",
        "mix",
        "train",
        "register",
        "conformance",
        "evaluate",
        "incumbent_evaluate",
        "cv_baseline",
        "diagnose",
        "incumbent_diagnose",
        "campaign",
        "promote",
    ]
    spec = {stage: s for stage, _, s in fake.calls}
    assert spec["collect"]["hard_seeds"] is None
    assert spec["hardcase"]["hard_seeds"] == config.training_seeds
    assert (spec["mix"]["base"], spec["mix"]["hardcase"]) == ("id-collect", "id-hardcase")
    assert spec["train"]["dataset"] == "id-mix"
    # proxy: the selection suite's TRAINING seeds (before 2026-11-24, the pipeline's training hard seeds)
    assert (spec["train"]["proxy"]["matrix"], spec["train"]["proxy"]["seed_manifest"]) == (
        config.selection.matrix,
        config.selection.seeds,
    )
    model = "smoke-01234567"
    assert spec["register"]["model_id"] == model and spec["register"]["status"] == "candidate"
    assert spec["evaluate"]["planner"]["model"] == model
    assert spec["diagnose"]["seed_manifest"] == config.evaluation_seeds
    assert spec["diagnose"]["planner"]["model"] == model
    assert spec["campaign"]["seed_manifest"] == config.evaluation_seeds
    assert spec["campaign"]["checkpoints"] == [model]
    assert spec["promote"] == {"model_id": model, "to": "promoted"}
    assert result.passed and result.exit_code == 0 and result.promoted and result.model_id == model
    report = (tmp_path / "report.md").read_text()
    for section in SECTIONS:
        assert section in report
    assert (tmp_path / "report.html").is_file() and (tmp_path / "pipeline_summary.json").is_file()


def test_failing_gate_writes_the_summary_exit_2_and_does_not_promote(tmp_path: Path) -> None:
    fake = _fake(tmp_path, evaluation_passes=False)
    result = run_pipeline(_smoke(), _ctx(tmp_path), fake, run_id="feedbeef", registry=fake)
    assert result.exit_code == 2 and not result.passed and result.status == "failed_gate"
    assert result.failed_gates == ["evaluation"]
    assert "promote" not in [c[0] for c in fake.calls] and not result.promoted
    assert "stays a candidate" in result.promotion
    report = (tmp_path / "report.md").read_text()
    for section in SECTIONS:
        assert section in report
    assert "FAILED" in report
    stages = {s.name: s.status for s in result.stages}
    assert stages["gates"] == "failed_gate" and stages["promote"] == "skipped"


def test_a_failed_gate_that_is_not_required_still_blocks_promotion(tmp_path: Path) -> None:
    # the smoke pipeline once printed "Gates: FAILED (training)" and promoted the model anyway
    config = _smoke()
    config.gates.require = ["evaluation", "closed_loop"]
    fake = _fake(tmp_path, training_passes=False)
    result = run_pipeline(config, _ctx(tmp_path), fake, run_id="0badcafe", registry=fake)
    assert result.exit_code == 2 and not result.passed and result.failed_gates == ["training"]
    assert "promote" not in [c[0] for c in fake.calls] and not result.promoted
    assert "stays a candidate" in result.promotion


def test_a_failed_stage_writes_the_summary_and_a_rerun_resumes_from_it(tmp_path: Path) -> None:
    config = _smoke()
    fake = _fake(tmp_path, fail="evaluate")
    with pytest.raises(StageFailed, match="stage evaluate failed"):
        run_pipeline(config, _ctx(tmp_path), fake, run_id="abc", registry=fake)
    report = (tmp_path / "report.md").read_text()
    assert "failed" in report and "evaluate exploded" in report
    ran_first = [c[0] for c in fake.calls]
    assert ran_first[-1] == "evaluate" and "campaign" not in ran_first

    fake.fail, fake.calls = None, []  # the retry: finished stages come back as resumed, nothing re-runs
    result = run_pipeline(config, _ctx(tmp_path), fake, run_id="abc", registry=fake)
    assert [c[0] for c in fake.calls] == [
        "evaluate",
        "incumbent_evaluate",
        "cv_baseline",
        "diagnose",
        "incumbent_diagnose",
        "campaign",
        "promote",
    ]
    assert result.passed
    assert {s.name: s.headline.endswith("(resumed)") for s in result.stages}["train"]


def test_cancellation_writes_the_summary_and_propagates(tmp_path: Path) -> None:
    flag = [False]

    class CancelDuringTrain(FakeChildren):
        def __call__(self, stage, kind, spec, progress):  # noqa: ANN001, ANN204
            if stage == "train":
                flag[0] = True
                raise Cancelled("job cancelled")
            return super().__call__(stage, kind, spec, progress)

    with pytest.raises(Cancelled):
        run_pipeline(_smoke(), _ctx(tmp_path, flag), CancelDuringTrain(), run_id="abc", registry=None)
    assert "cancelled" in (tmp_path / "report.md").read_text()


def test_without_hardcase_the_train_stage_takes_the_base_dataset(tmp_path: Path) -> None:
    config = _smoke().model_copy(update={"hardcase": None, "diagnose": None})
    fake = _fake(tmp_path)
    run_pipeline(config, _ctx(tmp_path), fake, registry=fake)
    stages = [c[0] for c in fake.calls]
    assert "hardcase" not in stages and "mix" not in stages and "diagnose" not in stages
    assert dict((s, spec) for s, _, spec in fake.calls)["train"]["dataset"] == "id-collect"


# ------------------------------------------------------------------------------------------ config


def test_the_shipped_pipeline_configs_validate_and_build_every_stage_config() -> None:
    inputs = {"base": "b", "hardcase": "h", "mixed": "m", "model": "cand"}
    for name in ("smoke", "quickstart", "full"):
        config = load_pipeline_config(BUILTIN_CONFIG_ROOT / "pipelines" / f"{name}.yaml")
        assert config.training_seeds != config.evaluation_seeds
        assert "train" in config.training_seeds and "eval" in config.evaluation_seeds
        for stage in ("collect", "hardcase", "mix", "train", "evaluate", "diagnose", "campaign"):
            built = stage_config(config, stage, inputs)
            assert getattr(built, "bundle", BUILTIN_BUNDLE) == BUILTIN_BUNDLE
        ctx = StageContext(workdir=Path("."), resolve_bundle=lambda ident: BUILTIN_CONFIG_ROOT)
        sizes = check_seed_separation(config, ctx)  # raises when training seeds meet evaluation episodes
        assert sizes["training_seeds"] > 0 and sizes["evaluation_seeds"] > 0
        # closed-loop model selection runs on the stress suite's TRAINING seeds
        assert config.selection is not None and config.selection.matrix == "scenarios/stress.yaml"
        proxy = stage_config(config, "train", inputs).proxy
        assert (proxy.matrix, proxy.seed_manifest) == (config.selection.matrix, config.selection.seeds)
        assert sizes["selection"] >= 3


def _covers(ours: Any, theirs: Any) -> bool:
    """``ours`` holds every value of ``theirs`` (keys a section gained since, with their defaults, do not count)."""
    if isinstance(theirs, dict) and isinstance(ours, dict):
        return all(_covers(ours.get(k), v) for k, v in theirs.items())
    return ours == theirs


def test_the_default_model_is_regenerated_by_one_pipeline_config_with_the_shipped_recipe() -> None:
    """configs/pipelines/default-model.yaml is a whole pipeline (one command regenerates the shipped default), and
    its training stage is the recipe recorded in the shipped model's training summary, key for key."""
    config = load_pipeline_config(BUILTIN_CONFIG_ROOT / "pipelines" / "default-model.yaml")
    inputs = {"base": "b", "hardcase": "h", "mixed": "m", "model": "cand"}
    ctx = StageContext(workdir=Path("."), resolve_bundle=lambda ident: BUILTIN_CONFIG_ROOT)
    assert check_seed_separation(config, ctx)["training_seeds"] > 0
    assert config.diagnose is None and config.hardcase is not None
    train = stage_config(config, "train", inputs).model_dump(mode="json")
    shipped = json.loads((REPO / "model" / "predictor-sim-default.training_summary.json").read_text())[
        "config"
    ]
    differing = {
        k for k in shipped if k not in ("dataset", "device") and not _covers(train.get(k), shipped[k])
    }
    assert not differing, f"the pipeline trains another recipe than the shipped model's: {sorted(differing)}"
    assert train["dataset"] == "m"  # the mixed (base + hard-case x3) dataset, as shipped
    assert stage_config(config, "collect", inputs).seeds_per_scenario == 48


def test_the_two_manifests_must_differ_and_sections_cannot_rewire_them() -> None:
    data = _smoke().model_dump()
    with pytest.raises(ValueError, match="different manifests"):
        PipelineConfig.model_validate({**data, "training_seeds": data["evaluation_seeds"]})
    bad = {**data, "hardcase": {**data["hardcase"], "hard_seeds": data["evaluation_seeds"]}}
    with pytest.raises(ValueError, match="training_seeds"):
        PipelineConfig.model_validate(bad)
    bad = {**data, "campaign": {**data["campaign"], "seed_manifest": data["training_seeds"]}}
    with pytest.raises(ValueError, match="evaluation_seeds"):
        PipelineConfig.model_validate(bad)
    bad = {**data, "train": {**data["train"], "proxy": {"seed_manifest": data["evaluation_seeds"]}}}
    with pytest.raises(ValueError, match="proxy"):
        PipelineConfig.model_validate(bad)


def test_training_seeds_that_meet_the_evaluation_episodes_are_refused(tmp_path: Path) -> None:
    data = _smoke().model_dump()
    # the quick evaluation manifest overlaps the full one: as training seeds it must be refused
    config = PipelineConfig.model_validate(
        {
            **data,
            "training_seeds": "seeds/classic_eval_hard_quick.yaml",
            "evaluation_seeds": "seeds/classic_eval_hard.yaml",
        }
    )
    with pytest.raises(ConfigError, match="overlap"):
        check_seed_separation(config, _ctx(tmp_path))


def test_a_selection_suite_on_evaluation_seeds_is_refused(tmp_path: Path) -> None:
    data = _smoke().model_dump()
    plain = PipelineConfig.model_validate(
        {**data, "selection": None}
    )  # no selection suite: the training hard seeds
    proxy = stage_config(plain, "train", {"base": "b", "hardcase": "h", "mixed": "m", "model": "c"}).proxy
    assert (proxy.matrix, proxy.seed_manifest) == (plain.matrix, plain.training_seeds)
    with pytest.raises(ValueError, match="selection.seeds"):
        PipelineConfig.model_validate(
            {**data, "selection": {"matrix": "scenarios/stress.yaml", "seeds": data["evaluation_seeds"]}}
        )
    # the evaluation hard seeds of the classic matrix are that matrix's own seeds: never a selection suite
    config = PipelineConfig.model_validate(
        {
            **data,
            "selection": {
                "matrix": "scenarios/classic_interactions.yaml",
                "seeds": "seeds/classic_eval_hard_quick.yaml",
            },
        }
    )
    with pytest.raises(ConfigError, match="evaluation seeds of scenarios/classic_interactions.yaml"):
        check_seed_separation(config, _ctx(tmp_path))
