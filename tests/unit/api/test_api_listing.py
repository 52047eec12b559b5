"""GET /v1/evaluations, /v1/campaigns and /v1/models: filters on what a run ran and on its job's labels,
pages, and unknown parameters refused (a real SQLite file; records written by the store's own recorders)."""

from __future__ import annotations

from typing import Any

from foresight.store import job_reads, queue, records
from tests.unit.reports import data


def _finished(client, auth, engine, kind: str, result: dict[str, Any], **labels) -> str:  # noqa: ANN001, ANN003
    """A job of ``kind`` submitted with ``labels``, claimed and finished with ``result``, its records written."""
    spec = {
        "kind": "evaluate",
        "bundle": "builtin",
        "matrix": "scenarios/classic_interactions.yaml",
        "planner": {"name": "goal"},
        "scenarios": ["crossing_low"],
        "seeds_per_scenario": 1,
    }
    if kind == "campaign":
        spec = {
            "kind": "campaign",
            "seed_manifest": "seeds/classic_eval_hard.yaml",
            "variants": [{"name": "a"}],
        }
    r = client.post("/v1/jobs", json={"spec": spec, **labels}, headers=auth)
    assert r.status_code == 201, r.text
    job_id = r.json()["id"]
    claimed = queue.claim(engine, "w", [kind], 30)
    assert claimed is not None and claimed["id"] == job_id
    queue.finish(engine, job_id, "w", claimed["attempts"], result)
    with engine.begin() as conn:
        records.RECORDERS[kind](conn, job_reads.get_job(engine, job_id), result, "")
    return job_id


def _evaluation(planner: dict, matrix: str, failures: bool = False) -> dict[str, Any]:
    result = data.evaluation(failures=failures)
    result["config"] = {**result.get("config", {}), "matrix": matrix, "planner": planner}
    return result


def _ids(client, path: str, **params) -> set[str]:  # noqa: ANN001, ANN003
    r = client.get(path, params=params)
    assert r.status_code == 200, r.text
    return {e["id"] for e in r.json()["data"]}


def test_evaluations_by_planner_matrix_verdict_and_labels(client, auth, engine) -> None:  # noqa: ANN001
    a = _finished(
        client,
        auth,
        engine,
        "evaluate",
        _evaluation({"name": "goal"}, "scenarios/classic_interactions.yaml"),
        name="goal baseline",
        tags=["baseline"],
    )
    b = _finished(
        client,
        auth,
        engine,
        "evaluate",
        _evaluation({"name": "orca"}, "scenarios/classic_interactions.yaml", True),
        tags=["baseline", "orca"],
    )
    c = _finished(client, auth, engine, "evaluate", _evaluation({"name": "orca"}, "scenarios/other.yaml"))
    assert _ids(client, "/v1/evaluations") == {a, b, c}
    assert _ids(client, "/v1/evaluations", planner="orca") == {b, c}
    assert _ids(client, "/v1/evaluations", matrix="scenarios/other.yaml") == {c}
    assert _ids(client, "/v1/evaluations", verdict="failed_gate") == {b}
    assert _ids(client, "/v1/evaluations", tag="baseline") == {a, b}
    assert _ids(client, "/v1/evaluations", tag=["baseline", "orca"]) == {b}
    assert _ids(client, "/v1/evaluations", name="goal baseline") == {a}
    assert _ids(client, "/v1/evaluations", planner="orca", tag="baseline") == {b}
    page = client.get("/v1/evaluations", params={"limit": 2}).json()
    assert page["count"] == 3 and [e["id"] for e in page["data"]] == [c, b]  # newest first
    assert page["data"][1]["tags"] == ["baseline", "orca"]
    rest = client.get("/v1/evaluations", params={"limit": 2, "offset": 2}).json()
    assert [e["id"] for e in rest["data"]] == [a] and rest["data"][0]["name"] == "goal baseline"
    results_page = client.get("/ui/results").text
    assert (
        "goal baseline" in results_page and 'href="/ui/jobs?tag=orca"' in results_page
    )  # labels on the Results page
    r = client.get("/v1/evaluations", params={"planer": "orca"})
    assert r.status_code == 422 and r.json()["detail"][0]["loc"] == ["query", "planer"]
    assert "planner" in r.json()["detail"][0]["msg"]
    assert client.get("/v1/evaluations", params={"verdict": "green"}).status_code == 422


def test_campaigns_list_filters_and_pages(client, auth, engine) -> None:  # noqa: ANN001
    first = _finished(client, auth, engine, "campaign", data.campaign(gate_passed=True), tags=["grid-v1"])
    other = data.campaign(gate_passed=False)
    other["matrix"] = "scenarios/other.yaml"
    for cell in other["ranked"]:
        cell["checkpoint"] = "model-7"
    second = _finished(client, auth, engine, "campaign", other, name="second sweep")
    body = client.get("/v1/campaigns").json()
    assert body["count"] == 2 and [c["id"] for c in body["data"]] == [second, first]
    listed = body["data"][1]
    assert listed["tags"] == ["grid-v1"] and listed["best"] == {"checkpoint": "cv", "variant": "careful"}
    assert listed["best_metrics"]["global"]["episodes"] == 20 and listed["config"]["matrix"].endswith(
        "classic_interactions.yaml"
    )
    assert _ids(client, "/v1/campaigns", matrix="scenarios/other.yaml") == {second}
    assert _ids(client, "/v1/campaigns", model="model-7") == {second}
    assert _ids(client, "/v1/campaigns", model="cv") == {first}
    assert _ids(client, "/v1/campaigns", tag="grid-v1") == {first}
    assert _ids(client, "/v1/campaigns", name="second sweep") == {second}
    assert _ids(client, "/v1/campaigns", limit=1, offset=1) == {first}
    assert client.get("/v1/campaigns", params={"limit": 0}).status_code == 422
    assert client.get("/v1/campaigns", params={"planner": "x"}).status_code == 422  # not a campaign filter


def test_models_list_pages(settings) -> None:  # noqa: ANN001
    from fastapi.testclient import TestClient

    from foresight.api.main import create_app
    from foresight.store.settings import REPO_ROOT

    app = create_app(settings.model_copy(update={"model_registry": REPO_ROOT / "model" / "registry.yaml"}))
    with TestClient(app) as client:
        _models_list_pages(client)


def _models_list_pages(client) -> None:  # noqa: ANN001
    everything = client.get("/v1/models").json()
    assert everything["count"] == len(everything["data"]) >= 1
    page = client.get("/v1/models", params={"limit": 1, "offset": 0}).json()
    assert page["count"] == everything["count"] and len(page["data"]) == 1 and page["limit"] == 1
    assert page["data"][0]["id"] == everything["data"][0]["id"]
    assert client.get("/v1/models", params={"offset": 10_000}).json()["data"] == []
    assert client.get("/v1/models", params={"stat": "default"}).status_code == 422
