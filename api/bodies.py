"""JSON request bodies are checked before FastAPI reads them: nesting beyond ``core.limits.MAX_NESTING``, and
values no store keeps and serves back (``core.limits.hostile_values``) are a 422 naming where they are.

Deep bodies broke the service in two ways: past ~1,000 levels ``json.loads`` raises RecursionError (a 500), and
a spec stored at 255 levels made every later listing of jobs fail to serialise. A lone UTF-16 surrogate
(``"\\ud800"``, valid JSON) was stored, and from then on every listing that held it failed to encode (500 for
everyone); a NUL byte is refused by PostgreSQL's text; NaN and 2**64 are not values a JSON column or an integer
column returns as sent. Routers whose bodies are JSON use this route class; the (small) body is parsed once
more here, which costs microseconds.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Coroutine
from typing import Any

from fastapi import HTTPException, Request, Response, status
from fastapi.exceptions import RequestValidationError
from fastapi.routing import APIRoute

from foresight.core.limits import MAX_NESTING, hostile_values, nesting_depth

_NOT_JSON = object()


def _parse(body: bytes) -> Any:
    try:
        return json.loads(body)
    except RecursionError:
        raise
    except ValueError:  # not JSON: FastAPI answers that itself
        return _NOT_JSON


def body_errors(body: bytes) -> list[dict[str, Any]]:
    """Validation errors (FastAPI's shape) for a JSON body that nests too deep or holds unstorable values."""
    try:
        value = _parse(body)
    except RecursionError:
        value = None
        depth = MAX_NESTING + 1
    else:
        if value is _NOT_JSON:
            return []
        depth = nesting_depth(value)
    if depth > MAX_NESTING:
        msg = f"the JSON body is nested deeper than {MAX_NESTING} levels"
        return [{"loc": ("body",), "msg": msg, "type": "value_error.nesting"}]
    return [
        {"loc": ("body", *loc), "msg": why, "type": "value_error.unstorable"}
        for loc, why in hostile_values(value)
    ]


class BoundedJsonRoute(APIRoute):
    max_body = 1 << 20  #: [bytes] a larger body is a 413 (Content-Length or not), before it is parsed

    def get_route_handler(self) -> Callable[[Request], Coroutine[Any, Any, Response]]:
        handler = super().get_route_handler()

        async def bounded(request: Request) -> Response:
            if request.method in ("POST", "PUT", "PATCH"):
                declared = request.headers.get("content-length", "")
                if declared.isdigit() and int(declared) > self.max_body:  # refused before it is read
                    raise HTTPException(
                        status.HTTP_413_CONTENT_TOO_LARGE, f"request body over {self.max_body} bytes"
                    )
                body = await request.body()
                if len(body) > self.max_body:
                    raise HTTPException(
                        status.HTTP_413_CONTENT_TOO_LARGE, f"request body over {self.max_body} bytes"
                    )
                errors = body_errors(body)
                if errors:
                    raise RequestValidationError(errors)
            return await handler(request)

        return bounded


class SmallJsonRoute(BoundedJsonRoute):
    """Registry writes: a model's metadata is a few kilobytes (10 MB of metrics made every model list 17 MB)."""

    max_body = 64 << 10


class QueryTextMiddleware:
    """A NUL character in a request's path or query string is a 422 naming where, before any route runs: on
    PostgreSQL it reached a text comparison (``?name=%00``) and failed there (a 500 that dropped the connection).
    Query text cannot carry a lone surrogate (it is decoded with replacement characters)."""

    def __init__(self, app: Any):
        self.app = app

    async def __call__(self, scope: dict, receive: Any, send: Any) -> None:
        if scope["type"] == "http":
            from urllib.parse import parse_qsl

            errors = []
            if "\x00" in scope.get("path", ""):
                errors.append(
                    {"loc": ["path"], "msg": "the path holds a NUL character", "type": "value_error"}
                )
            query = scope.get("query_string", b"").decode("latin-1")
            for name, value in parse_qsl(query, keep_blank_values=True):
                if "\x00" in name or "\x00" in value:
                    errors.append(
                        {
                            "loc": ["query", name.replace("\x00", "\\x00")],
                            "msg": "the value holds a NUL character",
                            "type": "value_error",
                        }
                    )
            if errors:
                from fastapi.responses import JSONResponse

                return await JSONResponse({"detail": errors}, status_code=422)(scope, receive, send)
        return await self.app(scope, receive, send)
