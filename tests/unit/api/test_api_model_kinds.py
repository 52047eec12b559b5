"""One registry for every kind of model: a predictor plug-in with its artifact folder and an external predictor
with its files register beside checkpoints (kind, declaration, sha256 of every file), promote and become the
default under the same rule, and are refused by id once a file changed."""

from __future__ import annotations

import hashlib
import io
import json
import sys
import tarfile

import pytest

from foresight.core.errors import CoreError
from foresight.core.predict.external import ENV
from foresight.store.settings import REPO_ROOT

ARTIFACT_NAMED = """
import json, os, sys
folder = os.environ.get("FORESIGHT_PREDICTOR_ARTIFACTS")
name = open(os.path.join(folder, "name.txt")).read().strip() if folder else "no-files"
for line in sys.stdin:
    if json.loads(line)["type"] == "hello":
        print(json.dumps({"type": "hello", "protocol": 1, "name": name, "frame": "world", "modes": 1,
                          "timebase": {"dt": 0.2, "history": 5, "horizon": 12}}), flush=True)
"""  # an external predictor that declares the name its registered files give it
FILES = {"weights.bin": b"\x00\x01weights", "conf/params.json": b'{"noise": 0.1}'}


def _tar(files: dict[str, bytes]) -> bytes:
    buf = io.BytesIO()
    with tarfile.open(fileobj=buf, mode="w:gz") as tar:
        for name, data in files.items():
            info = tarfile.TarInfo(name)
            info.size = len(data)
            tar.addfile(info, io.BytesIO(data))
    return buf.getvalue()


def _register(client, auth, ident, kind, predictor, files=None):  # noqa: ANN001, ANN202
    params = {"id": ident, "kind": kind, "predictor": predictor, "tag": ["mine"]}
    return client.post(
        "/v1/models/predictors", params=params, content=_tar(files) if files else b"", headers=auth
    )


def _register_checkpoint(client, auth, engine, settings, ident: str) -> None:  # noqa: ANN001
    from foresight.store import folders, queue

    job = client.post("/v1/jobs", json={"spec": {"kind": "sleep"}}, headers=auth).json()
    c = queue.claim(engine, "w", ["sleep"], 30)
    rel = f"jobs/{job['id']}/ckpt.pt"
    weights = (REPO_ROOT / "model" / "predictor-sim-default.pt").read_bytes()
    folders.write_atomic(folders.resolve_under(settings.store_root, rel), weights)
    queue.finish(
        engine, job["id"], "w", c["attempts"], {}, folders.scan(settings.store_root, f"jobs/{job['id']}")
    )
    body = {"id": ident, "job_id": job["id"], "artifact": "ckpt.pt"}
    assert client.post("/v1/models", json=body, headers=auth).status_code == 201


def test_a_plugin_with_its_folder_registers_promotes_and_is_refused_once_a_file_changed(
    client, auth, engine, settings
) -> None:  # noqa: ANN001
    from foresight.core.evaluation.plannerspec import build_planner, resolve_planner
    from foresight.core.runtime.context import StageContext

    created = _register(client, auth, "noise-1", "plugin", "cv_noise", FILES)
    assert created.status_code == 201, created.text
    m = created.json()
    assert m["kind"] == "plugin" and m["status"] == "candidate" and m["tags"] == ["mine"]
    assert m["time_base"] == {"dt": 0.4, "history": 8, "horizon": 12}  # its declaration
    assert m["lineage"]["predictor"] == "cv_noise" and m["lineage"]["frame"] == "world"
    assert m["lineage"]["modes"] == 20
    files = m["lineage"]["files"]
    assert files["files/weights.bin"] == hashlib.sha256(FILES["weights.bin"]).hexdigest()
    assert {"files/conf/params.json", "predictor.json"} <= files.keys()
    listing = "".join(f"{s}  {p}\n" for p, s in sorted(files.items()))
    assert m["sha256"] == hashlib.sha256(listing.encode()).hexdigest()
    assert _register(client, auth, "noise-1", "plugin", "cv_noise").status_code == 409

    # the default-model rule is the same for every kind
    _register_checkpoint(client, auth, engine, settings, "ck-1")
    kinds = {x["id"]: x["kind"] for x in client.get("/v1/models").json()["data"]}
    assert kinds == {"noise-1": "plugin", "ck-1": "checkpoint"}
    assert client.post("/v1/models/noise-1/promote", json={"to": "default"}, headers=auth).status_code == 200
    resolver = client.app.state.resolver
    folder = resolver.model("default")
    assert folder == settings.store_root / "models" / "noise-1"
    ctx = StageContext(workdir=settings.store_root, resolve_model=resolver.model)
    rp = resolve_planner({"name": "predictive", "model": "noise-1"}, ctx)
    assert rp.model_id == "noise-1" and rp.checkpoint_sha256 == "plugin:cv_noise"
    assert build_planner(rp).forecaster.declared.modes == 20  # the plug-in drives the planner
    assert client.post("/v1/models/ck-1/promote", json={"to": "default"}, headers=auth).status_code == 200
    assert client.get("/v1/models/noise-1").json()["status"] == "promoted"

    (folder / "files" / "weights.bin").write_bytes(b"retrained in place")
    with pytest.raises(
        CoreError, match=r"model 'noise-1': file files/weights.bin changed since registration"
    ):
        resolver.model("noise-1")
    with pytest.raises(CoreError, match="noise-1"):
        resolve_planner({"name": "predictive", "model": "noise-1"}, ctx)
    (folder / "files" / "weights.bin").write_bytes(FILES["weights.bin"])
    assert resolver.model("noise-1") == folder
    (folder / "files" / "extra.bin").write_bytes(b"x")
    with pytest.raises(CoreError, match="files/extra.bin was added"):
        resolver.model("noise-1")


def test_an_external_predictor_registers_with_its_declaration_and_gets_its_files(
    client, auth, settings, monkeypatch
) -> None:  # noqa: ANN001
    from foresight.cli.models import _line
    from foresight.core.evaluation.plannerspec import resolve_planner
    from foresight.core.runtime.context import StageContext
    from foresight.schemas import ModelPublic

    reference = [sys.executable, str(REPO_ROOT / "examples" / "external_predictor.py")]
    monkeypatch.setenv(
        ENV, json.dumps({"reference": reference, "named": [sys.executable, "-c", ARTIFACT_NAMED]})
    )
    created = _register(client, auth, "ext-1", "external", "external:reference", {"model.txt": b"cv"})
    assert created.status_code == 201, created.text
    m = created.json()
    assert m["kind"] == "external" and m["time_base"]["dt"] == 0.2 and m["lineage"]["modes"] == 1
    assert " external " in _line(ModelPublic.model_validate(m))  # `models ls` shows the kind
    resolver = client.app.state.resolver
    assert resolver.model("ext-1") == settings.store_root / "models" / "ext-1"

    assert (
        _register(
            client, auth, "ext-2", "external", "external:named", {"name.txt": b"from-files"}
        ).status_code
        == 201
    )
    ctx = StageContext(workdir=settings.store_root, resolve_model=resolver.model)
    rp = resolve_planner({"name": "predictive", "model": "ext-2"}, ctx)
    assert rp.checkpoint_sha256 == "external:from-files"  # the process was handed its registered files


@pytest.mark.parametrize(
    "kind, predictor, why",
    [
        ("external", "cv_noise", "is not of kind 'external'"),
        ("plugin", "nope", "'nope' is not of kind 'plugin'"),
        ("external", "external:unset", "not configured by the operator"),
    ],
)
def test_a_predictor_of_another_kind_or_not_there_is_422_and_stores_nothing(
    client, auth, settings, kind, predictor, why
) -> None:  # noqa: ANN001
    r = _register(client, auth, "bad-1", kind, predictor, FILES)
    assert r.status_code == 422 and why in r.text, r.text
    assert client.get("/v1/models/bad-1").status_code == 404
    assert not (settings.store_root / "models").exists() or not list(
        (settings.store_root / "models").iterdir()
    )


def test_a_deleted_plugin_model_can_be_registered_again(client, auth, settings) -> None:  # noqa: ANN001
    assert _register(client, auth, "again-1", "plugin", "cv_noise", FILES).status_code == 201
    assert client.delete("/v1/models/again-1", headers=auth).status_code == 204
    again = _register(client, auth, "again-1", "plugin", "cv_noise", {"other.bin": b"new"})
    assert again.status_code == 201, again.text
    assert set(again.json()["lineage"]["files"]) == {"files/other.bin", "predictor.json"}
    assert client.app.state.resolver.model("again-1") == settings.store_root / "models" / "again-1"
