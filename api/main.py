"""The FastAPI app factory: ``create_app(settings)`` builds everything; nothing happens at import."""

from __future__ import annotations

from fastapi import FastAPI
from fastapi.routing import APIRoute

from api import errors, web
from api.db.session import check_migrated, make_engine, session_factory
from api.deps import ReadAuth
from api.registry import Resolver, load_shipped_models, sync_bundles
from api.routes import bundles, jobs, models, ops, results
from api.settings import Settings
from core.version import code_version


def _operation_id(route: APIRoute) -> str:
    """Stable OpenAPI operation ids: the handler's name (``create_job``, ``read_jobs``...)."""
    return route.name


def create_app(settings: Settings | None = None) -> FastAPI:
    """The API app for ``settings``; refuses (NotMigratedError) a database that is not at the latest migration."""
    settings = settings or Settings()
    engine = make_engine(settings.resolved_database_url, busy_timeout_ms=settings.sqlite_busy_timeout_ms, pool_size=20)
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
    app.state.sessions = session_factory(engine)
    app.state.write_sessions = session_factory(engine, write=True)
    app.state.resolver = Resolver(settings, engine)
    app.state.token = settings.server_token()
    app.state.revision = revision
    errors.install(app)
    app.include_router(ops.router)
    # Reads are open unless closed by a setting; when open, the read routes carry no auth dependency at all
    # (dependency resolution is a good part of a status read's cost). Writes always require the token.
    read_auth = [ReadAuth] if settings.read_requires_token else []
    for module in (jobs, models, bundles, results):
        app.include_router(module.router, prefix="/v1", dependencies=read_auth)
    web.install(app)  # the dashboard: /ui pages over the same store
    return app
