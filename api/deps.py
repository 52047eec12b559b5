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
            status.HTTP_401_UNAUTHORIZED,
            "missing bearer token (Authorization: Bearer <FORESIGHT_API_TOKEN>)",
            headers={"WWW-Authenticate": "Bearer"},
        )
    if not secrets.compare_digest(credentials.credentials.encode(), request.app.state.token.encode()):
        raise HTTPException(status.HTTP_403_FORBIDDEN, "invalid bearer token")


async def require_write(
    request: Request, credentials: Annotated[HTTPAuthorizationCredentials | None, Depends(_bearer)]
) -> None:
    _check_token(request, credentials)


async def require_read(
    request: Request, credentials: Annotated[HTTPAuthorizationCredentials | None, Depends(_bearer)]
) -> None:
    if request.app.state.settings.read_requires_token:
        _check_token(request, credentials)


_KNOWN_QUERY: dict[int, tuple[frozenset[str], frozenset[str]]] = {}


def _query_names(dependant: Any) -> tuple[set[str], set[str]]:
    """The query parameter names a route's handler and its dependencies declare, and those of them that take
    one value (not a list)."""
    from fastapi.dependencies.utils import field_annotation_is_sequence

    names = {p.alias for p in dependant.query_params}
    single = {
        p.alias for p in dependant.query_params if not field_annotation_is_sequence(p.field_info.annotation)
    }
    for sub in dependant.dependencies:
        sub_names, sub_single = _query_names(sub)
        names, single = names | sub_names, single | sub_single
    return names, single


async def known_query(request: Request) -> None:
    """Refuse query parameters the route does not declare (a typo such as ``?stauts=`` would otherwise be
    silently ignored and answer for everything), and a one-value parameter given twice (``?name=a&name=b``
    would silently mean ``b``): 422 naming the parameter."""
    if not request.query_params:
        return
    route = request.scope.get("route")
    dependant = getattr(route, "dependant", None)
    if dependant is None:
        return
    if id(route) not in _KNOWN_QUERY:
        names, single = _query_names(dependant)
        _KNOWN_QUERY[id(route)] = frozenset(names), frozenset(single)
    known, single = _KNOWN_QUERY[id(route)]
    query = request.query_params
    unknown = sorted(set(query) - known)
    if unknown:
        expected = ", ".join(sorted(known)) or "none"
        raise RequestValidationError(
            [
                {
                    "loc": ("query", name),
                    "type": "extra_forbidden",
                    "input": query[name],
                    "msg": f"unknown query parameter {name!r} (this endpoint takes: {expected})",
                }
                for name in unknown
            ]
        )
    repeated = sorted(name for name in single & set(query) if len(query.getlist(name)) > 1)
    if repeated:
        raise RequestValidationError(
            [
                {
                    "loc": ("query", name),
                    "type": "too_long",
                    "input": query.getlist(name),
                    "msg": f"query parameter {name!r} takes one value, got {len(query.getlist(name))}",
                }
                for name in repeated
            ]
        )


SettingsDep = Annotated[Settings, Depends(get_settings)]
EngineDep = Annotated[Engine, Depends(get_engine)]
ResolverDep = Annotated[Resolver, Depends(get_resolver)]
WriteAuth = Depends(require_write)
ReadAuth = Depends(require_read)
KnownQuery = Depends(known_query)

__all__ = ["EngineDep", "KnownQuery", "ReadAuth", "ResolverDep", "SettingsDep", "WriteAuth"]
