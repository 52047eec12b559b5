"""The dashboard's server side without a browser: pages render, reads follow the token setting, job files
stay inside their folder, map previews are cached."""

from __future__ import annotations

import shutil
import warnings
from collections.abc import Iterator
from pathlib import Path

import pytest

from foresight.store.session import upgrade
from foresight.store.settings import Settings

TOKEN = "pages-token"
AUTH = {"Authorization": f"Bearer {TOKEN}"}
MATRIX = "scenarios/classic_interactions.yaml"


@pytest.fixture(scope="module")
def migrated(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("template") / "foresight.db"
    upgrade(f"sqlite:///{path}")
    return path


def _client(tmp_path: Path, migrated: Path, **overrides: object):  # noqa: ANN202
    (tmp_path / "data").mkdir(exist_ok=True)
    shutil.copyfile(migrated, tmp_path / "data" / "foresight.db")
    settings = Settings(
        data_dir=tmp_path / "data", api_token=TOKEN, model_registry=tmp_path / "none.yaml", **overrides
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        from fastapi.testclient import TestClient
    from foresight.api.main import create_app

    return TestClient(create_app(settings), raise_server_exceptions=False), settings


@pytest.fixture
def open_client(tmp_path: Path, migrated: Path) -> Iterator:
    client, settings = _client(tmp_path, migrated)
    with client:
        client.settings = settings
        yield client


def _job_with_report(client) -> str:  # noqa: ANN001
    """A finished-looking job folder: a report page with a figure, written where a worker writes it."""
    job = client.post("/v1/jobs", json={"spec": {"kind": "sleep"}}, headers=AUTH).json()["id"]
    folder = client.settings.store_root / "jobs" / job
    (folder / "figures").mkdir(parents=True)
    (folder / "report.html").write_text('<html><body><img src="figures/a.png"></body></html>')
    (folder / "figures" / "a.png").write_bytes(b"\x89PNG\r\n\x1a\n")
    return job


def test_pages_render(open_client) -> None:  # noqa: ANN001
    job = _job_with_report(open_client)
    assert open_client.get("/", follow_redirects=False).headers["location"] == "/ui/jobs"
    for url in (
        "/ui/jobs",
        "/ui/jobs?status=queued&kind=sleep",
        "/ui/jobs/rows",
        f"/ui/jobs/{job}",
        f"/ui/jobs/{job}/summary",
        "/ui/models",
        "/ui/results",
        "/ui/bundles",
        "/ui/bundles/builtin",
    ):
        resp = open_client.get(url)
        assert resp.status_code == 200, (url, resp.text[:500])
        assert resp.headers["content-type"].startswith("text/html")
    assert job in open_client.get("/ui/jobs/rows?status=queued").text
    assert job not in open_client.get("/ui/jobs/rows?status=failed").text
    page = open_client.get(f"/ui/jobs/{job}").text
    assert (
        f'href="/ui/jobs/{job}/files/report.html"' in page and f'data-events="/v1/jobs/{job}/events"' in page
    )
    assert 'data-url="/v1/jobs/' + job + '/cancel"' in page
    missing = open_client.get("/ui/jobs/no-such-job")
    assert missing.status_code == 404 and "no job" in missing.text
    assert open_client.get("/ui/static/app.css").status_code == 200
    assert open_client.get("/ui/static/nothing.js").status_code == 404


def test_job_files_stay_in_their_folder(open_client) -> None:  # noqa: ANN001
    job = _job_with_report(open_client)
    page = open_client.get(f"/ui/jobs/{job}/files/report.html")
    assert page.status_code == 200 and page.headers["content-type"].startswith("text/html")
    assert "script-src 'none'" in page.headers["content-security-policy"]
    assert "attachment" not in page.headers.get("content-disposition", "")
    assert open_client.get(f"/ui/jobs/{job}/files/figures/a.png").headers["content-type"] == "image/png"
    secret = open_client.settings.store_root / "secret.txt"
    secret.write_text("not yours")
    (open_client.settings.store_root / "jobs" / job / "link.txt").symlink_to(secret)
    for name in (
        "..%2Fsecret.txt",
        "figures/..%2F..%2F..%2Fsecret.txt",
        "link.txt",
        "%2Fetc%2Fpasswd",
        "nothing.png",
    ):
        resp = open_client.get(f"/ui/jobs/{job}/files/{name}")
        assert resp.status_code in (404, 422), (name, resp.status_code)
        assert "not yours" not in resp.text


def test_closed_reads_take_the_token_as_header_or_cookie(tmp_path: Path, migrated: Path) -> None:
    client, settings = _client(tmp_path, migrated, read_requires_token=True)
    with client:
        client.settings = settings
        job = _job_with_report(client)
        for url in ("/ui/jobs", f"/ui/jobs/{job}", f"/ui/jobs/{job}/files/figures/a.png", "/ui/bundles"):
            denied = client.get(url)
            assert denied.status_code == 401 and "Token required" in denied.text, url
            assert client.get(url, headers=AUTH).status_code == 200, url
            client.cookies.set("foresight_token", TOKEN)
            assert client.get(url).status_code == 200, url
            client.cookies.set("foresight_token", "wrong")
            assert client.get(url).status_code == 401, url
            client.cookies.clear()
        assert client.get("/ui/static/app.js").status_code == 200  # the token page needs its script


def test_matrix_page_and_cached_map_preview(open_client) -> None:  # noqa: ANN001
    page = open_client.get("/ui/bundles/builtin/matrix", params={"path": MATRIX})
    assert page.status_code == 200 and "crossing_low" in page.text
    url = "/ui/bundles/builtin/preview.png"
    first = open_client.get(url, params={"path": MATRIX, "scenario": "crossing_low"})
    assert first.status_code == 200 and first.content.startswith(b"\x89PNG")
    cached = list((open_client.settings.store_root / "web-cache" / "maps").glob("*.png"))
    assert len(cached) == 1
    mtime = cached[0].stat().st_mtime_ns
    # crossing_medium is drawn on the same map: same cached file, not drawn again
    assert (
        open_client.get(url, params={"path": MATRIX, "scenario": "crossing_medium"}).content == first.content
    )
    assert cached[0].stat().st_mtime_ns == mtime
    assert open_client.get(url, params={"path": MATRIX, "scenario": "nope"}).status_code == 404
    assert open_client.get(url, params={"path": "../etc/passwd", "scenario": "x"}).status_code == 404
