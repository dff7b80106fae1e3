"""The method registry: one readable entry per method.

A method is a name, a pydantic params model, a function running it on
meshcore and returning the result object (DESIGN.md's fixed keys: ``mesh``,
``quality``, ``axis``, ``domain``, ``regions``, ``stats``), a summary, the
section of the methods text, and an example of valid params. The service
never grows a route per method: the request body is a discriminated union
over this table (see :func:`service.api.jobs.request_model`).

Run functions are module-level so that they pickle by reference into the
job's process.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from meshcore import quality
from service.schemas import MeshIn, MethodParams

Progress = Callable[[float, str], None]


@dataclass(frozen=True)
class MethodSpec:
    """One method of the service."""

    name: str
    summary: str
    section: str
    params: type[MethodParams]
    run: Callable[[Any, Progress], dict]
    example: dict


Registry = dict[str, MethodSpec]

_UNIT_SQUARE = {
    "points": [[0, 0], [1, 0], [1, 1], [0, 1]],
    "cells": [{"type": "triangle", "data": [[0, 1, 2], [0, 2, 3]]}],
}


class QualityParams(MethodParams):
    mesh: MeshIn


def run_quality(params: QualityParams, progress: Progress) -> dict:
    """The quality report of DESIGN.md for the given mesh."""
    return {"quality": quality.report(params.mesh.to_mesh(), progress=progress)}


def default_registry() -> Registry:
    """The product's methods, by name."""
    specs = [
        MethodSpec(
            name="quality",
            summary="Quality report of a mesh: per cell type counts, invalid cells, "
            "quality and angle statistics, conformity.",
            section="§8.3.1 (conformity), §8.4.4 (quad quality); DESIGN.md quality measures",
            params=QualityParams,
            run=run_quality,
            example={"mesh": _UNIT_SQUARE},
        ),
    ]
    return {s.name: s for s in specs}
