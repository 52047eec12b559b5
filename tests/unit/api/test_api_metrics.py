"""/metrics: HTTP request counts by method, route template and status class, and the latency histogram."""

from __future__ import annotations

import re
import warnings

from tests.unit.api.conftest import TOKEN

_LINE = re.compile(r"^([a-z_]+)(?:\{(.*)\})? (\S+)$")


def scrape(client) -> dict[tuple[str, frozenset], float]:  # noqa: ANN001
    r = client.get("/metrics")
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/plain")
    out = {}
    for line in r.text.splitlines():
        if line.startswith("#") or not line:
            continue
        m = _LINE.match(line)
        assert m, line
        labels = frozenset(re.findall(r'(\w+)="([^"]*)"', m.group(2) or ""))
        out[(m.group(1), labels)] = float(m.group(3))
    return out


def requests(method: str, route: str, status: str) -> tuple[str, frozenset]:
    return "foresight_http_requests_total", frozenset(
        {("method", method), ("route", route), ("status", status)}
    )


def test_requests_are_counted_by_route_template_and_status_class(client, auth) -> None:  # noqa: ANN001
    job = client.post("/v1/jobs", json={"spec": {"kind": "sleep"}}, headers=auth).json()["id"]
    before = scrape(client)
    for _ in range(3):
        assert client.get(f"/v1/jobs/{job}").status_code == 200
    assert client.get("/v1/jobs/nope").status_code == 404
    assert client.get("/v1/jobs/also-nope").status_code == 404
    assert client.post("/v1/jobs", json={"spec": {"kind": "sleep"}}).status_code == 401
    assert client.post("/v1/jobs", json={"spec": {"kind": "sleep"}}, headers=auth).status_code == 201
    assert client.get("/no/such/path").status_code == 404
    after = scrape(client)

    def delta(key: tuple) -> float:
        return after.get(key, 0) - before.get(key, 0)

    assert delta(requests("GET", "/v1/jobs/{job_id}", "2xx")) == 3
    assert delta(requests("GET", "/v1/jobs/{job_id}", "4xx")) == 2
    assert delta(requests("POST", "/v1/jobs", "4xx")) == 1
    assert delta(requests("POST", "/v1/jobs", "2xx")) == 1
    assert delta(requests("GET", "unmatched", "4xx")) == 1
    assert delta(requests("GET", "/metrics", "2xx")) == 1  # the first scrape
    assert not any(
        job in str(labels) or "nope" in str(labels) for _, labels in after
    )  # templates, not raw paths

    # the histogram: cumulative buckets ending in +Inf == count, five more observations for the job route
    route = frozenset({("method", "GET"), ("route", "/v1/jobs/{job_id}")})
    count = ("foresight_http_request_duration_seconds_count", route)
    assert after[count] - before.get(count, 0) == 5
    buckets = sorted(
        (float(dict(labels)["le"]), v)
        for (name, labels), v in after.items()
        if name == "foresight_http_request_duration_seconds_bucket"
        and {p for p in labels if p[0] != "le"} == route
    )
    assert [v for _, v in buckets] == sorted(v for _, v in buckets) and buckets[-1] == (
        float("inf"),
        after[count],
    )
    assert 0 < after[("foresight_http_request_duration_seconds_sum", route)] < 60
    # the job gauges are still there
    assert after[("foresight_jobs", frozenset({("kind", "sleep"), ("status", "queued")}))] == 2


def test_closed_reads_close_metrics_and_workers_but_not_health(settings) -> None:  # noqa: ANN001
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        from fastapi.testclient import TestClient
    from foresight.api.main import create_app

    closed = settings.model_copy(update={"read_requires_token": True})
    with TestClient(create_app(closed)) as c:
        assert c.get("/healthz").status_code == 200
        for path in ("/metrics", "/v1/workers", "/v1/jobs"):
            assert c.get(path).status_code == 401, path
            assert c.get(path, headers={"Authorization": f"Bearer {TOKEN}"}).status_code == 200, path
        security = c.get("/openapi.json").json()["paths"]["/metrics"]["get"]
        assert "401" in security["responses"] and security.get("security")
