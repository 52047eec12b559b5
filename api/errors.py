"""Domain errors → HTTP status codes, always with a JSON body ``{"detail": ...}``."""

from __future__ import annotations

import errno
import logging
import math
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from fastapi import FastAPI, Request
from fastapi.encoders import jsonable_encoder
from fastapi.exception_handlers import http_exception_handler
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from pydantic import BaseModel
from starlette.exceptions import HTTPException

from foresight.core.errors import ConfigError, CoreError, NotFoundError
from foresight.core.limits import MAX_NAME_BYTES, printable
from foresight.core.runtime.refs import BUILTIN_CONFIG_ROOT
from foresight.store import queue
from foresight.store.folders import UnsafePath, is_full_disk
from foresight.store.session import DatabaseError, NotMigratedError

logger = logging.getLogger(__name__)


class ErrorBody(BaseModel):
    """The body of every non-422 error: one readable line."""

    detail: str


_WHY = {
    401: "missing bearer token",
    403: "invalid bearer token",
    404: "unknown id",
    409: "conflict with the resource's state (or a duplicate id)",
    413: "request body too large",
    507: "the store is full (no space left on device)",
}


def responses(*codes: int) -> dict[int | str, dict[str, Any]]:
    """OpenAPI ``responses=`` for a route's error codes (422 is documented by FastAPI for every route with
    parameters), so that the schema lists every status the route can answer."""
    return {code: {"model": ErrorBody, "description": _WHY[code]} for code in codes}


AUTH = (401, 403)  #: codes of a route behind the bearer token


def _json(code: int, detail: object, request: Request | None = None) -> JSONResponse:
    detail = _finite(detail)
    if request is not None:
        detail = _hide_paths(detail, _server_roots(request))
    return JSONResponse({"detail": detail}, status_code=code)


def _server_roots(request: Request) -> list[str]:
    """Folders of this server that an error message must not show (longest first): the store, the data folder,
    the project's configs, the installed package and the temporary folder (uploads are checked there); what
    follows them is the id-relative part a user knows."""
    import foresight

    settings = request.app.state.settings
    roots = {
        str(settings.store_root),
        str(settings.data_dir),
        str(BUILTIN_CONFIG_ROOT),
        tempfile.gettempdir(),
    }
    roots |= {str(Path(p).resolve()) for p in foresight.__path__}
    roots |= {str(Path(r).resolve()) for r in list(roots)}
    return sorted(roots, key=len, reverse=True)


def _hide_paths(value: Any, roots: list[str]) -> Any:
    if isinstance(value, str):
        for root in roots:
            value = value.replace(root + "/", "").replace(root, ".")
        return value
    if isinstance(value, dict):
        return {k: _hide_paths(v, roots) for k, v in value.items()}
    if isinstance(value, list):
        return [_hide_paths(v, roots) for v in value]
    return value


def _finite(value: Any) -> Any:
    """JSON-safe copy of echoed inputs: NaN and infinities become strings, lone surrogates and NUL escapes (a
    surrogate in a 422 body failed to encode: a 500 and a dropped connection)."""
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    if isinstance(value, dict):
        return {printable(k): _finite(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_finite(v) for v in value]
    return printable(value)


def private_paths(settings: Any) -> Callable[[str], str]:
    """A message without the server's folders: a builtin config is named inside its bundle, the store is
    ``<store>`` (a file error on a bundle's YAML names the file a client asked for, not where it lives)."""
    from foresight.core.runtime.refs import BUILTIN_CONFIG_ROOT

    folders = [
        (f"{BUILTIN_CONFIG_ROOT}/", ""),
        (str(settings.store_root.resolve()), "<store>"),
        (str(settings.data_dir.resolve()), "<data>"),
    ]

    def hide(text: str) -> str:
        for folder, name in folders:
            text = text.replace(folder, name)
        return text

    return hide


ECHO_ITEMS = 200  #: a refused input larger than this many values is not echoed back in a 422


def _size_over(value: Any, budget: int) -> bool:
    """Whether ``value`` holds more than ``budget`` values (counted without walking past the budget)."""
    stack, seen = [value], 0
    while stack:
        item = stack.pop()
        seen += 1
        if seen > budget:
            return True
        if isinstance(item, dict):
            stack.extend(item.values())
        elif isinstance(item, list | tuple):
            stack.extend(item)
    return False


def _compact(error: dict[str, Any]) -> dict[str, Any]:
    """A validation error whose large ``input`` is left out (encoding 100,000 echoed values took 0.7 s)."""
    if _size_over(error.get("input"), ECHO_ITEMS):
        return {**error, "input": f"(not echoed: over {ECHO_ITEMS} values)"}
    return error


def install(app: FastAPI) -> None:
    @app.exception_handler(RequestValidationError)
    async def _validation(request: Request, exc: RequestValidationError) -> JSONResponse:
        return _json(422, jsonable_encoder([_compact(e) for e in exc.errors()]), request)

    @app.exception_handler(HTTPException)
    async def _http(request: Request, exc: HTTPException) -> JSONResponse:
        if (
            exc.status_code == 400
        ):  # FastAPI could not parse the body (e.g. JSON that is not UTF-8): bad input
            msg = "the request body could not be parsed (a JSON body must be UTF-8 JSON)"
            return _json(422, [{"loc": ["body"], "msg": msg, "type": "body_invalid"}])
        return await http_exception_handler(request, exc)

    @app.exception_handler(ConfigError)
    async def _config(request: Request, exc: ConfigError) -> JSONResponse:
        hide = private_paths(request.app.state.settings)
        loc = [hide(p) for p in ("body", exc.source, exc.item) if p]
        return _json(422, [{"loc": loc, "msg": hide(exc.detail), "type": "config_error"}], request)

    @app.exception_handler(UnsafePath)
    async def _unsafe(request: Request, exc: UnsafePath) -> JSONResponse:
        return _json(422, [{"loc": ["path"], "msg": str(exc), "type": "unsafe_path"}], request)

    @app.exception_handler(NotFoundError)
    @app.exception_handler(queue.JobNotFound)
    async def _not_found(request: Request, exc: Exception) -> JSONResponse:
        return _json(404, private_paths(request.app.state.settings)(str(exc)), request)

    @app.exception_handler(queue.Conflict)
    async def _conflict(request: Request, exc: queue.Conflict) -> JSONResponse:
        return _json(409, str(exc), request)

    @app.exception_handler(NotMigratedError)
    async def _not_migrated(_: Request, exc: NotMigratedError) -> JSONResponse:
        return _json(503, str(exc))

    @app.exception_handler(CoreError)
    async def _core(request: Request, exc: CoreError) -> JSONResponse:
        msg = private_paths(request.app.state.settings)(str(exc))
        return _json(422, [{"loc": [], "msg": msg, "type": "core_error"}], request)  # every 422's shape

    # handled here, not by the catch-all below: that one's response also closes the connection
    @app.exception_handler(OSError)
    @app.exception_handler(DatabaseError)
    async def _full_disk(request: Request, exc: Exception) -> JSONResponse:
        if is_full_disk(exc):
            request.app.state.full_at = time.time()
            logger.error("disk full on %s %s: %s", request.method, request.url.path, exc)
            return _json(
                507,
                "the server's store is full (no space left on device for its files or its database); nothing was "
                "stored - retry once space is freed (deleting jobs and `foresight store gc` still work)",
            )
        if (
            getattr(exc, "errno", None) == errno.ENAMETOOLONG
        ):  # a name from a request that no file system holds
            msg = f"a file name over {MAX_NAME_BYTES} bytes (or a path too long) in the request"
            return _json(422, [{"loc": [], "msg": msg, "type": "name_too_long"}])
        return await _internal(request, exc)

    @app.exception_handler(Exception)
    async def _internal(request: Request, exc: Exception) -> JSONResponse:
        logger.exception("unhandled error on %s %s", request.method, request.url.path)
        return _json(500, f"internal error ({type(exc).__name__}); see the server log")
