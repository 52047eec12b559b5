"""The CLI reads a server's answers through the API's response models (``foresight.schemas``): an answer that does
not fit (a field missing, a wrong type, not JSON at all) is one readable error line and exit 1, never a traceback;
an answer that fits is printed by ``--json`` as the server sent it. A real HTTP server on a local port answers
with the bodies each test gives it."""

from __future__ import annotations

import json
import threading
from collections.abc import Iterator
from datetime import UTC, datetime
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from typing import Any

import pytest

from foresight.cli.main import main
from foresight.schemas import ArtifactPublic, JobPublic, JobsPublic


class _Answers(ThreadingHTTPServer):
    """Answers GET PATH with ``bodies[PATH]`` (bytes, as JSON), anything else with 404."""

    bodies: dict[str, bytes]


class _Handler(BaseHTTPRequestHandler):
    server: _Answers

    def do_GET(self) -> None:  # noqa: N802 (the http.server hook)
        body = self.server.bodies.get(self.path.split("?")[0])
        self.send_response(200 if body is not None else 404)
        self.send_header("Content-Type", "application/json")
        body = body if body is not None else b'{"detail": "no such thing"}'
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)

    def log_message(self, *args: Any) -> None:
        pass


@pytest.fixture
def server() -> Iterator[_Answers]:
    httpd = _Answers(("127.0.0.1", 0), _Handler)
    httpd.bodies = {}
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    yield httpd
    httpd.shutdown()
    httpd.server_close()


def _url(server: _Answers) -> str:
    return f"http://127.0.0.1:{server.server_address[1]}"


def _job(**changes: Any) -> dict[str, Any]:
    """A succeeded evaluate job as ``GET /v1/jobs/ID`` answers it."""
    now = datetime(2026, 1, 2, 3, 4, 5, 678000, tzinfo=UTC)
    job = JobPublic(
        id="job-0123456789ab",
        kind="evaluate",
        status="succeeded",
        spec={"kind": "evaluate"},
        priority=0,
        attempts=1,
        max_attempts=3,
        timeout_s=None,
        idempotency_key=None,
        parent_id=None,
        name="baseline",
        tags=["a"],
        cancel_requested=False,
        progress=1.0,
        message="done",
        error=None,
        result={"success_rate": 0.75, "episodes": 4},
        verdict="passed",
        worker="w1",
        created_at=now,
        started_at=now,
        finished_at=now,
        artifacts=[
            ArtifactPublic(
                name="report.md",
                size=3,
                sha256="ab" * 32,
                url="/v1/jobs/job-0123456789ab/artifacts/report.md",
            )
        ],
        children=[],
    )
    return {**job.model_dump(mode="json"), **changes}


def _one_line_error(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("foresight: error:"), err
    return err[0]


def test_a_job_row_without_status_is_one_line_naming_the_request_and_the_field(server, capsys) -> None:  # noqa: ANN001
    row = _job()
    del row["status"]
    server.bodies["/v1/jobs/job-0123456789ab"] = json.dumps(row).encode()
    assert main(["jobs", "show", "job-0123456789ab", "--url", _url(server)]) == 1
    line = _one_line_error(capsys)
    assert (
        "GET /v1/jobs/job-0123456789ab" in line and "JobPublic" in line and "status: Field required" in line
    )
    assert _url(server) in line


def test_a_page_with_a_bad_row_names_the_row_and_the_field(server, capsys) -> None:  # noqa: ANN001
    page = {"data": [_job(), _job(progress="most of it")], "count": 2, "limit": 20, "offset": 0}
    server.bodies["/v1/jobs"] = json.dumps(page).encode()
    assert main(["jobs", "ls", "--url", _url(server)]) == 1
    assert "data.1.progress: Input should be a valid number" in _one_line_error(capsys)


@pytest.mark.parametrize(
    ("argv", "path", "body", "shape"),
    [
        (
            ["jobs", "show", "j1"],
            "/v1/jobs/j1",
            b"<html>a proxy's login page</html>",
            "JobPublic",
        ),  # not JSON
        (["models", "ls"], "/v1/models", b'{"data": [{"id": "m"}], "count": 1}', "ModelsPublic"),
        (
            ["evaluations", "ls"],
            "/v1/evaluations",
            b'{"data": "none", "count": 0, "limit": 20, "offset": 0}',
            "EvaluationsPublic",
        ),
        (["compare", "e1", "e2"], "/v1/compare", b'{"a": "e1", "b": "e2"}', "ComparisonPublic"),
        (["planners"], "/v1/planners", b'{"data": [], "count": 0}', "PlannersPublic"),
        (
            ["evaluations", "episodes", "e1"],
            "/v1/evaluations/e1/episodes",
            b'[{"scenario": "s", "seed": 1}]',
            "list[EpisodePublic]",
        ),
    ],
)
def test_every_reader_refuses_a_body_that_does_not_fit(server, capsys, argv, path, body, shape) -> None:  # noqa: ANN001
    server.bodies[path] = body
    assert main([*argv, "--url", _url(server)]) == 1
    line = _one_line_error(capsys)
    assert f"{path} with a body that is not a {shape}: " in line and "a server of another version?" in line


def test_a_well_formed_answer_is_printed_by_json_as_the_server_sent_it(server, capsys) -> None:  # noqa: ANN001
    row = _job()
    server.bodies["/v1/jobs/job-0123456789ab"] = json.dumps(row).encode()
    page = JobsPublic(data=[JobPublic.model_validate(row)], count=7, limit=1, offset=0).model_dump(
        mode="json"
    )
    server.bodies["/v1/jobs"] = json.dumps(page).encode()
    assert main(["jobs", "show", "job-0123456789ab", "--json", "--url", _url(server)]) == 0
    assert json.loads(capsys.readouterr().out) == row
    assert main(["jobs", "ls", "--json", "--url", _url(server)]) == 0
    assert json.loads(capsys.readouterr().out) == page
    assert main(["jobs", "ls", "--url", _url(server)]) == 0  # and the text reads the same fields
    out = capsys.readouterr().out
    assert "job-0123456789ab  evaluate   succeeded  100.0%  2026-01-02T03:04:05  'baseline' #a" in out
    assert out.rstrip().endswith("1 of 7 jobs")
