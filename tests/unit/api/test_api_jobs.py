"""Jobs endpoints through the app: status codes, bodies, and nothing stored on bad input."""

from __future__ import annotations

import pytest

from foresight.store import queue
from foresight.store.settings import REPO_ROOT

SLEEP = {"spec": {"kind": "sleep"}}


def _count(client) -> int:  # noqa: ANN001
    return client.get("/v1/jobs").json()["count"]


def test_submit_201_and_read(client, auth) -> None:  # noqa: ANN001
    r = client.post("/v1/jobs", json={"spec": {"kind": "sleep", "seconds": 0.5}, "priority": 3}, headers=auth)
    assert r.status_code == 201
    job = r.json()
    assert job["status"] == "queued" and job["spec"]["seconds"] == 0.5 and job["priority"] == 3
    got = client.get(f"/v1/jobs/{job['id']}").json()
    assert got["id"] == job["id"] and got["artifacts"] == [] and got["children"] == []


def test_writes_need_the_token(client, auth) -> None:  # noqa: ANN001
    r = client.post("/v1/jobs", json=SLEEP)
    assert r.status_code == 401 and "token" in r.json()["detail"]
    r = client.post("/v1/jobs", json=SLEEP, headers={"Authorization": "Bearer wrong"})
    assert r.status_code == 403 and r.json()["detail"]
    job = client.post("/v1/jobs", json=SLEEP, headers=auth).json()
    for method, path in (
        ("post", f"/v1/jobs/{job['id']}/cancel"),
        ("post", f"/v1/jobs/{job['id']}/retry"),
        ("delete", f"/v1/jobs/{job['id']}"),
        ("post", "/v1/models"),
        ("post", "/v1/bundles?name=x"),
    ):
        assert getattr(client, method)(path).status_code == 401, path
    assert _count(client) == 1


@pytest.mark.parametrize(
    "body,where",
    [
        ({"spec": {"kind": "nope"}}, ["body", "spec"]),
        ({"spec": {"kind": "sleep", "seconds": -1}}, ["body", "spec", "sleep", "seconds"]),
        ({"spec": {"kind": "sleep", "seconds": 1e12}}, ["body", "spec", "sleep", "seconds"]),
        ({"spec": {"kind": "sleep", "steps": 10**9}}, ["body", "spec", "sleep", "steps"]),
        ({"spec": {"kind": "sleep", "extra": 1}}, ["body", "spec", "sleep", "extra"]),
        ({"spec": {"kind": "sleep", "artifact": "/etc/passwd"}}, ["body", "spec", "artifact"]),
        ({"spec": {"kind": "sleep", "artifact": "../../x"}}, ["body", "spec", "artifact"]),
        ({"spec": {"kind": "simulate", "matrix": "../secrets.yaml"}}, ["body", "spec", "simulate", "matrix"]),
        ({"spec": {"kind": "simulate", "bundle": "../x"}}, ["body", "spec", "simulate", "bundle"]),
        ({"spec": {"kind": "sleep"}, "priority": 10**6}, ["body", "priority"]),
        ({"spec": {"kind": "sleep"}, "timeout_s": -5}, ["body", "timeout_s"]),
        ({"spec": {"kind": "sleep"}, "idempotency_key": "has space"}, ["body", "idempotency_key"]),
        ({"spec": "not an object"}, ["body", "spec"]),
        ({}, ["body", "spec"]),
    ],
)
def test_bad_specs_are_422_with_field_paths_and_store_nothing(client, auth, body, where) -> None:  # noqa: ANN001
    r = client.post("/v1/jobs", json=body, headers=auth)
    assert r.status_code == 422, r.text
    locs = [e["loc"][: len(where)] for e in r.json()["detail"]]
    assert where in locs, locs
    assert _count(client) == 0


def test_malformed_json_and_nan_are_422(client, auth) -> None:  # noqa: ANN001
    headers = {**auth, "Content-Type": "application/json"}
    assert client.post("/v1/jobs", content=b"{not json", headers=headers).status_code == 422
    r = client.post("/v1/jobs", content=b'{"spec": {"kind": "sleep", "seconds": NaN}}', headers=headers)
    assert r.status_code == 422
    assert _count(client) == 0


def test_unknown_ids_are_404(client, auth) -> None:  # noqa: ANN001
    for path in (
        "/v1/jobs/deadbeef",
        "/v1/jobs/deadbeef/artifacts/a.txt",
        "/v1/models/nope",
        "/v1/bundles/nope",
        "/v1/datasets/nope",
        "/v1/evaluations/nope",
        "/v1/campaigns/nope",
    ):
        r = client.get(path)
        assert r.status_code == 404 and r.json()["detail"], path
    assert client.post("/v1/jobs/deadbeef/cancel", headers=auth).status_code == 404
    assert client.post("/v1/jobs", json={**SLEEP, "parent_id": "nope"}, headers=auth).status_code == 404
    assert client.get("/v1/jobs/bad%20id").status_code == 422


def test_idempotency_key_returns_the_same_job(client, auth) -> None:  # noqa: ANN001
    body = {**SLEEP, "idempotency_key": "abc-1"}
    first = client.post("/v1/jobs", json=body, headers=auth)
    second = client.post("/v1/jobs", json=body, headers=auth)
    assert (first.status_code, second.status_code) == (201, 200)
    assert first.json()["id"] == second.json()["id"]
    clash = client.post(
        "/v1/jobs", json={"spec": {"kind": "sleep", "seconds": 2}, "idempotency_key": "abc-1"}, headers=auth
    )
    assert clash.status_code == 409
    assert _count(client) == 1


def test_pagination_and_filters(client, auth, engine) -> None:  # noqa: ANN001
    ids = [client.post("/v1/jobs", json=SLEEP, headers=auth).json()["id"] for _ in range(7)]
    queue.request_cancel(engine, ids[0])
    seen = []
    for offset in (0, 3, 6):
        page = client.get("/v1/jobs", params={"limit": 3, "offset": offset}).json()
        assert page["count"] == 7
        seen += [j["id"] for j in page["data"]]
    assert sorted(seen) == sorted(ids) and len(set(seen)) == 7
    cancelled = client.get("/v1/jobs", params={"status": "cancelled"}).json()
    assert [j["id"] for j in cancelled["data"]] == [ids[0]]
    assert client.get("/v1/jobs", params={"kind": "simulate"}).json()["count"] == 0
    assert client.get("/v1/jobs", params={"limit": 0}).status_code == 422
    assert client.get("/v1/jobs", params={"offset": -1}).status_code == 422
    assert client.get("/v1/jobs", params={"status": "bogus"}).status_code == 422


def test_cancel_retry_delete_rules(client, auth, engine) -> None:  # noqa: ANN001
    job = client.post("/v1/jobs", json=SLEEP, headers=auth).json()
    assert client.delete(f"/v1/jobs/{job['id']}", headers=auth).status_code == 409  # still queued
    assert client.post(f"/v1/jobs/{job['id']}/retry", headers=auth).status_code == 409
    r = client.post(f"/v1/jobs/{job['id']}/cancel", headers=auth)
    assert r.status_code == 200 and r.json()["status"] == "cancelled"
    r = client.post(f"/v1/jobs/{job['id']}/cancel", headers=auth)
    assert r.status_code == 409 and "cancelled" in r.json()["detail"]
    assert client.post(f"/v1/jobs/{job['id']}/retry", headers=auth).json()["status"] == "queued"
    client.post(f"/v1/jobs/{job['id']}/cancel", headers=auth)
    assert client.delete(f"/v1/jobs/{job['id']}", headers=auth).status_code == 204
    assert client.get(f"/v1/jobs/{job['id']}").status_code == 404


def _finish_with_artifact(
    engine, settings, job_id: str, name: str = "out/a.txt", content: bytes = b"hello"
) -> None:  # noqa: ANN001
    from foresight.store import folders

    c = queue.claim(engine, "w", ["sleep"], 30)
    rel = f"{folders.job_dir(settings.store_root, job_id)}/{name}"
    folders.write_atomic(folders.resolve_under(settings.store_root, rel), content)
    queue.finish(
        engine,
        job_id,
        "w",
        c["attempts"],
        {},
        folders.scan(settings.store_root, folders.job_dir(settings.store_root, job_id)),
    )


def test_artifact_download_and_traversal(client, auth, engine, settings) -> None:  # noqa: ANN001
    job = client.post("/v1/jobs", json=SLEEP, headers=auth).json()
    _finish_with_artifact(engine, settings, job["id"])
    (settings.store_root / "secret.txt").write_text("TOP-SECRET-CONTENT")
    r = client.get(f"/v1/jobs/{job['id']}/artifacts/out/a.txt")
    assert r.status_code == 200 and r.content == b"hello"
    for bad in (
        "..%2F..%2Fsecret.txt",
        "out/..%2F..%2F..%2Fsecret.txt",
        "%2Fetc%2Fpasswd",
        "out%5C..%5C..%5Csecret.txt",
    ):
        r = client.get(f"/v1/jobs/{job['id']}/artifacts/{bad}")
        assert r.status_code in (404, 422), bad
        assert b"TOP-SECRET" not in r.content and r.json()["detail"]


def test_delete_keeps_files_a_model_uses(client, auth, engine, settings) -> None:  # noqa: ANN001
    job = client.post("/v1/jobs", json=SLEEP, headers=auth).json()
    weights = (REPO_ROOT / "model" / "predictor-sim-default.pt").read_bytes()  # registration checks it loads
    _finish_with_artifact(engine, settings, job["id"], "model.pt", weights)
    _finish_note = client.post(
        "/v1/models", json={"id": "m1", "job_id": job["id"], "artifact": "model.pt"}, headers=auth
    )
    assert _finish_note.status_code == 201
    assert client.delete(f"/v1/jobs/{job['id']}", headers=auth).status_code == 204
    checkpoint = settings.store_root / _finish_note.json()["checkpoint"]
    assert checkpoint.read_bytes() == weights


def test_health_workers_metrics_openapi(client) -> None:  # noqa: ANN001
    assert client.get("/healthz").json()["status"] == "ok"
    assert client.get("/v1/workers").json()["count"] == 0
    text = client.get("/metrics").text
    assert "# TYPE foresight_jobs gauge" in text and "foresight_workers_alive 0" in text
    ops = {
        op["operationId"]
        for path in client.get("/openapi.json").json()["paths"].values()
        for op in path.values()
    }
    assert {
        "create_job",
        "read_jobs",
        "read_job",
        "cancel_job",
        "retry_job",
        "delete_job",
        "read_job_events",
        "read_job_artifact",
        "read_models",
        "create_model",
        "promote_model",
        "delete_model",
    } <= ops


def test_reads_can_be_closed(settings, auth) -> None:  # noqa: ANN001
    from fastapi.testclient import TestClient

    from foresight.api.main import create_app

    closed = settings.model_copy(update={"read_requires_token": True})
    with TestClient(create_app(closed)) as c:
        assert c.get("/v1/jobs").status_code == 401
        assert c.get("/v1/jobs", headers=auth).status_code == 200


def test_oversized_submission_is_413(client, auth) -> None:  # noqa: ANN001
    body = {"spec": {"kind": "sleep", "fail": "x"}, "idempotency_key": "k", "pad": "y" * (2 << 20)}
    r = client.post("/v1/jobs", json=body, headers=auth)
    assert r.status_code == 413 and "bytes" in r.json()["detail"]
    assert _count(client) == 0


@pytest.mark.parametrize("kind", ["evaluate", "campaign"])
def test_a_spec_with_the_removed_shards_field_is_a_422_naming_the_ray_executor(client, auth, kind) -> None:  # noqa: ANN001
    spec = {
        "kind": kind,
        "shards": 4,
        **(
            {"seed_manifest": "seeds/classic_eval_hard_smoke.yaml", "variants": [{"name": "a"}]}
            if kind == "campaign"
            else {}
        ),
    }
    r = client.post("/v1/jobs", json={"spec": spec}, headers=auth)
    assert r.status_code == 422, r.text
    messages = [e["msg"] for e in r.json()["detail"]]
    assert any("'shards' was removed" in m and "executor: ray" in m for m in messages), messages
    assert _count(client) == 0
