"""HTTP client of the Foresight API (httpx): URL and token from flags, the environment or the data dir."""

from __future__ import annotations

import argparse
import json
from collections.abc import Iterator
from typing import Any

import httpx

from foresight.core.errors import CoreError
from foresight.store.settings import Settings


class ApiError(CoreError):
    """The server answered with an error status."""

    def __init__(self, status: int, detail: Any):
        self.status, self.detail = status, detail
        super().__init__(f"HTTP {status}: {describe(detail)}")


class ServerUnreachable(CoreError):
    """No server answered at the client's URL."""


def describe(detail: Any) -> str:
    """One readable line from an error body (``detail`` may be a string or a list of field errors)."""
    if isinstance(detail, list):
        parts = []
        for err in detail[:3]:
            if isinstance(err, dict):
                loc = ".".join(str(x) for x in err.get("loc", []) if x != "body")
                parts.append(f"{loc}: {err.get('msg')}" if loc else str(err.get("msg")))
            else:
                parts.append(str(err))
        return "; ".join(parts) + (f" (+{len(detail) - 3} more)" if len(detail) > 3 else "")
    return str(detail)


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

    def request(self, method: str, path: str, **kwargs: Any) -> Any:
        response = self._send(method, path, **kwargs)
        if response.status_code == 204 or not response.content:
            return None
        if response.headers.get("content-type", "").startswith("application/json"):
            return response.json()
        return response.text

    def download(self, path: str, **kwargs: Any) -> bytes:
        """A GET's body as bytes (files, exports); errors as :meth:`request` raises them."""
        return self._send("GET", path, **kwargs).content

    def _send(self, method: str, path: str, **kwargs: Any) -> httpx.Response:
        try:
            response = self.http.request(method, path, **kwargs)
        except httpx.HTTPError as exc:
            raise ServerUnreachable(f"cannot reach the server at {self.http.base_url} ({exc})") from None
        if response.status_code >= 400:
            try:
                detail = response.json().get("detail", response.text)
            except (ValueError, AttributeError):
                detail = response.text
            raise ApiError(response.status_code, detail)
        return response

    def get(self, path: str, **kwargs: Any) -> Any:
        return self.request("GET", path, **kwargs)

    def post(self, path: str, **kwargs: Any) -> Any:
        return self.request("POST", path, **kwargs)

    def patch(self, path: str, **kwargs: Any) -> Any:
        return self.request("PATCH", path, **kwargs)

    def delete(self, path: str) -> Any:
        return self.request("DELETE", path)

    def events(self, job_id: str, after: int = 0) -> Iterator[tuple[str, dict[str, Any]]]:
        """A job's server-sent events as ``(event, data)`` until the stream ends."""
        with self.http.stream(
            "GET", f"/v1/jobs/{job_id}/events", params={"after": after}, timeout=None
        ) as response:
            if response.status_code >= 400:
                response.read()
                raise ApiError(response.status_code, response.json().get("detail"))
            event, data = "message", ""
            for line in response.iter_lines():
                if line.startswith("event:"):
                    event = line[6:].strip()
                elif line.startswith("data:"):
                    data += line[5:].strip()
                elif not line and data:
                    yield event, json.loads(data)
                    event, data = "message", ""
