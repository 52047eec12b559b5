"""Job names, tags and notes: set at submission, edited with PATCH, filtered in the list (a real SQLite file),
and a database migrated before labels existed keeps its jobs and gains empty labels."""

from __future__ import annotations

import sqlite3
from pathlib import Path

from foresight.store.session import make_engine, upgrade


def _submit(client, auth, **labels) -> dict:  # noqa: ANN001, ANN003
    r = client.post("/v1/jobs", json={"spec": {"kind": "sleep"}, **labels}, headers=auth)
    assert r.status_code == 201, r.text
    return r.json()


def _ids(client, query: str) -> set[str]:  # noqa: ANN001
    r = client.get(f"/v1/jobs?{query}")
    assert r.status_code == 200, r.text
    return {j["id"] for j in r.json()["data"]}


def test_labels_at_submission_are_filterable(client, auth) -> None:  # noqa: ANN001
    a = _submit(
        client, auth, name="baseline orca", tags=["baseline", "orca"], note="first try, typical crowd"
    )
    b = _submit(client, auth, name="mpc run", tags=["orca", "ablation:no-pred", "orca"])
    c = _submit(client, auth)
    assert (
        a["name"] == "baseline orca" and a["tags"] == ["baseline", "orca"] and a["note"].startswith("first")
    )
    assert b["tags"] == ["orca", "ablation:no-pred"]  # duplicates dropped, order kept
    assert c["name"] is None and c["tags"] == [] and c["note"] == ""
    assert client.get(f"/v1/jobs/{a['id']}").json()["tags"] == ["baseline", "orca"]
    assert _ids(client, "tag=orca") == {a["id"], b["id"]}
    assert _ids(client, "tag=orca&tag=baseline") == {a["id"]}  # every tag given
    assert _ids(client, "tag=nothing") == set()
    assert _ids(client, "name=mpc%20run") == {b["id"]}
    assert _ids(client, "q=TYPICAL") == {a["id"]}  # the note, case-insensitive
    assert _ids(client, "q=run") == {b["id"]}
    assert _ids(client, "q=%25") == set()  # LIKE wildcards are literal
    assert _ids(client, "tag=orca&status=queued&kind=sleep") == {a["id"], b["id"]}
    assert client.get("/v1/jobs?tag=orca").json()["count"] == 2


def test_patch_edits_labels_of_any_job(client, auth) -> None:  # noqa: ANN001
    job = _submit(client, auth, name="x", tags=["a", "b"])
    path = f"/v1/jobs/{job['id']}"
    r = client.patch(
        path,
        json={"note": "seen: oscillates at the door", "add_tags": ["c"], "remove_tags": ["a"]},
        headers=auth,
    )
    assert r.status_code == 200, r.text
    assert r.json()["tags"] == ["b", "c"] and r.json()["name"] == "x" and "door" in r.json()["note"]
    assert _ids(client, "tag=a") == set() and _ids(client, "tag=c") == {job["id"]}
    r = client.patch(path[:-20], json={"name": None, "tags": ["z"]}, headers=auth)  # a 12-character short id
    assert r.status_code == 200, r.text
    assert r.json()["name"] is None and r.json()["tags"] == ["z"] and "door" in r.json()["note"]
    client.post(f"{path}/cancel", headers=auth)
    assert client.patch(path, json={"name": "cancelled one"}, headers=auth).json()["name"] == "cancelled one"


def test_bad_labels_are_422_naming_the_field(client, auth) -> None:  # noqa: ANN001
    for body, field in (
        ({"tags": ["has space"]}, "tags"),
        ({"tags": ["x"] * 21}, "tags"),
        ({"name": ""}, "name"),
        ({"name": "a\nb"}, "name"),
        ({"note": "x" * 10_001}, "note"),
    ):
        r = client.post("/v1/jobs", json={"spec": {"kind": "sleep"}, **body}, headers=auth)
        assert r.status_code == 422 and r.json()["detail"][0]["loc"][:2] == ["body", field], r.text
    job = _submit(client, auth)
    r = client.patch(f"/v1/jobs/{job['id']}", json={"title": "x"}, headers=auth)
    assert r.status_code == 422 and "title" in r.text
    assert client.patch(f"/v1/jobs/{job['id']}", json={"name": "x"}).status_code == 401
    assert client.patch("/v1/jobs/" + "0" * 32, json={"name": "x"}, headers=auth).status_code == 404
    r = client.get("/v1/jobs?tags=x")
    assert r.status_code == 422 and "tags" in r.json()["detail"][0]["msg"]
    assert client.get("/v1/jobs?tag=a%20b").status_code == 422


def test_upgrade_keeps_jobs_of_a_database_from_before_labels(tmp_path: Path) -> None:
    """A database at the previous revision, with a job in it, migrates: the job gets no name, no tags and an
    empty note, and can be tagged afterwards."""
    from foresight.store import job_reads, labels

    path = tmp_path / "old.db"
    url = f"sqlite:///{path}"
    upgrade(url, "3ea855f35745")
    with sqlite3.connect(path) as conn:
        conn.execute(
            "INSERT INTO jobs (id, kind, spec, status, priority, attempts, max_attempts, cancel_requested, "
            "progress, message, created_at) VALUES ('"
            + "a"
            * 32
            + "', 'sleep', '{}', 'succeeded', 0, 1, 3, 0, "
            "1.0, '', 1.0)"
        )
    upgrade(url)
    engine = make_engine(url)
    job = job_reads.get_job(engine, "a" * 32)
    assert job["name"] is None and job["tags"] == [] and job["note"] == ""
    labels.edit(engine, "a" * 32, add=["old"])
    assert job_reads.list_jobs(engine, tags=["old"])[0] == 1
    engine.dispose()


def test_dashboard_lists_and_filters_by_labels(client, auth) -> None:  # noqa: ANN001
    a = _submit(client, auth, name="baseline orca", tags=["baseline"], note="the reference run")
    b = _submit(client, auth, name="other", tags=["ablation"])
    page = client.get("/ui/jobs").text
    assert 'value="baseline"' in page and 'value="ablation"' in page  # the tags offered as filters
    rows = client.get("/ui/jobs/rows?tag=baseline").text
    assert a["id"] in rows and b["id"] not in rows and "baseline orca" in rows and "the reference run" in rows
    rows = client.get("/ui/jobs/rows?q=REFERENCE").text
    assert a["id"] in rows and b["id"] not in rows
    assert "the reference run" in client.get(f"/ui/jobs/{a['id']}").text
