"""Named data roots: the `import_dataset` spec names a root, never a path; unknown names are refused at submission."""

from __future__ import annotations

from pathlib import Path

import pytest

from foresight.store.settings import Settings, parse_data_roots


@pytest.fixture
def roots_env(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    root = tmp_path / "mine"
    (root / "zara1").mkdir(parents=True)
    (root / "hotel").mkdir()
    (root / "notes").mkdir()
    monkeypatch.setenv("FORESIGHT_DATA_ROOTS", f"mine={root}")
    monkeypatch.setenv("FORESIGHT_SHARED", str(tmp_path / "no-shared"))  # no default ethucy root
    return root


def test_parse_data_roots(tmp_path: Path) -> None:
    assert parse_data_roots(f" a={tmp_path} , b=rel ") == {
        "a": tmp_path.resolve(),
        "b": (Path.cwd() / "rel").resolve(),
    }
    for bad in ("noequals", "=/x", "../up=/x", "a b=/x", "a="):
        with pytest.raises(ValueError, match="NAME=PATH"):
            parse_data_roots(bad)


def test_default_ethucy_root_from_the_shared_folder(tmp_path: Path) -> None:
    (tmp_path / "reference" / "ethucy").mkdir(parents=True)
    settings = Settings(shared=tmp_path, data_roots="")
    assert settings.named_data_roots == {"ethucy": (tmp_path / "reference" / "ethucy").resolve()}
    assert Settings(shared=tmp_path / "absent", data_roots="").named_data_roots == {}
    override = Settings(
        shared=tmp_path, data_roots=f"ethucy={tmp_path}"
    )  # a named root wins over the default
    assert override.data_root("ethucy") == tmp_path.resolve()
    with pytest.raises(LookupError, match=r"unknown data root 'nope'; known: ethucy"):
        override.data_root("nope")


def test_data_roots_endpoint_lists_names_and_folds(roots_env: Path, client) -> None:  # noqa: ANN001
    response = client.get("/v1/data-roots")
    assert response.status_code == 200
    assert response.json() == [{"name": "mine", "folds": ["hotel", "zara1"]}]
    assert str(roots_env) not in response.text  # the server's folders stay private
    assert client.app.openapi()["paths"]["/v1/data-roots"]["get"]["operationId"] == "read_data_roots"


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ({"root": "nope", "fold": "zara1"}, "unknown data root 'nope'; known: mine"),
        ({"root": "../mine", "fold": "zara1"}, "pattern"),
        ({"root": "/data/ethucy", "fold": "zara1"}, "pattern"),
        ({"root": "mine", "fold": "../zara1"}, "fold"),
        ({"root": "mine", "fold": "zara1", "source": "sdd"}, "source"),
        ({"root": "mine", "fold": "zara1", "path": "x"}, "path"),
    ],
)
def test_bad_import_specs_are_refused(roots_env: Path, client, auth, spec: dict, message: str) -> None:  # noqa: ANN001
    response = client.post("/v1/jobs", json={"spec": {"kind": "import_dataset", **spec}}, headers=auth)
    assert response.status_code == 422, response.text
    assert message in response.text
    assert client.get("/v1/jobs").json()["count"] == 0  # nothing stored


def test_known_root_is_queued(roots_env: Path, client, auth) -> None:  # noqa: ANN001
    response = client.post(
        "/v1/jobs", json={"spec": {"kind": "import_dataset", "root": "mine", "fold": "zara1"}}, headers=auth
    )
    assert response.status_code == 201, response.text
    assert response.json()["spec"] == {
        "kind": "import_dataset",
        "source": "ethucy",
        "root": "mine",
        "fold": "zara1",
        "max_agents": 12,
    }
