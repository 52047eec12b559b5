"""Dependencies shared by the routers, as ``Annotated`` aliases: a handler's signature says what it needs."""

from __future__ import annotations

import secrets
from typing import Annotated, Any

from fastapi import Depends, HTTPException, Request, status
from fastapi.exceptions import RequestValidationError
from fastapi.security import HTTPAuthorizationCredentials, HTTPBearer

from foresight.store.registry import Resolver
from foresight.store.session import Engine
from foresight.store.settings import Settings

_bearer = HTTPBearer(auto_error=False, description="FORESIGHT_API_TOKEN")

# The small dependencies are ``async``: FastAPI runs a sync dependency in the thread pool, a hand-off that
# cost more than the dependency itself on every request.


async def get_settings(request: Request) -> Settings:
    return request.app.state.settings


async def get_engine(request: Request) -> Engine:
    return request.app.state.engine


async def get_resolver(request: Request) -> Resolver:
    return request.app.state.resolver


def _check_token(request: Request, credentials: HTTPAuthorizationCredentials | None) -> None:
    if credentials is None:
        raise HTTPException(
            status.HTTP_401_UNAUTHORIZED, "missing bearer token (Authorization: Bearer <FORESIGHT_API_TOKEN>)",
            headers={"WWW-Authenticate": "Bearer"},
        )  # fmt: skip
    if not secrets.compare_digest(credentials.credentials.encode(), request.app.state.token.encode()):
        raise HTTPException(status.HTTP_403_FORBIDDEN, "invalid bearer token")


async def require_write(request: Request, credentials: Annotated[HTTPAuthorizationCredentials | None, Depends(_bearer)]) -> None:
    _check_token(request, credentials)


async def require_read(request: Request, credentials: Annotated[HTTPAuthorizationCredentials | None, Depends(_bearer)]) -> None:
    if request.app.state.settings.read_requires_token:
        _check_token(request, credentials)


_KNOWN_QUERY: dict[int, frozenset[str]] = {}


def _query_names(dependant: Any) -> set[str]:
    """The query parameter names a route's handler and its dependencies declare."""
    names = {p.alias for p in dependant.query_params}
    for sub in dependant.dependencies:
        names |= _query_names(sub)
    return names


async def known_query(request: Request) -> None:
    """Refuse query parameters the route does not declare (a typo such as ``?stauts=`` would otherwise be
    silently ignored and answer for everything): 422 naming the parameter and the known ones."""
    if not request.query_params:
        return
    route = request.scope.get("route")
    dependant = getattr(route, "dependant", None)
    if dependant is None:
        return
    known = _KNOWN_QUERY.get(id(route))
    if known is None:
        known = _KNOWN_QUERY[id(route)] = frozenset(_query_names(dependant))
    unknown = sorted(set(request.query_params) - known)
    if unknown:
        expected = ", ".join(sorted(known)) or "none"
        raise RequestValidationError([{"loc": ("query", name), "type": "extra_forbidden", "input": request.query_params[name],
                                       "msg": f"unknown query parameter {name!r} (this endpoint takes: {expected})"}
                                      for name in unknown])  # fmt: skip


SettingsDep = Annotated[Settings, Depends(get_settings)]
EngineDep = Annotated[Engine, Depends(get_engine)]
ResolverDep = Annotated[Resolver, Depends(get_resolver)]
WriteAuth = Depends(require_write)
ReadAuth = Depends(require_read)
KnownQuery = Depends(known_query)

__all__ = ["EngineDep", "KnownQuery", "ReadAuth", "ResolverDep", "SettingsDep", "WriteAuth"]
