"""Campaign metrics against the planner-grid parameters: which keys varied, the JSON series and the dashboard
page's inline SVG charts (a real SQLite file; the campaign recorded by the store's recorder)."""

from __future__ import annotations

import copy
import xml.etree.ElementTree as ET

from foresight.core.reports.grid_plot import GridCell, chart_svg, parameter_plots, varied_parameters
from foresight.store import job_reads, queue, records
from tests.unit.reports import data


def _grid_campaign() -> dict:
    """The test campaign, its three variants differing in planner.speed_limit and safety.margin (one cell
    per variant and checkpoint cv), plus the same three on checkpoint m-1."""
    result = data.campaign(gate_passed=True)
    for cell, (speed, margin) in zip(result["ranked"], ((0.8, 0.5), (1.0, 0.5), (1.2, 0.3)), strict=True):
        cell["planner"]["config"] = {
            "speed_limit": speed,
            "safety": {"margin": margin, "mode": "soft"},
            "name": "x",
        }
    others = copy.deepcopy(result["ranked"])
    for cell in others:
        cell["checkpoint"], cell["key"] = "m-1", cell["variant"] + "__m-1"
    result["ranked"] += others
    return result


def _store(client, auth, engine, result: dict) -> str:  # noqa: ANN001
    spec = {"kind": "campaign", "seed_manifest": "seeds/classic_eval_hard.yaml", "variants": [{"name": "a"}]}
    job_id = client.post("/v1/jobs", json={"spec": spec}, headers=auth).json()["id"]
    claimed = queue.claim(engine, "w", ["campaign"], 30)
    queue.finish(engine, job_id, "w", claimed["attempts"], result)
    with engine.begin() as conn:
        records.RECORDERS["campaign"](conn, job_reads.get_job(engine, job_id), result, "")
    return job_id


def test_varied_parameters_are_the_numeric_keys_that_differ() -> None:
    from foresight.core.evaluation.campaign_result import CampaignResult

    result = CampaignResult.model_validate(_grid_campaign())
    cells = [
        GridCell(c.checkpoint, c.variant, c.planner.config, {"global": c.global_, "hard": c.hard})
        for c in result.ranked
    ]
    assert varied_parameters(cells) == [
        "safety.margin",
        "speed_limit",
    ]  # not the text key, not the constant ones
    plot = parameter_plots(cells)[1]
    lines = {(s.checkpoint, s.suite): s for s in plot.series["success"]}
    assert set(lines) == {("cv", "global"), ("cv", "hard"), ("m-1", "global"), ("m-1", "hard")}
    assert [p.x for p in lines[("cv", "global")].points] == [0.8, 1.0, 1.2]  # sorted by the parameter
    assert [p.variant for p in lines[("cv", "global")].points] == ["careful", "base", "fast"]
    assert [p.rate for p in lines[("cv", "hard")].points] == [0.75, 0.5, 0.25]
    svg = chart_svg(plot, "success")
    root = ET.fromstring(svg)  # well-formed SVG
    ns = "{http://www.w3.org/2000/svg}"
    assert len(root.findall(f"{ns}polyline")) == 4 and len(root.findall(f"{ns}circle")) == 6
    assert "careful @ cv, global suite: speed_limit = 0.8, success 85.0 %" in svg
    same = [GridCell(c.checkpoint, c.variant, {}, c.suites) for c in cells]
    assert [p.parameter for p in parameter_plots(same)] == ["variant"]  # nothing varies: by variant name


def test_campaign_grid_api_and_page(client, auth, engine) -> None:  # noqa: ANN001
    job_id = _store(client, auth, engine, _grid_campaign())
    body = client.get(f"/v1/campaigns/{job_id[:12]}/grid").json()
    assert [p["parameter"] for p in body] == ["safety.margin", "speed_limit"]
    speed = body[1]["series"]["collision"]
    assert {(s["checkpoint"], s["suite"]) for s in speed} == {
        ("cv", "global"),
        ("cv", "hard"),
        ("m-1", "global"),
        ("m-1", "hard"),
    }
    html = client.get(f"/ui/campaigns/{job_id}").text
    assert (
        html.count('<svg xmlns="http://www.w3.org/2000/svg" class="grid-chart"') == 4
    )  # 2 parameters x 2 metrics
    assert 'data-parameter="speed_limit" data-metric="collision"' in html and "compare with best" in html
    assert f'href="/ui/campaigns/{job_id}"' in client.get(f"/ui/jobs/{job_id}").text
    assert client.get("/ui/campaigns/nope").status_code == 404
    assert client.get("/v1/campaigns/nope/grid").status_code == 404
