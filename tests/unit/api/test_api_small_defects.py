"""The hostile-input probe's smaller defects: SSE id bounds, NUL in stored text, a stale LeaseExpired error,
numeric and name bounds, ?kind= validation, relative paths in job errors, OPTIONS' Allow header."""

from __future__ import annotations

import time

import pytest

from foresight.store import job_reads, queue


def _job(client, auth) -> dict:  # noqa: ANN001
    return client.post("/v1/jobs", json={"spec": {"kind": "sleep"}}, headers=auth).json()


def test_event_ids_beyond_64_bits_are_422(client, auth) -> None:  # noqa: ANN001
    job = _job(client, auth)
    assert client.get(f"/v1/jobs/{job['id']}/events", params={"after": 2**63}).status_code == 422
    assert (
        client.get(f"/v1/jobs/{job['id']}/events", headers={"Last-Event-ID": str(2**63)}).status_code == 422
    )
    client.post(f"/v1/jobs/{job['id']}/cancel", headers=auth)  # finished: its stream ends
    last = client.get(f"/v1/jobs/{job['id']}/events", params={"after": 2**63 - 1})
    assert last.status_code == 200 and "event: end" in last.text


def test_an_unknown_kind_filter_is_422(client) -> None:  # noqa: ANN001
    r = client.get("/v1/jobs", params={"kind": ".exe"})
    assert r.status_code == 422 and "kind" in str(r.json()["detail"])
    assert client.get("/v1/jobs", params={"kind": "evaluate"}).status_code == 200


def test_nul_characters_are_stored_escaped(client, auth, engine) -> None:  # noqa: ANN001
    job = _job(client, auth)
    c = queue.claim(engine, "w", ["sleep"], 30)
    queue.report_progress(engine, job["id"], "w", c["attempts"], 0.5, "half\x00way")
    queue.fail_or_retry(engine, job["id"], "w", c["attempts"], "Bad\x00Type", "bad\x00byte", retry=False)
    got = job_reads.get_job(engine, job["id"])
    assert (got["error_type"], got["error_message"]) == ("Bad\\x00Type", "bad\\x00byte")
    assert all("\x00" not in e["message"] for e in job_reads.events_after(engine, job["id"], 0))


def test_success_after_a_re_lease_clears_the_stale_error(client, auth, engine) -> None:  # noqa: ANN001
    job = _job(client, auth)
    queue.claim(engine, "w1", ["sleep"], lease_s=0.05)
    time.sleep(0.1)
    queue.reap_stale(engine)
    assert job_reads.get_job(engine, job["id"])["error_type"] == "LeaseExpired"
    c = queue.claim(engine, "w2", ["sleep"], 30)
    queue.finish(engine, job["id"], "w2", c["attempts"], {"ok": True})
    got = client.get(f"/v1/jobs/{job['id']}").json()
    assert got["status"] == "succeeded" and got["error"] is None


@pytest.mark.parametrize(
    "spec,field",
    [
        ({"kind": "collect", "base_seed": 10**30}, "base_seed"),
        ({"kind": "train", "dataset": "d", "batch_size": 10**9}, "batch_size"),
        ({"kind": "train", "dataset": "d", "lr": 1e300}, "lr"),
        ({"kind": "evaluate", "scenarios": ["x" * 200_000]}, "scenarios"),
        ({"kind": "evaluate", "scenarios": ["a\x00b"]}, "scenarios"),
        ({"kind": "simulate", "seeds": [2**40]}, "seeds"),
        ({"kind": "campaign", "seed_manifest": "s.yaml", "variants": [{"name": "v\x00"}]}, "name"),
    ],
)
def test_unbounded_fields_are_422(client, auth, spec, field) -> None:  # noqa: ANN001
    r = client.post("/v1/jobs", json={"spec": spec}, headers=auth)
    assert r.status_code == 422, r.text[:300]
    assert field in str(r.json()["detail"])


def test_options_lists_every_method_of_the_path(client) -> None:  # noqa: ANN001
    allow = {m.strip() for m in client.options("/v1/jobs").headers["allow"].split(",")}
    assert {"GET", "POST"} <= allow
    allow = {m.strip() for m in client.options("/v1/jobs/abc").headers["allow"].split(",")}
    assert {"GET", "DELETE"} <= allow
