"""JSON request bodies nested deeper than ``core.limits.MAX_NESTING`` are refused (422) before FastAPI reads them.

Deep bodies broke the service in two ways: past ~1,000 levels ``json.loads`` raises RecursionError (a 500), and
a spec stored at 255 levels made every later listing of jobs fail to serialise. Routers whose bodies are
JSON use this route class; the (small) body is parsed once more here, which costs microseconds.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Coroutine
from typing import Any

from fastapi import Request, Response
from fastapi.exceptions import RequestValidationError
from fastapi.routing import APIRoute

from foresight.core.limits import MAX_NESTING, nesting_depth


def too_deep(body: bytes) -> bool:
    try:
        return nesting_depth(json.loads(body)) > MAX_NESTING
    except RecursionError:
        return True
    except ValueError:  # not JSON: FastAPI answers that itself
        return False


class BoundedJsonRoute(APIRoute):
    def get_route_handler(self) -> Callable[[Request], Coroutine[Any, Any, Response]]:
        handler = super().get_route_handler()

        async def bounded(request: Request) -> Response:
            if request.method in ("POST", "PUT", "PATCH") and too_deep(await request.body()):
                msg = f"the JSON body is nested deeper than {MAX_NESTING} levels"
                raise RequestValidationError([{"loc": ("body",), "msg": msg, "type": "value_error.nesting"}])
            return await handler(request)

        return bounded
