"""HTTP client of the Foresight API (httpx): URL and token from flags, the environment or the data dir.

Every answer is read through its response model (``foresight.schemas``): :meth:`Client.fetch` returns the model, and
a body that does not fit it (a server of another version, or something else at the URL) is one error line naming
the request and the field, never a traceback."""

from __future__ import annotations

import argparse
import json
import re
from collections.abc import Iterator
from typing import Any, TypeVar, get_origin

import httpx
from pydantic import BaseModel, Field, TypeAdapter, ValidationError

from foresight.core.errors import CoreError
from foresight.schemas import JobEndPublic, JobEventPublic, JobPublic
from foresight.store.settings import Settings

T = TypeVar("T")


class ApiError(CoreError):
    """The server answered with an error status."""

    def __init__(self, status: int, detail: Any):
        self.status, self.detail = status, detail
        super().__init__(f"HTTP {status}: {describe(detail)}")


class ServerUnreachable(CoreError):
    """No server answered at the client's URL."""


class MalformedResponse(CoreError):
    """The server answered a body that is not what the API promises for the request."""


class _ErrorBody(BaseModel):
    detail: Any


class _FieldError(BaseModel):
    """One entry of a 422's ``detail`` list: where (``loc``, ``body`` first for a request body) and what."""

    loc: list[str | int] = Field(default_factory=list)
    msg: str


def _field_error(err: Any) -> str:
    try:
        e = _FieldError.model_validate(err)
    except ValidationError:
        return str(err)
    loc = ".".join(str(x) for x in e.loc if x != "body")
    return f"{loc}: {e.msg}" if loc else e.msg


def describe(detail: Any) -> str:
    """One readable line from an error body (``detail`` may be a string or a list of field errors)."""
    if isinstance(detail, list):
        parts = [_field_error(err) for err in detail[:3]]
        return "; ".join(parts) + (f" (+{len(detail) - 3} more)" if len(detail) > 3 else "")
    return str(detail)


def _detail(response: httpx.Response) -> Any:
    """An error response's ``detail``, else its text."""
    try:
        return _ErrorBody.model_validate_json(response.content).detail
    except ValidationError:
        return response.text


def _name(shape: Any) -> str:
    """``JobPublic``, ``list[EpisodePublic]``: a shape by its models' names."""
    return re.sub(r"[\w.]+\.", "", str(shape)) if get_origin(shape) else shape.__name__


def _errors(exc: ValidationError) -> str:
    return describe(exc.errors(include_url=False, include_input=False, include_context=False))


def read(shape: type[T], data: Any, what: str) -> T:
    """``data``, a part of an answer kept free-form by the API (a stage config), as ``shape``;
    :class:`MalformedResponse` naming ``what`` where it does not fit."""
    try:
        return TypeAdapter(shape).validate_python(data)
    except ValidationError as exc:
        raise MalformedResponse(f"{what} is not a {_name(shape)}: {_errors(exc)}") from None


def plain(obj: Any) -> Any:
    """Response models (and lists of them) as the JSON data the server sent them as: what ``--json`` prints."""
    if isinstance(obj, BaseModel):
        return obj.model_dump(mode="json", by_alias=True)
    if isinstance(obj, list):
        return [plain(x) for x in obj]
    return obj


def dump(obj: Any) -> str:
    """:func:`plain`, indented."""
    return json.dumps(plain(obj), indent=2)


def add_connection_args(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--url",
        help="server URL (default: $FORESIGHT_API_URL, else the running `foresight up` of the "
        "data dir, else http://127.0.0.1:8000)",
    )
    parser.add_argument("--token", help="write token (default: $FORESIGHT_API_TOKEN or the data dir's token)")


class Client:
    def __init__(self, url: str, token: str | None, timeout: float = 30.0):
        headers = {"Authorization": f"Bearer {token}"} if token else {}
        self.http = httpx.Client(base_url=url, headers=headers, timeout=timeout)

    @classmethod
    def from_args(cls, args: argparse.Namespace) -> Client:
        settings = Settings()
        return cls(
            getattr(args, "url", None) or settings.client_url,
            getattr(args, "token", None) or settings.client_token(),
        )

    @property
    def base_url(self) -> str:
        """The server's URL without a trailing slash (links to the dashboard start with it)."""
        return str(self.http.base_url).rstrip("/")

    def fetch(self, shape: type[T], path: str, *, method: str = "GET", **kwargs: Any) -> T:
        """The answer to ``method path`` as ``shape`` (a response model, or e.g. ``list[EpisodePublic]``);
        :class:`MalformedResponse` where the body does not fit it."""
        response = self._send(method, path, **kwargs)
        try:
            return TypeAdapter(shape).validate_json(response.content)
        except ValidationError as exc:
            raise MalformedResponse(
                f"the server at {self.base_url} answered {method} {path} with a body that is not a "
                f"{_name(shape)}: {_errors(exc)} (a server of another version?)"
            ) from None

    def job(self, job_id: str) -> JobPublic:
        return self.fetch(JobPublic, f"/v1/jobs/{job_id}")

    def send(self, method: str, path: str, **kwargs: Any) -> None:
        """A request whose answer is not read (deletions)."""
        self._send(method, path, **kwargs)

    def download(self, path: str, **kwargs: Any) -> bytes:
        """A GET's body as bytes (files, exports); errors as :meth:`fetch` raises them."""
        return self._send("GET", path, **kwargs).content

    def _send(self, method: str, path: str, **kwargs: Any) -> httpx.Response:
        try:
            response = self.http.request(method, path, **kwargs)
        except httpx.HTTPError as exc:
            raise ServerUnreachable(f"cannot reach the server at {self.http.base_url} ({exc})") from None
        if response.status_code >= 400:
            raise ApiError(response.status_code, _detail(response))
        return response

    def events(self, job_id: str, after: int = 0) -> Iterator[tuple[str, JobEventPublic | JobEndPublic]]:
        """A job's server-sent events as ``(event, data)`` until the stream ends (``end``: its status)."""
        path = f"/v1/jobs/{job_id}/events"
        with self.http.stream("GET", path, params={"after": after}, timeout=None) as response:
            if response.status_code >= 400:
                response.read()
                raise ApiError(response.status_code, _detail(response))
            event, data = "message", ""
            for line in response.iter_lines():
                if line.startswith("event:"):
                    event = line[6:].strip()
                elif line.startswith("data:"):
                    data += line[5:].strip()
                elif not line and data:
                    shape = JobEndPublic if event == "end" else JobEventPublic
                    try:
                        yield event, shape.model_validate_json(data)
                    except ValidationError as exc:
                        raise MalformedResponse(
                            f"the server at {self.base_url} sent a {event!r} event of {path} that is not a "
                            f"{shape.__name__}: {_errors(exc)}"
                        ) from None
                    event, data = "message", ""
