"""Read access of the pages, and the HTML pages shown instead of a page (token needed, not found)."""

from __future__ import annotations

import secrets

from fastapi import FastAPI, Request

from foresight.api.web.render import page

COOKIE = "foresight_token"  #: session cookie the page script sets from the prompted token


class NeedToken(Exception):
    """Reads are closed and the request carries no valid token."""


class PageNotFound(Exception):
    """The page's object does not exist."""


def _presented(request: Request) -> str | None:
    header = request.headers.get("authorization", "")
    if header.lower().startswith("bearer "):
        return header[7:].strip()
    return request.cookies.get(COOKIE)


def read_access(request: Request) -> None:
    """Dependency of every dashboard route: open unless the settings close reads."""
    if not request.app.state.settings.read_requires_token:
        return
    token = _presented(request)
    if not token or not secrets.compare_digest(token.encode(), request.app.state.token.encode()):
        raise NeedToken()


def install_handlers(app: FastAPI) -> None:
    @app.exception_handler(NeedToken)
    async def _need_token(request: Request, _: NeedToken):  # noqa: ANN202
        return page(request, "token.html", status_code=401, title="Token required")

    @app.exception_handler(PageNotFound)
    async def _not_found(request: Request, exc: PageNotFound):  # noqa: ANN202
        return page(request, "error.html", status_code=404, title="Not found", message=str(exc))
