"""Uploaded bundles can be replaced (PUT, or POST with replace=true) and deleted, never while a queued or running
job uses them (409 naming the jobs); project bundles are never changed through the API; a bad replacement
keeps the old files."""

from __future__ import annotations

from tests.unit.api.test_api_registry import _project_bundle, _tar

GZ = {"Content-Type": "application/gzip"}


def _upload(client, auth, name: str, files: dict[str, bytes], **params) -> object:  # noqa: ANN001, ANN003
    return client.post(
        "/v1/bundles", params={"name": name, **params}, content=_tar(files), headers={**auth, **GZ}
    )


def _evaluate_on(client, auth, bundle: str) -> str:  # noqa: ANN001
    spec = {
        "kind": "evaluate",
        "bundle": bundle,
        "matrix": "scenarios/classic_interactions.yaml",
        "planner": {"name": "goal"},
        "scenarios": ["crossing_low"],
        "seeds_per_scenario": 1,
    }
    r = client.post("/v1/jobs", json={"spec": spec}, headers=auth)
    assert r.status_code == 201, r.text
    return r.json()["id"]


def test_replace_and_delete_an_uploaded_bundle(client, auth, settings) -> None:  # noqa: ANN001
    files = _project_bundle()
    assert _upload(client, auth, "mine", files).status_code == 201
    folder = settings.store_root / "bundles" / "mine"
    smaller = {k: v for k, v in files.items() if not k.endswith("stress.yaml") and "crowdnav" not in k}
    r = client.put("/v1/bundles/mine", content=_tar(smaller), headers={**auth, **GZ})
    assert r.status_code == 200, r.text
    assert r.json()["scenarios"] == ["scenarios/classic_interactions.yaml"]
    assert (
        not (folder / "scenarios" / "stress.yaml").exists()
        and (folder / "scenarios" / "classic_interactions.yaml").is_file()
    )
    r = _upload(client, auth, "mine", files, replace="true")  # the POST form of a replacement
    assert r.status_code == 200 and "scenarios/stress.yaml" in r.json()["scenarios"]
    bad = client.put("/v1/bundles/mine", content=_tar({"m.yaml": b"scenarios: [\n"}), headers={**auth, **GZ})
    assert bad.status_code == 422 and (folder / "scenarios" / "stress.yaml").is_file()  # the old files stay
    assert [p.name for p in folder.parent.iterdir()] == ["mine"]  # no staging or old folders left
    assert client.delete("/v1/bundles/mine").status_code == 401
    assert client.delete("/v1/bundles/mine", headers=auth).status_code == 204
    assert client.get("/v1/bundles/mine").status_code == 404 and not folder.exists()
    assert client.delete("/v1/bundles/mine", headers=auth).status_code == 404
    assert _upload(client, auth, "mine", smaller).status_code == 201  # the id is free again


def test_a_bundle_in_use_is_kept_and_the_jobs_are_named(client, auth) -> None:  # noqa: ANN001
    files = _project_bundle()
    assert _upload(client, auth, "busy", files).status_code == 201
    first, second = _evaluate_on(client, auth, "busy"), _evaluate_on(client, auth, "busy")
    for r in (
        client.delete("/v1/bundles/busy", headers=auth),
        client.put("/v1/bundles/busy", content=_tar(files), headers={**auth, **GZ}),
    ):
        assert r.status_code == 409, r.text
        assert first in r.json()["detail"] and second in r.json()["detail"]
    for job in (first, second):
        client.post(f"/v1/jobs/{job}/cancel", headers=auth)
    assert client.delete("/v1/bundles/busy", headers=auth).status_code == 204


def test_project_bundles_cannot_be_changed(client, auth) -> None:  # noqa: ANN001
    r = client.delete("/v1/bundles/builtin", headers=auth)
    assert r.status_code == 409 and "project" in r.json()["detail"]
    r = client.put("/v1/bundles/builtin", content=_tar(_project_bundle()), headers={**auth, **GZ})
    assert r.status_code == 409
    assert client.get("/v1/bundles/builtin").status_code == 200
    r = _upload(client, auth, "again", _project_bundle())
    assert _upload(client, auth, "again", _project_bundle()).status_code == 409
