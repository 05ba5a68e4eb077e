"""FastAPI application of the ROM-AMS flutter service (``uvicorn api.app:app``)."""

from __future__ import annotations

import contextlib
from collections.abc import AsyncIterator
from pathlib import Path
from typing import Any

import anyio.to_thread
from fastapi import Depends, FastAPI
from fastapi.middleware.cors import CORSMiddleware
from fastapi.responses import RedirectResponse
from fastapi.staticfiles import StaticFiles
from starlette.types import ASGIApp

from api import openapi, problems
from api.deps import Service, service, single_query_values
from api.middleware import RequestGuard, SecurityHeaders
from api.responses import Health, ok
from romams import __version__
from romams.jobs import StaleSweeper
from romams.memory import heap_trimmer, limit_malloc_arenas
from romams.persistence import open_store
from romams.settings import Settings, get_settings

STATIC_DIR = Path(__file__).resolve().parent / "static"
CORS_HEADERS = ["Authorization", "Content-Type", "Accept"]


class RomamsAPI(FastAPI):
    """FastAPI with the security headers outside everything else (also on Starlette's own 500 page)."""

    def build_middleware_stack(self) -> ASGIApp:
        return SecurityHeaders(super().build_middleware_stack())

    def openapi(self) -> dict[str, Any]:
        """The OpenAPI document with the problem+json schema and the image content types (api.openapi)."""
        if self.openapi_schema is None:
            self.openapi_schema = openapi.finish(super().openapi())
        return self.openapi_schema


def create_app(settings: Settings | None = None, *, celery: Any = None, sweeper: bool = True) -> FastAPI:
    """Build the app for ``settings`` (default: the environment); ``celery`` overrides the task sender."""
    settings = settings or get_settings()
    if celery is None:
        from romams.services.queue import make_celery

        celery = make_celery(settings)
    store = open_store(settings)

    @contextlib.asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        # the threads running synchronous handlers: as many as the database pool holds connections for
        anyio.to_thread.current_default_thread_limiter().total_tokens = settings.api_threads
        limit_malloc_arenas(settings.malloc_arena_max)  # before the pool's threads exist (docs/reliability.md)
        trimmer = heap_trimmer(settings.heap_trim_s).start() if settings.heap_trim_s > 0 else None
        sw = (StaleSweeper(store, celery, settings.job_stale_s, queued_resend_s=settings.job_queued_resend_s).start()
              if sweeper else None)
        try:
            yield
        finally:
            if sw is not None:
                sw.stop()
            if trimmer is not None:
                trimmer.stop(join_s=5.0)

    app = RomamsAPI(title="romams", version=__version__, lifespan=lifespan, dependencies=[Depends(single_query_values)],
                    docs_url=None, redoc_url=None,
                  description="ROM-AMS flutter service: wings, PCA bases, aerodynamic ROM training, flutter "
                              "evaluation of arbitrary structures. Errors are RFC 9457 problem+json.")
    app.state.service = Service(settings=settings, store=store, celery=celery)
    problems.install(app)
    app.add_middleware(RequestGuard, settings=settings)
    if settings.cors_origins:  # outside the guard: it answers preflights (which carry no key) itself
        app.add_middleware(CORSMiddleware, allow_origins=settings.cors_origins, allow_headers=CORS_HEADERS,
                           allow_methods=["GET", "POST", "PUT"], expose_headers=["Retry-After", "Location"],
                           max_age=600)

    from api.dashboard import router as dashboard_router
    from api.dashboard_pages import router as pages_router
    from api.routes import flutter, jobs, modes, runs, tables, wings

    for r in (tables.router, wings.router, jobs.router, flutter.router, modes.router, runs.router):  # shapes.npz first
        app.include_router(r, prefix="/api/v1")
    app.include_router(dashboard_router)
    app.include_router(pages_router)
    openapi.install_docs(app)  # /docs and /redoc from the package's assets (no CDN)
    app.mount("/static", StaticFiles(directory=STATIC_DIR), name="static")

    @app.get("/", include_in_schema=False)
    def root() -> RedirectResponse:
        return RedirectResponse("/dashboard")

    @app.get("/api/v1/health", tags=["meta"], responses={**openapi.problems(503), **ok(Health, "the service is up")})
    def health(svc: Service = Depends(service)) -> dict[str, Any]:
        """Liveness + database check (503 problem with Retry-After while the database is unavailable)."""
        return {"status": "ok", "version": __version__, "database": svc.store.ping()}

    return app


def __getattr__(name: str) -> Any:
    """``api.app:app`` is built on first access (so importing the module has no side effects)."""
    if name == "app":
        application = create_app()
        globals()["app"] = application
        return application
    raise AttributeError(name)
