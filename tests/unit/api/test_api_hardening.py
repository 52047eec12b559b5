"""Hostile input at the API: job budgets and default timeouts, ids resolved at submission, upload
bombs, deep JSON, checkpoint registration."""

from __future__ import annotations

import json
import time

import pytest

from foresight.store import folders, queue
from foresight.store.settings import REPO_ROOT
from tests.archives import hostile, mangled, tar_of

EVALUATE = {
    "kind": "evaluate",
    "scenarios": ["crossing_low"],
    "seeds_per_scenario": 1,
    "max_steps": 10,
    "planner": {"name": "goal"},
}


def _submit(client, auth, spec: dict, **extra) -> object:  # noqa: ANN001, ANN003
    return client.post("/v1/jobs", json={"spec": spec, **extra}, headers=auth)


@pytest.mark.parametrize(
    "spec,size",
    [
        (
            {"kind": "evaluate", "seeds_per_scenario": 1000, "max_steps": 100_000},
            "33000 episodes of 3300000000",
        ),
        (
            {"kind": "collect", "seeds_per_scenario": 10_000, "max_steps": 100_000},
            "330000 episodes of 33000000000",
        ),
        (
            {
                "kind": "campaign",
                "seed_manifest": "seeds/classic_eval_hard.yaml",
                "variants": [{"name": "a"}],
                "checkpoints": ["cv"],
                "seeds_per_scenario": 1000,
                "max_steps": 100_000,
            },
            "episodes of",
        ),
    ],
)
def test_a_job_over_the_step_budget_is_422_naming_fields_and_budget(client, auth, spec, size) -> None:  # noqa: ANN001
    r = _submit(client, auth, spec)
    assert r.status_code == 422, r.text
    detail = r.json()["detail"][0]
    assert size in detail["msg"] and "budget of 200000000 steps" in detail["msg"]
    assert "seeds_per_scenario" in detail["loc"][-1] and "max_steps" in detail["loc"][-1]
    assert client.get("/v1/jobs").json()["count"] == 0


def test_a_small_job_passes_and_gets_the_default_timeout(client, auth, settings) -> None:  # noqa: ANN001
    r = _submit(client, auth, EVALUATE)
    assert r.status_code == 201, r.text
    assert r.json()["timeout_s"] == settings.job_timeout_s == 12 * 3600
    assert _submit(client, auth, {"kind": "sleep"}, timeout_s=5).json()["timeout_s"] == 5


@pytest.mark.parametrize(
    "change,status,what",
    [
        ({"bundle": "nope"}, 404, "unknown bundle id 'nope'"),
        ({"matrix": "scenarios/nope.yaml"}, 422, "nope.yaml"),
        ({"scenarios": ["no_such_scenario"]}, 404, "no_such_scenario"),
        (
            {"planner": {"name": "predictive", "model": "no-such-model"}},
            404,
            "unknown model id 'no-such-model'",
        ),
    ],
)
def test_unknown_inputs_fail_at_submission(client, auth, change, status, what) -> None:  # noqa: ANN001
    r = _submit(client, auth, {**EVALUATE, **change})
    assert r.status_code == status, r.text
    assert what in json.dumps(r.json())
    mix = _submit(client, auth, {"kind": "mix", "base": "no-such-data", "hardcase": "x"})
    assert mix.status_code == 404 and "unknown dataset id 'no-such-data'" in mix.text


@pytest.mark.parametrize("case", sorted(hostile()))
def test_hostile_archives_are_422_naming_the_member(client, auth, settings, case) -> None:  # noqa: ANN001
    data, why, member = hostile()[case]
    t0 = time.monotonic()
    r = client.post("/v1/bundles", params={"name": "bad"}, content=data, headers=auth)
    assert time.monotonic() - t0 < 10
    assert r.status_code == 422, r.text
    detail = r.json()["detail"][0]
    assert why in detail["msg"] and (member is None or member in detail["loc"])
    assert not (settings.store_root / "bundles" / "bad").exists()
    assert client.get("/healthz").status_code == 200


def test_malformed_archives_never_give_500(client, auth) -> None:  # noqa: ANN001
    codes = {
        client.post("/v1/bundles", params={"name": f"m{i}"}, content=data, headers=auth).status_code
        for i, data in enumerate(mangled(seed=7, count=60))
    }
    assert codes <= {201, 422}, codes


def test_an_alias_bomb_in_a_bundle_is_422_at_once(client, auth) -> None:  # noqa: ANN001
    lines = ['a0: &a0 ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    lines += [f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 9)}]" for i in range(1, 8)]
    t0 = time.process_time()
    r = client.post(
        "/v1/bundles",
        params={"name": "bomb"},
        content=tar_of({"m.yaml": "\n".join(lines).encode()}),
        headers=auth,
    )
    assert r.status_code == 422 and "aliases expand" in r.text and time.process_time() - t0 < 2.0


def _nested(depth: int) -> dict:
    value: dict = {}
    for _ in range(depth):
        value = {"k": value}
    return value


@pytest.mark.parametrize("depth", [255, 5000, 100_000])
def test_deep_json_is_422_and_nothing_is_stored(client, auth, depth) -> None:  # noqa: ANN001
    spec = {**EVALUATE, "planner": {"name": "goal", "config": _nested(depth)}}
    body = (
        json.dumps({"spec": spec})
        if depth < 900
        else '{"spec": {"kind": "sleep", "x": ' + "[" * depth + "]" * depth + "}}"
    )
    r = client.post("/v1/jobs", content=body, headers={**auth, "Content-Type": "application/json"})
    assert r.status_code == 422, r.text[:300]
    assert "nested deeper than 64 levels" in r.text
    assert client.get("/v1/jobs").status_code == 200 and client.get("/v1/jobs").json()["count"] == 0


def _finished_job_with(client, auth, engine, settings, content: bytes) -> str:  # noqa: ANN001
    job = client.post("/v1/jobs", json={"spec": {"kind": "sleep"}}, headers=auth).json()
    c = queue.claim(engine, "w", ["sleep"], 30)
    rel = f"jobs/{job['id']}/ckpt.pt"
    folders.write_atomic(folders.resolve_under(settings.store_root, rel), content)
    queue.finish(
        engine, job["id"], "w", c["attempts"], {}, folders.scan(settings.store_root, f"jobs/{job['id']}")
    )
    return job["id"]


def test_registration_refuses_what_is_not_a_checkpoint_and_starts_candidates(
    client, auth, engine, settings
) -> None:  # noqa: ANN001
    text = _finished_job_with(client, auth, engine, settings, b"just some text\n")
    r = client.post("/v1/models", json={"id": "t", "job_id": text, "artifact": "ckpt.pt"}, headers=auth)
    assert r.status_code == 422 and "not a readable checkpoint" in r.text and "ckpt.pt" in r.text
    assert client.get("/v1/models/t").status_code == 404
    good = _finished_job_with(
        client, auth, engine, settings, (REPO_ROOT / "model" / "predictor-sim-default.pt").read_bytes()
    )
    body = {"id": "g", "job_id": good, "artifact": "ckpt.pt"}
    assert client.post("/v1/models", json={**body, "status": "promoted"}, headers=auth).status_code == 422
    assert client.post("/v1/models", json=body, headers=auth).json()["status"] == "candidate"


def test_a_checkpoint_rewritten_in_place_is_refused_by_the_resolver(client, auth, engine, settings) -> None:  # noqa: ANN001
    import os

    from foresight.store.registry import Resolver

    good = _finished_job_with(
        client, auth, engine, settings, (REPO_ROOT / "model" / "predictor-sim-default.pt").read_bytes()
    )
    assert (
        client.post(
            "/v1/models", json={"id": "g", "job_id": good, "artifact": "ckpt.pt"}, headers=auth
        ).status_code
        == 201
    )
    resolver = Resolver(settings, engine)
    path = resolver.model("g")
    st = path.stat()
    data = bytearray(path.read_bytes())
    data[-100] ^= 0xFF
    path.write_bytes(bytes(data))
    os.utime(path, ns=(st.st_atime_ns, st.st_mtime_ns))  # same size, same mtime
    with pytest.raises(Exception, match="does not match its registered sha256"):
        resolver.model("g")
