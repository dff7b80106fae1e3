"""Health and metrics: liveness, readiness, Prometheus text."""

from __future__ import annotations

from fastapi import APIRouter, Depends, Request, Response

from service.deps import ManagerDep, metrics_access
from service.problems import Unavailable

api = APIRouter(tags=["health"])


@api.get("/healthz", operation_id="healthz", summary="Alive")
async def healthz() -> dict[str, str]:
    return {"status": "ok"}


@api.get(
    "/readyz",
    operation_id="readyz",
    summary="Store and executor usable",
    responses={503: {"description": "Not ready", "content": {"application/problem+json": {}}}},
)
async def readyz(manager: ManagerDep) -> dict:
    if not manager.store.ping():
        raise Unavailable("the job store does not answer")
    if not manager.executor.ready():
        raise Unavailable(f"the {manager.executor.name} executor is not ready")
    return {"status": "ready", **manager.executor.describe()}


@api.get(
    "/metrics",
    operation_id="metrics",
    summary="Prometheus metrics",
    response_class=Response,
    dependencies=[Depends(metrics_access)],
    responses={
        200: {"content": {"text/plain": {}}, "description": "Prometheus text format."},
        401: {"description": "Missing or wrong metrics token (API keys are set)."},
    },
)
async def metrics(request: Request) -> Response:
    return Response(
        request.app.state.metrics.render(), media_type="text/plain; version=0.0.4; charset=utf-8"
    )
