"""What a campaign's MLflow run holds (built without MLflow: worker.mlflow_export.describe), and that no export is
attempted without a tracking URI or for kinds that are not exported."""

from __future__ import annotations

from pathlib import Path

from foresight.worker import mlflow_export
from tests.unit.reports import data


def test_a_campaign_run_holds_every_cell_and_the_best() -> None:
    result = data.campaign(gate_passed=True)
    content = mlflow_export.describe("campaign", result, Path("."), job_id="ab" * 16, parent_id="cd" * 16)
    assert content.name == f"campaign {'ab' * 6}"
    assert (
        content.tags["foresight.job_id"] == "ab" * 16 and content.tags["foresight.parent_job_id"] == "cd" * 16
    )
    assert content.tags["foresight.verdict"] == "passed"
    metrics = {key: value for key, value, _ in content.metrics}
    for cell in result["ranked"]:
        prefix = f"cell.{cell['variant']}.{cell['checkpoint']}"
        assert metrics[f"{prefix}.hard.success_rate"] == cell["hard"]["success"]["rate"]
        assert metrics[f"{prefix}.global.success_rate"] == cell["global"]["success"]["rate"]
    assert metrics["best.hard.success_rate"] == result["best"]["hard"]["success"]["rate"]
    assert (
        content.params["best_variant"] == result["best"]["variant"]
        and len(content.params["config_hash"]) == 16
    )
    assert content.documents["result.json"]["status"] == "passed"


def test_nothing_is_exported_without_a_target_or_for_other_kinds() -> None:
    lines: list[str] = []
    assert mlflow_export.target("  ") is None
    assert mlflow_export.export_run(None, "evaluate", data.evaluation(), Path("."), lines.append) is None
    target = mlflow_export.target("http://127.0.0.1:9")
    assert mlflow_export.export_run(target, "collect", {}, Path("."), lines.append) is None
    assert lines == []  # not even a warning: nothing was attempted
    assert mlflow_export.MlflowTarget("https://u:p@h:5000/x").public_uri() == "https://h:5000/x"
