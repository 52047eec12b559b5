"""GET /v1/compare on stored results: two evaluations, an evaluation against a campaign cell, unknown ids."""

from __future__ import annotations

import time

from sqlalchemy import insert

from foresight.store.models import Campaign, CampaignCell, Evaluation


def _rate(k: int, n: int, low: float, high: float) -> dict:
    return {"count": k, "n": n, "rate": k / n, "low": low, "high": high}


def _store(engine) -> None:  # noqa: ANN001
    overall = {"episodes": 80, "rates": {"success": _rate(48, 80, 0.4904, 0.7000)}, "means": {}}
    better = {"episodes": 70, "rates": {"success": _rate(56, 70, 0.6922, 0.8769)}, "means": {}}
    suite = {"episodes": 70, "success": _rate(56, 70, 0.6922, 0.8769), "taxonomy": {}}
    with engine.begin() as conn:
        for ident, metrics, horizon in (("eval-a", overall, 12), ("eval-b", better, 8)):
            conn.execute(insert(Evaluation.__table__).values(
                id=ident, config={"planner": {"horizon": horizon}}, metrics={"overall": metrics}, per_scenario=[],
                created_at=time.time()))  # fmt: skip
        conn.execute(insert(Campaign.__table__).values(id="camp", config={"grid": "grids/x.yaml"}, best=None,
                                                       created_at=time.time()))  # fmt: skip
        conn.execute(insert(CampaignCell.__table__).values(campaign_id="camp", rank=1, params={"variant": "v1"},
                                                           metrics={"global": suite, "hard": None}))  # fmt: skip


def test_two_evaluations_diff_and_deltas_with_intervals(client, engine) -> None:  # noqa: ANN001
    _store(engine)
    body = client.get("/v1/compare", params={"a": "eval-a", "b": "eval-b"}).json()
    assert body["sources"] == {"a": "evaluation", "b": "evaluation"}
    assert body["config_diff"] == {"planner.horizon": {"a": 12, "b": 8}}
    success = body["metrics"]["success"]
    assert abs(success["delta"] - 0.2) < 1e-9 and success["significant"]
    assert abs(success["low"] - 0.0524) < 1e-3 and abs(success["high"] - 0.3339) < 1e-3  # Newcombe's example


def test_an_evaluation_against_a_campaign_cell(client, engine) -> None:  # noqa: ANN001
    _store(engine)
    body = client.get("/v1/compare", params={"a": "eval-a", "b": "camp:1"}).json()
    assert body["sources"]["b"] == "campaign cell (global suite)"
    assert body["config_diff"]["variant"] == {"a": None, "b": "v1"}
    assert abs(body["metrics"]["success"]["delta"] - 0.2) < 1e-9


def test_unknown_results_are_404_naming_them(client, engine) -> None:  # noqa: ANN001
    _store(engine)
    for b in ("nope", "camp:9", "camp:1:sideways", "camp:x"):
        r = client.get("/v1/compare", params={"a": "eval-a", "b": b})
        assert r.status_code == 404 and b.split(":")[0] in r.json()["detail"], (b, r.text)
    assert client.get("/v1/compare", params={"a": "eval-a", "b": "camp:1:hard"}).status_code == 404  # no hard suite
