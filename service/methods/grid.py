"""Params and run functions of the grid methods (§8.2).

Each params model refuses, with the field's location, what JSON Schema can
say (choices, signs, NaN and infinities); its :meth:`check` runs meshcore's
own checks before the job is queued: the domain (every error of
``triangulate``'s domain, located under ``domain`` or ``segments``) and the
grid's size against ``max_cells`` (a 422 on ``size`` giving the estimate);
``quad_grid``'s also refuses a fallback band past its bound where the grid
alone tells that the projection cannot apply
(:func:`meshcore.grid.superposition.check_band`).

meshcore's method packages are imported in the functions that use them (see
:mod:`service.methods.registry`).
"""

from __future__ import annotations

import math
from typing import Annotated, Literal

from pydantic import ConfigDict, Field, model_validator

from meshcore.errors import InputError
from meshcore.limits import MAX_CELLS
from meshcore.mesh import quality
from service.methods.domain_schema import (
    ConstraintPolylines,
    DomainIn,
    Position,
    check_resolution,
)
from service.methods.triangulation import check_thinness
from service.schemas import InputModel, MethodParams, Progress


class GridParams(MethodParams):
    """A mesh of a planar domain by a regular grid of squares (§8.2)."""

    domain: DomainIn
    segments: ConstraintPolylines | None = None
    size: float | None = Field(
        None,
        gt=0,
        allow_inf_nan=False,
        description="Cell side. Default: the smallest distance between two boundary vertices, "
        "enlarged to keep the grid under max_cells.",
    )
    origin: Position | None = Field(
        None, description="A grid node (default: the lower-left corner of the domain's box)."
    )
    angle: float = Field(
        0.0, allow_inf_nan=False, description="Rotation of the grid, degrees counter-clockwise."
    )
    boundary: Literal["keep", "fit", "split"] = Field(
        "fit",
        description="keep: every cell meeting the domain whole (the staircase); fit: boundary "
        "nodes snapped onto the boundary and cut cells split by templates into quads and "
        "triangles, the domain covered exactly; split: as fit, cut cells as triangles only.",
    )
    cells: Literal["quad", "triangle"] = Field(
        "quad", description="Squares, or each square as two right triangles."
    )
    max_cells: int = Field(
        MAX_CELLS,
        ge=1,
        le=MAX_CELLS,
        description="Largest number of cells of the grid's bounding box.",
    )

    def check(self) -> None:
        from meshcore.grid import cartesian

        super().check()
        dom = self.domain.to_domain(self.segments)
        check_resolution(dom.points, self.size, ("size",))
        if self.size is not None:
            est = cartesian.estimated_cells(dom, size=self.size, angle=self.angle)
            if est > self.max_cells:
                raise InputError(
                    f"size {self.size:g} makes a grid of about {est} cells, more than "
                    f"max_cells={self.max_cells}",
                    loc=("size",),
                    code="too_many_cells",
                )

    def grid_kwargs(self) -> dict:
        """Keyword arguments of :func:`meshcore.grid.grid`."""
        return {
            "domain": self.domain.to_domain(self.segments),
            "size": self.size,
            "origin": self.origin,
            "angle": self.angle,
            "boundary": self.boundary,
            "cells": self.cells,
            "max_cells": self.max_cells,
        }


def run_grid(params: GridParams, progress: Progress) -> dict:
    """The grid mesh, its quality report and the counts by kind and template."""
    from meshcore.grid import cartesian

    res = cartesian.grid(**params.grid_kwargs(), progress=progress)
    stats = {**res.stats, "seconds": res.timings}
    return {"mesh": res.mesh, "quality": quality.report(res.mesh), "stats": stats}


class QuadGridParams(MethodParams):
    """An all-quad mesh of a planar domain by grid superposition (§8.5.2)."""

    domain: DomainIn
    segments: ConstraintPolylines | None = None
    size: float | None = Field(
        None,
        gt=0,
        allow_inf_nan=False,
        description="Grid side (the interior squares'). Default as for grid.",
    )
    layers: int = Field(
        1, ge=1, le=8, description="Quads across the band between the squares and the boundary."
    )
    smooth: bool = Field(
        True,
        description="Optimize the band and two rings of squares along it: operators and "
        "smoothing that never inverts a cell; the boundary stays.",
    )
    max_cells: int = Field(MAX_CELLS, ge=1, le=MAX_CELLS)

    def check(self) -> None:
        from meshcore.grid import superposition

        super().check()
        dom = self.domain.to_domain(self.segments)
        check_resolution(dom.points, self.size, ("size",))
        check_thinness(dom)  # the band is triangulated: its thin parts' triangles
        # the grid's size (too_many_cells at size) and the fallback band's refusal where
        # the grid alone decides it (else in the job)
        superposition.check_band(dom, size=self.size, layers=self.layers, max_cells=self.max_cells)


def run_quad_grid(params: QuadGridParams, progress: Progress) -> dict:
    """The all-quad mesh, its quality report and the counts."""
    from meshcore.grid import superposition

    res = superposition.quad_grid(
        params.domain.to_domain(params.segments),
        size=params.size,
        layers=params.layers,
        smooth=params.smooth,
        max_cells=params.max_cells,
        progress=progress,
    )
    stats = {**res.stats, "seconds": res.timings}
    return {"mesh": res.mesh, "quality": quality.report(res.mesh), "stats": stats}


class ParallelogramPattern(InputModel):
    """Cells ``origin + i a + j b`` (Figure 8.6, left)."""

    model_config = ConfigDict(extra="forbid")

    type: Literal["parallelogram"]
    vectors: Annotated[list[Position], Field(min_length=2, max_length=2)] = Field(
        description="The two edge vectors a and b: neither zero, not parallel."
    )
    origin: Position | None = Field(None, description="A pattern vertex (default: box corner).")


class HexagonPattern(InputModel):
    """Regular hexagons of six equilateral triangles of side ``size``."""

    model_config = ConfigDict(extra="forbid")

    type: Literal["hexagon"]
    size: float = Field(gt=0, allow_inf_nan=False, description="Side of the hexagons.")
    origin: Position | None = None


class RadialPattern(InputModel):
    """Quads between circles about a centre, in angular sectors (Figure 8.6, middle, right)."""

    model_config = ConfigDict(extra="forbid")

    type: Literal["radial"]
    center: Position
    radii: list[Annotated[float, Field(gt=0, allow_inf_nan=False)]] | None = Field(
        None, min_length=2, description="Increasing radii of the circles (all above 0)."
    )
    rings: int | None = Field(
        None, ge=1, le=4096, description="Or: this many rings up to the farthest domain vertex."
    )
    segments: int = Field(ge=3, le=1 << 16, description="Angular sectors.")

    @model_validator(mode="after")
    def _one_of(self) -> RadialPattern:
        if (self.radii is None) == (self.rings is None):
            raise ValueError("give either radii or rings")
        return self


Pattern = Annotated[
    ParallelogramPattern | HexagonPattern | RadialPattern, Field(discriminator="type")
]


class PatternParams(MethodParams):
    """A mesh of pre-defined patterns plus a mesh of the gap along the boundary (§8.2)."""

    domain: DomainIn
    segments: ConstraintPolylines | None = None
    pattern: Pattern
    margin: float = Field(
        0.5,
        gt=0,
        allow_inf_nan=False,
        description="Patterns closer to the boundary than margin times their size are dropped.",
    )
    gap: Literal["triangles", "quads"] = Field(
        "triangles",
        description="The gap as triangles, or (quad_combine all_quad, patterns split alike) "
        "the whole mesh as quads.",
    )

    def check(self) -> None:
        from meshcore.grid import patterns

        super().check()
        check_thinness(self.domain.to_domain(self.segments))  # the gap is triangulated
        patterns.check_pattern(self.pattern.model_dump())

    def pattern_kwargs(self) -> dict:
        return {
            "domain": self.domain.to_domain(self.segments),
            "pattern": self.pattern.model_dump(),
            "margin": self.margin,
            "gap": self.gap,
        }


def run_pattern(params: PatternParams, progress: Progress) -> dict:
    """The merged mesh (cell sets pattern and gap), its quality and the Figure 8.7 counts."""
    from meshcore.grid import patterns

    res = patterns.pattern(**params.pattern_kwargs(), progress=progress)
    stats = {**res.stats, "seconds": res.timings}
    return {"mesh": res.mesh, "quality": quality.report(res.mesh), "stats": stats}


#: The unit square with a round hole, cells of side 0.05, the boundary fitted.
GRID_EXAMPLE = {
    "domain": {
        "type": "Polygon",
        "coordinates": [
            [[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]],
            [[0.75, 0.5], [0.5, 0.75], [0.25, 0.5], [0.5, 0.25], [0.75, 0.5]],
        ],
    },
    "size": 0.05,
    "boundary": "fit",
}

#: The same domain, quads of side 0.025, smoothed.
QUAD_GRID_EXAMPLE = {"domain": GRID_EXAMPLE["domain"], "size": 0.025, "smooth": True}

#: Figure 8.7: a disc with a rectangular hole off its centre, radial quads about a point.
PATTERN_EXAMPLE = {
    "domain": {
        "type": "Polygon",
        "coordinates": [
            [
                [round(math.cos(k * math.pi / 24), 9), round(math.sin(k * math.pi / 24), 9)]
                for k in range(48)
            ],
            [[0.15, -0.2], [0.15, 0.25], [0.55, 0.25], [0.55, -0.2]],
        ],
    },
    "pattern": {"type": "radial", "center": [-0.3, 0.1], "rings": 8, "segments": 32},
}
