"""The FastAPI app factory: ``create_app(settings)`` builds everything; nothing happens at import."""

from __future__ import annotations

import gc
from typing import Any

from fastapi import FastAPI, Response
from fastapi.routing import APIRoute
from starlette.routing import Match

from foresight.api import errors, web
from foresight.api.bodies import QueryTextMiddleware
from foresight.api.deps import KnownQuery, ReadAuth
from foresight.api.http_metrics import HttpMetrics, MetricsMiddleware, route_templates
from foresight.api.routes import bundles, jobs, listing, models, ops, planners, results
from foresight.core.planners.external import operator_commands
from foresight.core.version import code_version
from foresight.store import space
from foresight.store.registry import Resolver, load_shipped_models, sync_bundles
from foresight.store.session import check_migrated, make_engine
from foresight.store.settings import Settings


def _operation_id(route: APIRoute) -> str:
    """Stable OpenAPI operation ids: the handler's name (``create_job``, ``read_jobs``...)."""
    return route.name


def _require_discriminators(doc: dict) -> dict:
    """Mark each discriminated union's tag (a job spec's ``kind``) required in the schemas it selects: the
    spec models give ``kind`` a default (handy in Python), yet a request body must name it, and a schema that
    calls it optional describes bodies the API refuses."""
    schemas = doc.get("components", {}).get("schemas", {})

    def walk(node: object) -> None:
        if isinstance(node, dict):
            disc = node.get("discriminator")
            if isinstance(disc, dict):
                for ref in disc.get("mapping", {}).values():
                    target = schemas.get(ref.rsplit("/", 1)[-1])
                    if target is not None and disc["propertyName"] not in target.setdefault("required", []):
                        target["required"].append(disc["propertyName"])
            for value in node.values():
                walk(value)
        elif isinstance(node, list):
            for value in node:
                walk(value)

    walk(doc)
    return doc


def create_app(settings: Settings | None = None) -> FastAPI:
    """The API app for ``settings``; refuses (NotMigratedError) a database that is not at the latest migration."""
    settings = settings or Settings()
    operator_commands()  # a malformed FORESIGHT_EXTERNAL_PLANNERS stops the start, naming the variable
    engine = make_engine(
        settings.resolved_database_url, busy_timeout_ms=settings.sqlite_busy_timeout_ms, pool_size=20
    )
    revision = check_migrated(engine)
    settings.store_root.mkdir(parents=True, exist_ok=True)
    sync_bundles(engine, settings)
    load_shipped_models(engine, settings)

    app = FastAPI(
        title="Foresight",
        version=code_version(),
        description="Predictive local planners in crowds: jobs, results, the model registry.",
        generate_unique_id_function=_operation_id,
    )
    app.state.settings = settings
    app.state.engine = engine
    app.state.resolver = Resolver(settings, engine)
    app.state.token = settings.server_token()
    app.state.revision = revision
    app.state.full_at = None  #: when a request last met a full disk (``/healthz``)
    space.keep_reserve(settings)  # lets a deletion work on a full disk
    app.state.http_metrics = HttpMetrics()
    app.add_middleware(MetricsMiddleware, metrics=app.state.http_metrics)
    errors.install(app)
    # Reads are open unless closed by a setting; when open, the read routes carry no auth dependency at all
    # (dependency resolution is a good part of a status read's cost). Writes always require the token.
    read_auth = [ReadAuth] if settings.read_requires_token else []
    read_codes = errors.responses(*errors.AUTH) if settings.read_requires_token else {}
    app.include_router(ops.router)
    app.include_router(ops.read_router, dependencies=read_auth, responses=read_codes)
    for router in (jobs, models, bundles, listing, results, planners, planners.predictors_router):
        app.include_router(
            getattr(router, "router", router),
            prefix="/v1",
            dependencies=[*read_auth, KnownQuery],
            responses=read_codes,
        )
    web.install(app)  # the dashboard: /ui pages over the same store
    app.add_middleware(AllowMiddleware, router=app.router)
    app.add_middleware(QueryTextMiddleware)
    app.state.http_metrics.templates = route_templates(app)
    base_openapi = app.openapi

    def openapi() -> dict:
        built = app.openapi_schema is not None
        doc = base_openapi()
        return doc if built else _require_discriminators(doc)

    app.openapi = openapi  # type: ignore[method-assign]
    return app


_METHODS = ("GET", "HEAD", "POST", "PUT", "PATCH", "DELETE")


class AllowMiddleware:
    """OPTIONS on a path: 204 with ``Allow`` listing the methods of every route of that path (Starlette's own
    answer, a 405, named only the first route's: GET without POST on /v1/jobs). Other requests pass untouched."""

    def __init__(self, app: Any, router: Any):
        self.app, self.router = app, router

    async def __call__(self, scope: dict, receive: Any, send: Any) -> None:
        if scope["type"] != "http" or scope["method"] != "OPTIONS":
            return await self.app(scope, receive, send)
        methods = {
            m
            for m in _METHODS
            if any(r.matches({**scope, "method": m})[0] == Match.FULL for r in self.router.routes)
        }
        if not methods:
            return await self.app(scope, receive, send)
        allow = ", ".join(sorted(methods | {"OPTIONS"}))
        await Response(status_code=204, headers={"Allow": allow})(scope, receive, send)


def create_server_app(settings: Settings | None = None) -> FastAPI:
    """:func:`create_app` for a server process (``foresight serve``/``up``; uvicorn's factory with --workers):
    the heap built so far is then frozen out of the garbage collector.

    The app's start-up objects (~140,000: FastAPI, pydantic, SQLAlchemy, the core config models) made each
    full collection take 100-280 ms on the 2-core machine, stalling the event loop and every request in
    flight; under the submission benchmark one ran about every second. ``gc.freeze()`` leaves them out of
    every later collection (2-8 ms each). Not done in :func:`create_app`, because a process that builds many
    apps (tests) would keep their frozen cycles forever.
    """
    app = create_app(settings)
    gc.collect()
    gc.freeze()
    return app
