"""The convert resource: a mesh file in any format meshio reads, answered as the JSON mesh.

The web page uploads meshes through it for the methods that take a mesh or a
surface; any client may use it to turn a file into a method's ``mesh`` param.
The body is the file's bytes; ``?filename=`` names it, and its suffix picks
the reader (meshio's own rule). Bodies over ``MESHSERVICE_MAX_BODY_BYTES``
and meshes over ``MESHSERVICE_MAX_POINTS`` answer 413, a suffix meshio does
not read 415, and a file its reader refuses 422.
"""

from __future__ import annotations

import asyncio
from typing import Annotated, Any

from fastapi import APIRouter, Query, Request
from fastapi.responses import JSONResponse

from service.deps import ClientDep, SettingsDep
from service.methods.registry import InputError, mesh_of_file
from service.problems import TooLarge, UnsupportedMediaType, from_input_error
from service.schemas import MeshIn, ProblemOut


def _problems(*statuses: int) -> dict[int | str, dict[str, Any]]:
    return {s: {"model": ProblemOut, "content": {"application/problem+json": {}}} for s in statuses}


def router() -> APIRouter:
    api = APIRouter(prefix="/v1/convert", tags=["convert"])

    @api.post(
        "",
        operation_id="convertMesh",
        summary="Read a mesh file (any format meshio reads) into the JSON mesh",
        response_model=None,
        responses={
            200: {
                "description": "The mesh in the JSON shape of a method's `mesh` param.",
                "content": {"application/json": {"schema": MeshIn.model_json_schema()}},
            },
            **_problems(401, 413, 415, 422),
        },
        openapi_extra={
            "requestBody": {
                "required": True,
                "content": {
                    "application/octet-stream": {"schema": {"type": "string", "format": "binary"}}
                },
            }
        },
    )
    async def convert(
        request: Request,
        settings: SettingsDep,
        _client: ClientDep,
        filename: Annotated[
            str,
            Query(
                min_length=1,
                max_length=255,
                description="The file's name; its suffix (.msh, .vtu, .stl, ...) picks the reader.",
            ),
        ],
    ) -> JSONResponse:
        data = await request.body()
        try:
            mesh = await asyncio.to_thread(mesh_of_file, data, filename)
        except InputError as exc:
            if exc.code == "unsupported_format":
                raise UnsupportedMediaType(exc.message) from None
            raise from_input_error(exc) from None
        if len(mesh["points"]) > settings.max_points:
            raise TooLarge(
                f"the mesh has {len(mesh['points'])} points; this service takes at most "
                f"{settings.max_points} (MESHSERVICE_MAX_POINTS)"
            )
        return JSONResponse(mesh)

    return api
