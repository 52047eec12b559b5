"""The incumbent in the runbook: resolved and recorded, run on the candidate's episodes (cached by key), and the
regression and floors gates that decide promotion; a relaxed pipeline's model is never promoted."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from foresight.core.jobs.pipeline.config import INCUMBENT, IncumbentSection, PromoteSection, stage_config
from foresight.core.jobs.pipeline.incumbent import cache_key, reference_spec, resolve_incumbent
from foresight.core.jobs.pipeline.runbook import run_pipeline
from tests.unit.pipeline.test_runbook import INCUMBENT_ROW, SMOKE, _ctx, _fake, _smoke, load_pipeline_config

INPUTS = {"base": "b", "hardcase": "h", "mixed": "m", "model": "cand"}


class Rows:
    def __init__(self, rows: list[dict[str, Any]]):
        self.rows = rows

    def model_rows(self) -> list[dict[str, Any]]:
        return self.rows

    def model_row(self, ident: str) -> dict[str, Any] | None:
        if ident == "default":
            return next((r for r in self.rows if r["status"] == "default"), None)
        return next((r for r in self.rows if r["id"] == ident), None)


def _row(ident: str, status: str, pipeline: str | None = None, at: float = 0.0) -> dict[str, Any]:
    return {
        "id": ident,
        "status": status,
        "sha256": ident[0] * 64,
        "created_at": at,
        "lineage": {"pipeline": pipeline} if pipeline else {},
    }


def test_the_incumbent_is_the_newest_promoted_model_of_the_lineage_else_the_default() -> None:
    config = _smoke()
    rows = Rows(
        [
            _row("dflt", "default"),
            _row("old", "promoted", "smoke", 1.0),
            _row("new", "promoted", "smoke", 2.0),
            _row("other", "promoted", "elsewhere", 3.0),
            _row("relax", "relaxed", "smoke", 4.0),
        ]
    )
    got = resolve_incumbent(config, rows)
    assert got is not None and (got.id, got.sha256) == ("new", "n" * 64) and "smoke" in got.why
    to_default = config.model_copy(update={"promote": PromoteSection(to="default")})
    assert resolve_incumbent(to_default, rows).id == "dflt"
    assert resolve_incumbent(config, Rows([_row("dflt", "default")])).id == "dflt"
    named = config.model_copy(update={"incumbent": IncumbentSection(model="old")})
    assert resolve_incumbent(named, rows).id == "old"
    none = config.model_copy(update={"incumbent": IncumbentSection(model=None)})
    assert resolve_incumbent(none, rows) is None


def test_reference_runs_hold_the_candidates_episodes_with_another_model_and_a_stable_cache_key() -> None:
    config = _smoke()
    inc = resolve_incumbent(config, Rows([_row("dflt", "default")]))
    cand = stage_config(config, "evaluate", INPUTS).model_dump(mode="json")
    ref = reference_spec(config, "incumbent_evaluate", INPUTS, inc)
    cv = reference_spec(config, "cv_baseline", INPUTS, inc)
    for key in ("matrix", "scenarios", "seeds_per_scenario", "max_steps", "scenario_overrides"):
        assert ref[key] == cand[key] == cv[key]
    assert (cand["planner"]["model"], ref["planner"]["model"], cv["planner"]["model"]) == (
        "cand",
        "dflt",
        "cv",
    )
    assert ref["planner"]["config"] == cand["planner"]["config"]
    diag = reference_spec(config, "incumbent_diagnose", INPUTS, inc)
    assert diag["seed_manifest"] == config.evaluation_seeds and diag["render"] is False
    # the key does not depend on the candidate, and does on the incumbent's bytes and planner config
    other_cand = reference_spec(config, "incumbent_evaluate", {**INPUTS, "model": "cand2"}, inc)
    assert cache_key("incumbent_evaluate", "evaluate", other_cand, inc.sha256) == cache_key(
        "incumbent_evaluate", "evaluate", ref, inc.sha256
    )
    assert cache_key("incumbent_evaluate", "evaluate", ref, "x" * 64) != cache_key(
        "incumbent_evaluate", "evaluate", ref, inc.sha256
    )
    tuned = config.model_copy(
        update={
            "incumbent": IncumbentSection(planner_config={"safety": {"crowd": {"yielding": {"speed": 0.0}}}})
        }
    )
    ref2 = reference_spec(tuned, "incumbent_evaluate", INPUTS, inc)
    assert ref2["planner"]["config"] == {"safety": {"crowd": {"yielding": {"speed": 0.0}}}}
    assert cache_key("i", "evaluate", ref2, inc.sha256) != cache_key("i", "evaluate", ref, inc.sha256)
    assert cache_key("incumbent_evaluate", "evaluate", ref, inc.sha256).endswith(":incumbent_evaluate")


def test_the_campaign_may_name_the_incumbent_as_a_checkpoint() -> None:
    config = _smoke()
    config.campaign = config.campaign.model_copy(update={"checkpoints": ["candidate", INCUMBENT]})
    built = stage_config(config, "campaign", {**INPUTS, "incumbent": "dflt"})
    assert built.checkpoints == ["cand", "dflt"]


def test_the_pipeline_records_its_incumbent_and_passes_against_an_equal_one(tmp_path: Path) -> None:
    fake = _fake(tmp_path)
    result = run_pipeline(_smoke(), _ctx(tmp_path), fake, run_id="0123abcd", registry=fake)
    assert result.incumbent is not None
    assert (result.incumbent.id, result.incumbent.sha256) == (INCUMBENT_ROW["id"], INCUMBENT_ROW["sha256"])
    spec = {stage: s for stage, _, s in fake.calls}
    assert spec["incumbent_evaluate"]["planner"]["model"] == INCUMBENT_ROW["id"]
    assert spec["cv_baseline"]["planner"]["model"] == "cv"
    assert fake.keys["incumbent_evaluate"].startswith("reference:") and fake.keys["evaluate"] is None
    assert result.passed and result.promoted
    gates = {g.name: g for g in result.summary.gates}
    assert gates["regression"].passed and gates["floors"].passed
    report = (tmp_path / "report.md").read_text()
    assert report.index("## Candidate vs incumbent") < report.index("## Stages")


def test_a_worse_candidate_is_refused_by_the_regression_gate(tmp_path: Path) -> None:
    worse = ["success"] * 4 + ["timeout", "collision_pedestrian"]
    fake = _fake(tmp_path, outcomes={"evaluate": worse, "incumbent_evaluate": ["success"] * 6})
    result = run_pipeline(_smoke(), _ctx(tmp_path), fake, run_id="0123abcd", registry=fake)
    assert not result.passed and result.exit_code == 2 and not result.promoted
    assert "regression" in result.failed_gates
    assert any(
        f.startswith("regression.success_vs_incumbent: 0.333 (threshold 0)") for f in result.failing_checks
    )
    assert "stays a candidate" in result.promotion and "regression" in result.promotion
    kept = fake.verdicts[result.model_id]  # the registry keeps why, with the model
    assert not kept["promoted"] and kept["failing_checks"] == result.failing_checks
    assert kept["gates"]["regression"] is False and kept["incumbent"]["id"] == INCUMBENT_ROW["id"]
    regression = result.summary.regression
    assert regression is not None and len(regression.changed) == 2
    assert "promote" not in [c[0] for c in fake.calls]


def test_without_an_incumbent_the_required_regression_gate_fails(tmp_path: Path) -> None:
    fake = _fake(tmp_path)
    result = run_pipeline(_smoke(), _ctx(tmp_path), fake, run_id="0123abcd", registry=None)
    assert not result.passed and "regression" in result.failed_gates and result.incumbent is None
    assert {s.name: s.status for s in result.stages}["incumbent_evaluate"] == "skipped"


def test_a_relaxed_pipeline_registers_a_relaxed_model_and_never_promotes_it(tmp_path: Path) -> None:
    config = load_pipeline_config(SMOKE)  # the shipped smoke pipeline: gates relaxed on purpose
    assert config.gates.relaxed
    fake = _fake(tmp_path, outcomes={"evaluate": ["timeout"] * 6})
    result = run_pipeline(config, _ctx(tmp_path), fake, run_id="0123abcd", registry=fake)
    spec = {stage: s for stage, _, s in fake.calls}
    assert spec["register"]["status"] == "relaxed"
    assert not result.promoted and "promote" not in spec
    assert "can never be promoted or become the default" in result.promotion


def test_the_planner_the_pipeline_evaluates_must_conform(tmp_path: Path) -> None:
    class NonConforming(type(_fake(tmp_path))):
        def result(self, stage: str, kind: str, spec: dict[str, Any]) -> dict[str, Any]:
            if kind == "planner_check":
                check = {
                    "name": "within_limits",
                    "passed": False,
                    "value": 3.0,
                    "threshold": 0.0,
                    "detail": "v 4",
                }
                return {
                    "passed": False,
                    "checks": [check],
                    "planner": "predictive",
                    "failed": ["within_limits"],
                }
            return super().result(stage, kind, spec)

    fake = NonConforming(root=tmp_path / "runs")
    result = run_pipeline(_smoke(), _ctx(tmp_path), fake, run_id="0123abcd", registry=fake)
    spec = {stage: s for stage, _, s in fake.calls}
    assert (
        spec["conformance"]["planner"] == spec["evaluate"]["planner"]
    )  # the candidate model, evaluate's config
    assert spec["conformance"]["matrix"] == _smoke().matrix
    assert not result.passed and result.failed_gates == ["conformance"] and not result.promoted
    assert result.failing_checks == ["conformance.within_limits: 3 (threshold 0)"]


def test_in_process_runs_resolve_the_incumbent_from_the_shipped_registry(tmp_path: Path) -> None:
    from foresight.core.jobs.pipeline.local import LocalChildren
    from foresight.local import MODEL_REGISTRY, ModelArgs
    from foresight.store.shipped import default_model, read_shipped

    want = default_model(read_shipped(MODEL_REGISTRY))
    children = LocalChildren(_ctx(tmp_path), describe_model=ModelArgs.describe, reports=False)
    got = resolve_incumbent(_smoke(), children)
    assert got is not None and (got.id, got.sha256) == (want["id"], want["sha256"])
    assert children.model_row("no-such-model") is None
    children.record_promotion(
        "absent", {"promoted": False}
    )  # a model this run did not register: nothing kept
