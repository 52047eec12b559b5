"""Bundles (upload validation) and the model registry (shipped entries, promote, delete rules)."""

from __future__ import annotations

import hashlib
import io
import tarfile
import zipfile
from pathlib import Path

import pytest
import yaml

from foresight.core.errors import CoreError
from foresight.store.settings import REPO_ROOT

CONFIGS = REPO_ROOT / "configs"


def _tar(files: dict[str, bytes], extra: list[tarfile.TarInfo] = ()) -> bytes:  # noqa: B006
    buf = io.BytesIO()
    with tarfile.open(fileobj=buf, mode="w:gz") as tar:
        for name, data in files.items():
            info = tarfile.TarInfo(name)
            info.size = len(data)
            tar.addfile(info, io.BytesIO(data))
        for info in extra:
            tar.addfile(info)
    return buf.getvalue()


def _project_bundle() -> dict[str, bytes]:
    """The project's classic matrix with its archetypes and maps, as archive members."""
    files = {}
    for path in sorted(CONFIGS.rglob("*")):
        if (
            path.is_file()
            and path.suffix in {".yaml", ".svg"}
            and ("scenarios" in path.parts or "maps" in path.parts)
        ):
            files[path.relative_to(CONFIGS).as_posix()] = path.read_bytes()
    return files


def test_builtin_bundle_registered_at_start_up(client) -> None:  # noqa: ANN001
    bundles = client.get("/v1/bundles").json()
    assert "builtin" in [b["id"] for b in bundles["data"]]
    scenarios = client.get("/v1/bundles/builtin/scenarios").json()
    assert scenarios and {"matrix", "name", "map", "seeds"} <= scenarios[0].keys()


def test_upload_valid_bundle(client, auth, settings) -> None:  # noqa: ANN001
    r = client.post(
        "/v1/bundles",
        params={"name": "mine"},
        content=_tar(_project_bundle()),
        headers={**auth, "Content-Type": "application/gzip"},
    )
    assert r.status_code == 201, r.text
    crowdnav = ["circle_crossing", "crowdnavpp_no_rand", "crowdnavpp_rand", "square_crossing"]
    assert r.json()["scenarios"] == [
        "scenarios/classic_interactions.yaml",
        *(f"scenarios/crowdnav/{name}.yaml" for name in crowdnav),
        "scenarios/stress.yaml",
    ]
    assert (settings.store_root / "bundles" / "mine" / "scenarios" / "classic_interactions.yaml").is_file()
    assert len(client.get("/v1/bundles/mine/scenarios").json()) > 0
    again = client.post("/v1/bundles", params={"name": "mine"}, content=_tar(_project_bundle()), headers=auth)
    assert again.status_code == 409


def _symlink() -> tarfile.TarInfo:
    info = tarfile.TarInfo("scenarios/link.yaml")
    info.type, info.linkname = tarfile.SYMTYPE, "/etc/passwd"
    return info


@pytest.mark.parametrize(
    "archive,why",
    [
        (lambda: _tar({"../evil.yaml": b"scenarios: []"}), ".."),
        (lambda: _tar({"/abs/evil.yaml": b"scenarios: []"}), "absolute"),
        (lambda: _tar({"m.yaml": b"includes: [../../etc/x.yaml]"}), "leaves the bundle"),
        (lambda: _tar({"m.yaml": b"map_registry: /etc/registry.yaml\nscenarios: []"}), "absolute"),
        (lambda: _tar({"m.yaml": b"scenarios: [\n"}), "YAML"),
        (lambda: _tar({"run.sh": b"echo hi"}), "file type"),
        (lambda: _tar({"readme.md": b"no matrix"}), "no scenario matrix"),
        (lambda: _tar({"m.yaml": b"scenarios: []"}, [_symlink()]), "links"),
        (lambda: b"not an archive at all", "not a zip or tar"),
        (lambda: _zip({"../x.yaml": b"scenarios: []"}), ".."),
    ],
)
def test_upload_invalid_bundles_are_422_and_store_nothing(client, auth, settings, archive, why) -> None:  # noqa: ANN001
    r = client.post("/v1/bundles", params={"name": "bad"}, content=archive(), headers=auth)
    assert r.status_code == 422, r.text
    assert why in str(r.json()["detail"])
    assert client.get("/v1/bundles/bad").status_code == 404
    assert not (settings.store_root / "bundles" / "bad").exists()


def _zip(files: dict[str, bytes]) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        for name, data in files.items():
            z.writestr(name, data)
    return buf.getvalue()


def test_upload_name_and_auth(client, auth) -> None:  # noqa: ANN001
    data = _tar(_project_bundle())
    assert client.post("/v1/bundles", params={"name": "x"}, content=data).status_code == 401
    assert client.post("/v1/bundles", params={"name": "../x"}, content=data, headers=auth).status_code == 422
    assert client.post("/v1/bundles", params={"name": "builtin"}, content=data, headers=auth).status_code in (
        409,
        422,
    )


def test_shipped_models_are_read_only(tmp_path: Path, settings, auth) -> None:  # noqa: ANN001
    from fastapi.testclient import TestClient

    from foresight.api.main import create_app

    repo = tmp_path / "repo"
    ckpt = repo / "model" / "checkpoint.bin"
    ckpt.parent.mkdir(parents=True)
    ckpt.write_bytes(b"weights")
    registry = repo / "model" / "registry.yaml"
    registry.write_text(
        yaml.safe_dump(
            {
                "models": [
                    {
                        "id": "shipped-1",
                        "path": "model/checkpoint.bin",
                        "sha256": hashlib.sha256(b"weights").hexdigest(),
                        "provenance": "test",
                        "tags": ["default", "predictor"],
                    }
                ]
            }
        )
    )
    with TestClient(create_app(settings.model_copy(update={"model_registry": registry}))) as c:
        model = c.get("/v1/models/shipped-1").json()
        assert model["read_only"] and model["status"] == "default"
        assert c.delete("/v1/models/shipped-1", headers=auth).status_code == 409
        assert c.post("/v1/models/shipped-1/promote", headers=auth).status_code == 409
        resolver = c.app.state.resolver
        assert resolver.model("shipped-1") == ckpt.resolve()
        assert resolver.model("default") == ckpt.resolve()
        ckpt.write_bytes(b"tampered")
        with pytest.raises(CoreError, match="sha256"):
            resolver.model("shipped-1")


def test_register_promote_delete(client, auth, engine, settings) -> None:  # noqa: ANN001
    from foresight.store import folders, queue

    job = client.post("/v1/jobs", json={"spec": {"kind": "sleep"}}, headers=auth).json()
    body = {"id": "m1", "job_id": job["id"], "artifact": "ckpt.pt"}
    assert client.post("/v1/models", json=body, headers=auth).status_code == 409  # job not finished
    c = queue.claim(engine, "w", ["sleep"], 30)
    rel = f"jobs/{job['id']}/ckpt.pt"
    weights = (REPO_ROOT / "model" / "predictor-sim-default.pt").read_bytes()  # registration checks it loads
    folders.write_atomic(folders.resolve_under(settings.store_root, rel), weights)
    queue.finish(
        engine, job["id"], "w", c["attempts"], {}, folders.scan(settings.store_root, f"jobs/{job['id']}")
    )
    assert client.post("/v1/models", json={**body, "artifact": "../x"}, headers=auth).status_code == 422
    assert client.post("/v1/models", json={**body, "artifact": "nope.pt"}, headers=auth).status_code == 404
    created = client.post("/v1/models", json=body, headers=auth)
    assert created.status_code == 201 and created.json()["status"] == "candidate"
    assert created.json()["sha256"] == hashlib.sha256(weights).hexdigest()
    assert client.post("/v1/models", json={**body}, headers=auth).status_code == 409
    body2 = {**body, "id": "m2"}
    assert client.post("/v1/models", json=body2, headers=auth).status_code == 201
    assert (
        client.post("/v1/models/m1/promote", json={"to": "default"}, headers=auth).json()["status"]
        == "default"
    )
    assert (
        client.post("/v1/models/m2/promote", json={"to": "default"}, headers=auth).json()["status"]
        == "default"
    )
    assert client.get("/v1/models/m1").json()["status"] == "promoted"
    assert client.get("/v1/models", params={"status": "default"}).json()["count"] == 1
    assert client.delete("/v1/models/m2", headers=auth).status_code == 409  # the default
    assert client.delete("/v1/models/m1", headers=auth).status_code == 204
    assert "m2" in client.get("/v1/models/export").text


def test_a_model_trained_in_another_frame_is_refused_at_submission(client, auth, engine, settings) -> None:  # noqa: ANN001
    """An ETH/UCY-style (pedestrian-frame) checkpoint registers, but a planner spec naming it is a 422 naming the model
    id before anything is queued; the same spec with the simulator-trained model is accepted."""
    from foresight.core.predict.nn.checkpoint import read_checkpoint, save_checkpoint
    from foresight.store import folders, queue

    job = client.post("/v1/jobs", json={"spec": {"kind": "sleep"}}, headers=auth).json()
    c = queue.claim(engine, "w", ["sleep"], 30)
    payload = read_checkpoint(REPO_ROOT / "model" / "predictor-sim-default.pt")
    for name, frame in (("robot.pt", "robot"), ("ethucy.pt", "pedestrian")):
        payload["feature_schema"]["frame_convention"] = frame
        save_checkpoint(payload, folders.resolve_under(settings.store_root, f"jobs/{job['id']}/{name}"))
    queue.finish(
        engine, job["id"], "w", c["attempts"], {}, folders.scan(settings.store_root, f"jobs/{job['id']}")
    )
    for ident, name in (("sim-1", "robot.pt"), ("eth-1", "ethucy.pt")):
        body = {"id": ident, "job_id": job["id"], "artifact": name}
        assert client.post("/v1/models", json=body, headers=auth).status_code == 201
    assert client.get("/v1/models/eth-1").json()["lineage"]["frame_convention"] == "pedestrian"
    before = client.get("/v1/jobs").json()["count"]
    spec = {
        "kind": "evaluate",
        "bundle": "builtin",
        "matrix": "scenarios/classic_interactions.yaml",
        "scenarios": ["crossing_low"],
        "seeds_per_scenario": 1,
        "planner": {"name": "predictive", "model": "eth-1"},
    }
    refused = client.post("/v1/jobs", json={"spec": spec}, headers=auth)
    assert refused.status_code == 422, refused.text
    assert (
        "model 'eth-1' was trained in the 'pedestrian' frame" in refused.text
        and "planner.model" in refused.text
    )
    campaign = {
        "kind": "campaign",
        "bundle": "builtin",
        "matrix": "scenarios/classic_interactions.yaml",
        "seed_manifest": "seeds/classic_eval_hard_smoke.yaml",
        "grid": "planners/predictive_grid_v1.yaml",
        "checkpoints": ["sim-1", "eth-1"],
    }
    refused = client.post("/v1/jobs", json={"spec": campaign}, headers=auth)
    assert refused.status_code == 422 and "model 'eth-1'" in refused.text, refused.text
    assert client.get("/v1/jobs").json()["count"] == before  # nothing queued
    spec["planner"]["model"] = "sim-1"
    assert client.post("/v1/jobs", json={"spec": spec}, headers=auth).status_code == 201


def test_a_relaxed_model_can_never_be_promoted(client, auth, engine, settings) -> None:  # noqa: ANN001
    """A pipeline whose gates are relaxed on purpose registers its model as ``relaxed``: promote and default are 409."""
    from foresight.store import folders, queue, registry

    job = client.post("/v1/jobs", json={"spec": {"kind": "sleep"}}, headers=auth).json()
    c = queue.claim(engine, "w", ["sleep"], 30)
    rel = f"jobs/{job['id']}/model.pt"
    weights = (REPO_ROOT / "model" / "predictor-sim-default.pt").read_bytes()
    folders.write_atomic(folders.resolve_under(settings.store_root, rel), weights)
    queue.finish(
        engine, job["id"], "w", c["attempts"], {}, folders.scan(settings.store_root, f"jobs/{job['id']}")
    )
    registry.register_checkpoint(engine, settings, model_id="smoke-1", job_id=job["id"], status="relaxed")
    assert client.get("/v1/models/smoke-1").json()["status"] == "relaxed"
    assert client.get("/v1/models", params={"status": "relaxed"}).json()["count"] == 1
    for to in ("promoted", "default"):
        refused = client.post("/v1/models/smoke-1/promote", json={"to": to}, headers=auth)
        assert refused.status_code == 409 and "never be promoted" in refused.text
    assert client.get("/v1/models/smoke-1").json()["status"] == "relaxed"


def test_a_checkpoint_trained_on_recordings_registers_the_scenes_it_saw(
    client, auth, engine, settings
) -> None:  # noqa: ANN001
    """A fold checkpoint's recorded scenes (``dataset.scenes``) become its lineage, so whoever runs it on a replay can
    see which scene it held out; a simulator checkpoint records none."""
    from foresight.core.predict.nn.checkpoint import read_checkpoint, save_checkpoint
    from foresight.store import folders, queue

    job = client.post("/v1/jobs", json={"spec": {"kind": "sleep"}}, headers=auth).json()
    c = queue.claim(engine, "w", ["sleep"], 30)
    payload = read_checkpoint(REPO_ROOT / "model" / "predictor-sim-default.pt")
    save_checkpoint(payload, folders.resolve_under(settings.store_root, f"jobs/{job['id']}/sim.pt"))
    scenes = {"test": ["biwi_hotel"], "train": ["biwi_eth_train"], "val": ["biwi_eth_val"]}
    payload["feature_schema"]["frame_convention"] = "focal_pedestrian"
    payload["dataset"] = {**payload["dataset"], "source": "real", "scenes": scenes}
    save_checkpoint(payload, folders.resolve_under(settings.store_root, f"jobs/{job['id']}/hotel.pt"))
    queue.finish(
        engine, job["id"], "w", c["attempts"], {}, folders.scan(settings.store_root, f"jobs/{job['id']}")
    )
    for ident, name in (("sim-2", "sim.pt"), ("hotel-fold", "hotel.pt")):
        body = {"id": ident, "job_id": job["id"], "artifact": name}
        assert client.post("/v1/models", json=body, headers=auth).status_code == 201
    lineage = client.get("/v1/models/hotel-fold").json()["lineage"]
    assert lineage["scenes"] == scenes and lineage["frame_convention"] == "focal_pedestrian"
    assert "scenes" not in client.get("/v1/models/sim-2").json()["lineage"]
