"""Dependencies shared by the routers, as ``Annotated`` aliases: a handler's signature says what it needs."""

from __future__ import annotations

import secrets
from typing import Annotated

from fastapi import Depends, HTTPException, Request, status
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


SettingsDep = Annotated[Settings, Depends(get_settings)]
EngineDep = Annotated[Engine, Depends(get_engine)]
ResolverDep = Annotated[Resolver, Depends(get_resolver)]
WriteAuth = Depends(require_write)
ReadAuth = Depends(require_read)

__all__ = ["EngineDep", "ReadAuth", "ResolverDep", "SettingsDep", "WriteAuth"]
