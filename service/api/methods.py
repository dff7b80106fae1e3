"""The methods resource: what the service can run, with each params schema."""

from __future__ import annotations

from fastapi import APIRouter, Depends

from service.deps import authenticated
from service.methods.registry import MethodSpec, Registry
from service.problems import NotFound
from service.schemas import MethodOut, ProblemOut


def _out(spec: MethodSpec) -> MethodOut:
    return MethodOut(
        name=spec.name,
        summary=spec.summary,
        section=spec.section,
        params_schema=spec.params.model_json_schema(),
        example=spec.example,
    )


def router(registry: Registry) -> APIRouter:
    api = APIRouter(prefix="/v1/methods", tags=["methods"], dependencies=[Depends(authenticated)])

    @api.get(
        "",
        operation_id="listMethods",
        summary="The methods and their params",
        responses={401: {"model": ProblemOut, "content": {"application/problem+json": {}}}},
    )
    async def list_methods() -> list[MethodOut]:
        return [_out(spec) for spec in registry.values()]

    @api.get(
        "/{name}",
        operation_id="getMethod",
        summary="One method and its params",
        responses={
            s: {"model": ProblemOut, "content": {"application/problem+json": {}}}
            for s in (401, 404)
        },
    )
    async def get_method(name: str) -> MethodOut:
        spec = registry.get(name)
        if spec is None:
            raise NotFound(f"no method {name!r}; GET /v1/methods lists them")
        return _out(spec)

    return api
