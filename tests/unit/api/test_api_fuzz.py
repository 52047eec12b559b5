"""Our own fuzzing of every operation in the OpenAPI document, beside schemathesis (test_api_schemathesis.py):
it mixes hostile strings (server paths, '..', SQL, huge values) into otherwise schema-shaped requests, and it
checks what schemathesis does not: refused submissions store nothing, and every error body is JSON."""

from __future__ import annotations

import random
from typing import Any

import pytest

NASTY_STRINGS = [
    "",
    " ",
    "..",
    "../../etc/passwd",
    "/etc/passwd",
    "C:\\\\x",
    "%2e%2e%2f",
    "a" * 5000,
    "\u00ff\u2603",
    "null",
    "0",
    "-1",
    "1e309",
    "NaN",
    "x/../../y",
    "~root",
    "${HOME}",
    "'; DROP TABLE jobs; --",
]
NASTY_NUMBERS = [0, -1, -(2**63), 2**63, 10**30, 1.5, -0.0, 1e308]


def _resolve(schema: dict, doc: dict) -> dict:
    while "$ref" in schema:
        node: Any = doc
        for part in schema["$ref"].lstrip("#/").split("/"):
            node = node[part]
        schema = node
    return schema


def generate(schema: dict, doc: dict, rng: random.Random, depth: int = 0) -> Any:
    """A value that mostly follows ``schema`` and sometimes breaks it."""
    schema = _resolve(schema, doc)
    if rng.random() < 0.15 or depth > 6:
        return rng.choice([*NASTY_STRINGS, *NASTY_NUMBERS, None, [], {}, True])
    for key in ("anyOf", "oneOf"):
        if key in schema:
            return generate(rng.choice(schema[key]), doc, rng, depth + 1)
    if "const" in schema:
        return schema["const"]
    if "enum" in schema:
        return rng.choice(schema["enum"])
    kind = schema.get("type")
    if kind == "object" or "properties" in schema:
        props = schema.get("properties", {})
        required = set(schema.get("required", []))
        return {
            k: generate(v, doc, rng, depth + 1)
            for k, v in props.items()
            if k in required or rng.random() < 0.5
        }
    if kind == "array":
        return [generate(schema.get("items", {}), doc, rng, depth + 1) for _ in range(rng.randint(0, 3))]
    if kind == "integer":
        return rng.choice([*NASTY_NUMBERS[:4], rng.randint(-5, 50)])
    if kind == "number":
        return rng.choice([*NASTY_NUMBERS, rng.uniform(-5, 50)])
    if kind == "boolean":
        return rng.random() < 0.5
    if kind == "string":
        return rng.choice([*NASTY_STRINGS, "sleep", "builtin", "crossing_low"])
    return rng.choice(NASTY_STRINGS)


def _operations(doc: dict) -> list[tuple[str, str, dict]]:
    ops = []
    for path, item in doc["paths"].items():
        for method, op in item.items():
            if path.endswith("/events"):
                continue  # a stream: covered by its own test
            ops.append((path, method, op))
    return ops


@pytest.mark.parametrize("seed", range(3))
def test_no_input_breaks_the_server(client, auth, seed: int) -> None:  # noqa: ANN001
    doc = client.get("/openapi.json").json()
    rng = random.Random(seed)
    jobs_before = client.get("/v1/jobs").json()["count"]
    accepted_jobs = 0
    seen: dict[int, int] = {}
    for path, method, op in _operations(doc):
        for _ in range(12):
            url = path
            params = {}
            for p in op.get("parameters", []):
                value = generate(p.get("schema", {}), doc, rng)
                if p["in"] == "path":
                    url = url.replace("{" + p["name"] + "}", str(value).replace("/", "%2F") or "x")
                elif (
                    p["in"] == "query"
                    and (p.get("required") or rng.random() < 0.5)
                    and not isinstance(value, dict)
                ):
                    params[p["name"]] = value if not isinstance(value, list) else [str(v) for v in value]
            kwargs: dict[str, Any] = {"params": params, "headers": auth if rng.random() < 0.8 else {}}
            content = op.get("requestBody", {}).get("content", {})
            if "application/json" in content:
                kwargs["json"] = generate(content["application/json"]["schema"], doc, rng)
            elif content:
                kwargs["content"] = rng.choice([b"", b"\x00" * 100, b"PK\x03\x04garbage", b"not an archive"])
            r = client.request(method.upper(), url, **kwargs)
            seen[r.status_code] = seen.get(r.status_code, 0) + 1
            assert r.status_code < 500, (method, url, kwargs, r.text)
            if r.status_code >= 400:
                assert isinstance(r.json().get("detail"), str | list) and r.json()["detail"], (
                    method,
                    url,
                    r.text,
                )
            if method == "post" and path == "/v1/jobs" and r.status_code == 201:
                accepted_jobs += 1
    assert (
        client.get("/v1/jobs").json()["count"] == jobs_before + accepted_jobs
    )  # refused submissions stored nothing
    assert len(seen) >= 4, seen  # the generator reaches successes and several kinds of refusal
    print(sorted(seen.items()))


def test_events_stream(client, auth, engine) -> None:  # noqa: ANN001
    from foresight.store import queue

    job = client.post("/v1/jobs", json={"spec": {"kind": "sleep"}}, headers=auth).json()
    c = queue.claim(engine, "w", ["sleep"], 30)
    queue.report_progress(engine, job["id"], "w", c["attempts"], 0.5, "half way")
    queue.log(engine, job["id"], "a log line")
    queue.finish(engine, job["id"], "w", c["attempts"], {})
    with client.stream("GET", f"/v1/jobs/{job['id']}/events") as r:
        assert r.headers["content-type"].startswith("text/event-stream")
        text = r.read().decode()
    events = [line.split(": ", 1)[1] for line in text.splitlines() if line.startswith("event: ")]
    assert events == ["status", "status", "progress", "log", "status", "end"]
    assert "half way" in text and '"status": "succeeded"' in text
    resumed = client.get(f"/v1/jobs/{job['id']}/events", headers={"Last-Event-ID": "4"}).text
    assert "half way" not in resumed and "succeeded" in resumed
    assert client.get("/v1/jobs/nope/events").status_code == 404
