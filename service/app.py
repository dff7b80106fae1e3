"""The application factory: ``create_app(settings)``; nothing is built at import time."""

from __future__ import annotations

import functools
import gc
import logging
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path

from fastapi import FastAPI
from fastapi.middleware.cors import CORSMiddleware
from fastapi.openapi.utils import get_openapi
from fastapi.responses import FileResponse
from fastapi.staticfiles import StaticFiles

from service.api import convert, health, jobs, methods
from service.executors import Executor
from service.executors.local import LocalExecutor
from service.jobs import JobManager
from service.limits import BodySizeLimit, ClientTimeouts
from service.methods.registry import Registry, default_registry
from service.metrics import Metrics
from service.problems import install_handlers
from service.settings import Settings
from service.store import Store, StoreDamaged

log = logging.getLogger("meshservice")

DESCRIPTION = """\
Meshing jobs over HTTP: submit a method and its params as JSON, poll or
stream the job, fetch the result as JSON or download its mesh in a file
format. Errors are RFC 9457 problem documents. The service's own web page
is at `/`.
"""

WEB = Path(__file__).parent / "web"


def _openapi(app: FastAPI, keys: bool) -> dict:
    """The app's OpenAPI document; the bearer scheme and 401s only when API keys are set."""
    if app.openapi_schema is None:
        schema = get_openapi(
            title=app.title, version=app.version, description=app.description, routes=app.routes
        )
        components = schema.setdefault("components", {}).setdefault("schemas", {})
        for path in schema["paths"].values():
            for operation in path.values():
                components.update(operation.pop("x-schemas", {}))
        if not keys:
            schema.get("components", {}).pop("securitySchemes", None)
            for path in schema["paths"].values():
                for operation in path.values():
                    operation.pop("security", None)
                    operation.get("responses", {}).pop("401", None)
        app.openapi_schema = schema
    return app.openapi_schema


def create_app(settings: Settings | None = None, registry: Registry | None = None) -> FastAPI:
    """The service for ``settings`` running the methods of ``registry`` (default: all)."""
    settings = settings or Settings()
    registry = registry if registry is not None else default_registry()

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        try:
            store = Store(settings.data_dir, settings.durable)
        except StoreDamaged as exc:
            log.error("refusing to start: %s", exc)
            raise
        metrics = Metrics(store.counts_by_status)
        executor: Executor
        if settings.dask_scheduler:
            # imported here: dask.distributed costs a second at start-up when unused
            from service.executors.cluster import DaskExecutor

            executor = DaskExecutor(settings.dask_scheduler, settings.job_memory_limit)
        else:
            executor = LocalExecutor(
                settings.workers, settings.job_memory_limit, settings.data_dir, settings.warmup
            )
        manager = JobManager(store, executor, registry, settings, metrics)
        app.state.metrics = metrics
        app.state.manager = manager
        await manager.start()
        # Everything loaded by now (meshcore, numba, scipy: ~140k objects) lives as long
        # as the process: out of the collector's sight, a full collection under load
        # takes microseconds instead of ~200 ms stalls of every request.
        gc.collect()
        gc.freeze()
        try:
            yield
        finally:
            await manager.close()
            store.close()

    app = FastAPI(
        title="meshservice",
        version="0.1.0",
        description=DESCRIPTION,
        lifespan=lifespan,
    )
    app.state.settings = settings
    app.openapi = functools.partial(_openapi, app, bool(settings.clients_by_key))
    install_handlers(app)
    app.include_router(jobs.router(registry))
    app.include_router(methods.router(registry))
    app.include_router(convert.router())
    app.include_router(health.api)
    # The web page: static files, public like /healthz (they hold no data; the
    # page sends the API key on its /v1 calls). Mounts stay out of the schema.
    app.mount("/static", StaticFiles(directory=WEB), name="static")

    @app.get("/", include_in_schema=False)
    async def page() -> FileResponse:
        return FileResponse(WEB / "index.html", headers={"Cache-Control": "no-cache"})

    if settings.cors_origin_list:
        app.add_middleware(
            CORSMiddleware,
            allow_origins=settings.cors_origin_list,
            allow_methods=["GET", "POST", "DELETE"],
            allow_headers=["Authorization", "Content-Type", "Idempotency-Key", "If-None-Match"],
            expose_headers=["Location", "Retry-After", "ETag", "Content-Disposition"],
        )
    app.add_middleware(BodySizeLimit, max_bytes=settings.max_body_bytes)
    app.add_middleware(
        ClientTimeouts, body_timeout=settings.body_timeout, send_timeout=settings.send_timeout
    )
    logging.getLogger("meshservice").setLevel(logging.INFO)
    return app
