"""Health and metrics: liveness, readiness, Prometheus text."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Depends, Request, Response
from fastapi.responses import JSONResponse

from service.deps import ManagerDep, metrics_access
from service.problems import PROBLEM_MEDIA_TYPE, Unavailable

api = APIRouter(tags=["health"])


@api.get("/healthz", operation_id="healthz", summary="Alive")
async def healthz() -> dict[str, str]:
    return {"status": "ok"}


@api.get(
    "/readyz",
    operation_id="readyz",
    summary="Store and executor usable",
    responses={
        503: {
            "description": "Not ready; while the kernels compile (first start), the problem's "
            "`warming` member says how far: `done`, `total`, `current`, `left`.",
            "content": {"application/problem+json": {}},
        }
    },
)
async def readyz(manager: ManagerDep) -> Any:
    if not manager.store.ping():
        raise Unavailable("the job store does not answer")
    if not manager.executor.ready():
        warming = getattr(manager.executor, "warming", lambda: None)()
        if warming is not None:
            if warming["total"] is None:
                where = warming["current"]
            else:
                left = ", ".join(warming["left"]) or "none"
                where = (
                    f"compiling kernels {warming['done'] + 1}/{warming['total']} "
                    f"({warming['current']}); left: {left}"
                    if warming["current"]
                    else "the kernels are compiled; the executor is starting"
                )
            doc = Unavailable(
                f"warming: {where}. Jobs submitted now queue and run when it is done."
            ).document()
            return JSONResponse(
                {**doc, "warming": warming},
                status_code=503,
                media_type=PROBLEM_MEDIA_TYPE,
                headers={"Retry-After": "5"},
            )
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
