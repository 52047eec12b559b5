"""The web dashboard: server-rendered pages over the same store and database as the JSON API.

Pages live under ``/ui`` (``/`` redirects there); write actions are buttons that call the JSON API with the
bearer token the browser asked for once (kept in ``sessionStorage``). Reads follow the API's setting: open by
default; when ``read_requires_token`` is set, pages also accept the token as a session cookie the page's
script sets from the same prompt (images and report pages cannot send headers).
"""

from __future__ import annotations

from fastapi import FastAPI

from foresight.api.deps import KnownQuery
from foresight.api.web.auth import install_handlers
from foresight.api.web.pages import router


def install(app: FastAPI) -> None:
    """Add the dashboard routes and its HTML error pages to ``app``."""
    app.include_router(router, dependencies=[KnownQuery])  # a junk parameter is a 422, as on the API
    install_handlers(app)
