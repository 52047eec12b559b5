"""What a researcher sees through the API: gate verdicts in job status, short ids, unknown query parameters
refused, the evaluation list."""

from __future__ import annotations

from typing import Any

from foresight.core.jobs.results import planner_and_model, verdict
from foresight.store import job_reads, queue
from tests.unit.reports import data


def _finished_evaluation(client, auth, engine, result: dict[str, Any]) -> str:  # noqa: ANN001
    spec = {
        "kind": "evaluate",
        "bundle": "builtin",
        "matrix": "scenarios/classic_interactions.yaml",
        "planner": {"name": "goal"},
        "scenarios": ["crossing_low"],
        "seeds_per_scenario": 1,
    }
    job_id = client.post("/v1/jobs", json={"spec": spec}, headers=auth).json()["id"]
    c = queue.claim(engine, "w", ["evaluate"], 30)
    assert c is not None and c["id"] == job_id
    queue.finish(engine, job_id, "w", c["attempts"], result)
    return job_id


def test_a_failed_gate_is_in_the_job_status_and_on_the_dashboard(client, auth, engine) -> None:  # noqa: ANN001
    failed = _finished_evaluation(client, auth, engine, data.evaluation(failures=True))
    passed = _finished_evaluation(client, auth, engine, data.evaluation(failures=False))
    assert client.get(f"/v1/jobs/{failed}").json()["verdict"] == "failed_gate"
    assert client.get(f"/v1/jobs/{passed}").json()["verdict"] == "passed"
    listed = {j["id"]: j["verdict"] for j in client.get("/v1/jobs").json()["data"]}
    assert listed == {failed: "failed_gate", passed: "passed"}
    sleep = client.post("/v1/jobs", json={"spec": {"kind": "sleep"}}, headers=auth).json()
    assert sleep["verdict"] is None  # no gate: no verdict
    rows = client.get("/ui/jobs/rows").text
    assert rows.count("GATE FAILED") == 1 and rows.count("gates passed") == 1
    results = client.get("/ui/results").text
    assert "GATE FAILED" in results and "<th>planner</th><th>model</th>" in results
    assert '<td class="planner">predictive</td>' in results  # the fixture's planner provenance
    assert "success 70.0%, collision 10.0% over 10 episodes; gate FAILED" in results  # from the typed result
    _finished_evaluation(client, auth, engine, {"success_rate": 0.5})  # an old row: not this version's model
    assert client.get("/ui/results").status_code == 200


def test_verdict_and_subject_from_typed_results() -> None:
    assert verdict("evaluate", data.evaluation(failures=True)) == "failed_gate"
    assert verdict("campaign", data.campaign(gate_passed=False)) == "failed_gate"
    assert verdict("campaign", data.campaign(gate_passed=True)) == "passed"
    assert verdict("sleep", {"slept_s": 0}) is None and verdict("evaluate", {"not": "a result"}) is None
    name, model = planner_and_model("evaluate", data.evaluation())
    assert name == "predictive" and model


def test_short_ids_are_accepted_where_a_job_id_is(client, auth) -> None:  # noqa: ANN001
    job = client.post("/v1/jobs", json={"spec": {"kind": "sleep"}}, headers=auth).json()
    short = job["id"][:12]
    assert client.get(f"/v1/jobs/{short}").json()["id"] == job["id"]
    assert client.post(f"/v1/jobs/{short}/cancel", headers=auth).json()["id"] == job["id"]
    page = client.get(f"/ui/jobs/{short}", follow_redirects=False)
    assert page.status_code == 307 and page.headers["location"] == f"/ui/jobs/{job['id']}"
    assert client.get("/v1/jobs/0123456789ab").status_code == 404
    assert client.get("/v1/jobs/nothex-notfound").status_code == 404


def test_unknown_query_parameters_are_422_naming_them(client) -> None:  # noqa: ANN001
    r = client.get("/v1/jobs", params={"stauts": "failed"})
    assert r.status_code == 422
    detail = r.json()["detail"][0]
    assert detail["loc"] == ["query", "stauts"] and "status" in detail["msg"]
    assert client.get("/v1/jobs", params={"status": "failed"}).status_code == 200
    assert client.get("/v1/models", params={"x": "1"}).status_code == 422


def test_a_one_value_query_parameter_given_twice_is_422_naming_it(client) -> None:  # noqa: ANN001
    """``?name=a&name=b`` used to mean ``b`` silently (schemathesis' negative phase found it on /v1/campaigns);
    list parameters such as ``tag`` still repeat."""
    for path in ("/v1/jobs", "/v1/campaigns", "/v1/evaluations"):
        r = client.get(path, params=[("name", "a"), ("name", "b")])
        assert r.status_code == 422, (path, r.text)
        assert (
            r.json()["detail"][0]["loc"] == ["query", "name"]
            and "takes one value, got 2" in r.json()["detail"][0]["msg"]
        )
        assert client.get(path, params=[("tag", "a"), ("tag", "b")]).status_code == 200


def test_evaluations_list_with_filters_and_pagination(client, auth, engine) -> None:  # noqa: ANN001
    from foresight.store import records

    ids = []
    for failures in (True, False, True):
        job_id = _finished_evaluation(client, auth, engine, {})
        job = job_reads.get_job(engine, job_id)
        with engine.begin() as conn:
            records.RECORDERS["evaluate"](conn, job, data.evaluation(failures=failures), "")
        ids.append(job_id)
    page = client.get("/v1/evaluations", params={"limit": 2}).json()
    assert page["count"] == 3 and len(page["data"]) == 2 and page["limit"] == 2
    rest = client.get("/v1/evaluations", params={"limit": 2, "offset": 2}).json()
    assert {e["id"] for e in page["data"] + rest["data"]} == set(ids)
    bundle = page["data"][0]["bundle_id"]
    assert bundle and client.get("/v1/evaluations", params={"bundle": bundle}).json()["count"] == 3
    assert client.get("/v1/evaluations", params={"bundle": "no-such-bundle"}).json()["count"] == 0
    assert client.get("/v1/evaluations", params={"model_id": "no-such-model"}).json()["count"] == 0


def test_compare_leads_with_what_differs_api_and_page(client, auth, engine) -> None:  # noqa: ANN001
    from foresight.store import records

    ids = []
    for planner in ({"name": "goal"}, {"name": "predictive", "model": "cv"}):
        result = data.evaluation(failures=False)
        result["config"] = {
            "matrix": "scenarios/classic_interactions.yaml",
            "planner": planner,
            "scenarios": ["crossing_low"],
            "seeds_per_scenario": 5,
        }
        job_id = _finished_evaluation(client, auth, engine, {})
        with engine.begin() as conn:
            records.RECORDERS["evaluate"](conn, job_reads.get_job(engine, job_id), result, "")
        ids.append(job_id)
    body = client.get("/v1/compare", params={"a": ids[0], "b": ids[1]}).json()
    assert list(body["differs"]) == [
        "planner",
        "model",
    ]  # not the matrix, episodes or horizon: those are the same
    assert body["differs"]["planner"] == {"a": "goal", "b": "predictive"}
    short = client.get("/v1/compare", params={"a": ids[0][:12], "b": ids[1][:12]}).json()
    assert short["a"] == ids[0] and short["differs"] == body["differs"]  # short ids, as the CLI prints them
    assert client.get(f"/v1/evaluations/{ids[0][:12]}").json()["id"] == ids[0]
    same = client.get("/v1/compare", params={"a": ids[0], "b": ids[0]}).json()
    assert same["differs"] == {} and same["config_diff"] == {}
    page = client.get("/ui/compare", params={"a": ids[0], "b": ids[1]})
    assert page.status_code == 200
    text = page.text
    assert text.index("What differs") < text.index("Metrics (B") < text.index("Config keys that differ")
    assert "<th>planner</th><td><code>goal</code></td><td><code>predictive</code></td>" in text
    assert client.get("/ui/compare", params={"a": ids[0], "b": "nope"}).status_code == 404


def test_compare_an_evaluation_with_a_campaign_cell_names_the_cell_planner(client, auth, engine) -> None:  # noqa: ANN001
    from foresight.store import records

    result = data.evaluation(failures=False)
    result["config"] = {
        "matrix": "scenarios/classic_interactions.yaml",
        "planner": {"name": "goal"},
        "scenarios": ["crossing_low"],
        "seeds_per_scenario": 5,
    }
    evaluation = _finished_evaluation(client, auth, engine, {})
    with engine.begin() as conn:
        records.RECORDERS["evaluate"](conn, job_reads.get_job(engine, evaluation), result, "")
    spec = {
        "kind": "campaign",
        "seed_manifest": "seeds/classic_eval_hard_smoke.yaml",
        "variants": [{"name": "default", "config": {}}],
        "scenarios": ["crossing_low"],
        "seeds_per_scenario": 1,
    }
    campaign = client.post("/v1/jobs", json={"spec": spec}, headers=auth).json()["id"]
    c = queue.claim(engine, "w", ["campaign"], 30)
    assert c is not None and c["id"] == campaign
    cells = data.campaign(gate_passed=True)
    queue.finish(
        engine,
        campaign,
        "w",
        c["attempts"],
        cells,
        record=lambda conn: records.RECORDERS["campaign"](
            conn, job_reads.get_job(engine, campaign), cells, ""
        ),
    )
    body = client.get("/v1/compare", params={"a": evaluation, "b": f"{campaign}:1"}).json()
    best = cells["ranked"][0]
    assert body["differs"]["planner"] == {"a": "goal", "b": f"{best['planner']['name']} ({best['variant']})"}
    assert body["setup"]["b"]["episodes"] == "global suite"


def test_a_planner_checks_verdict_and_checks_are_on_its_job_page(client, auth, engine) -> None:  # noqa: ANN001
    spec = {"kind": "planner_check", "planner": {"name": "goal"}}
    job_id = client.post("/v1/jobs", json={"spec": spec}, headers=auth).json()["id"]
    c = queue.claim(engine, "w", ["planner_check"], 30)
    bad = {
        "name": "within_limits",
        "passed": False,
        "value": 2.0,
        "threshold": 0.0,
        "detail": "v 4 outside [0, 2]",
    }
    result = {
        "passed": False,
        "checks": [{"name": "finite", "passed": True}, bad],
        "planner": "goal",
        "failed": ["within_limits"],
    }
    queue.finish(engine, job_id, "w", c["attempts"], result)
    assert client.get(f"/v1/jobs/{job_id}").json()["verdict"] == "failed_gate"
    page = client.get(f"/ui/jobs/{job_id}").text
    assert 'id="gates"' in page and "planner goal: FAILED within_limits" in page
    assert "v 4 outside [0, 2]" in page and "FAIL" in page
