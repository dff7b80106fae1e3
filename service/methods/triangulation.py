"""Params and run functions of the triangulation methods (§9.1).

meshcore's method packages are imported in the functions that use them (see
:mod:`service.methods.registry`).

Each params model refuses, with the field's location, what JSON Schema can
say (shapes, signs, ranges, NaN and infinities); its :meth:`check` runs
meshcore's own checks (domain validation, curves against their rings, size
field points, conflicting options, runaway sizes) and raises
:class:`~meshcore.errors.InputError` located relative to the params.
"""

from __future__ import annotations

from typing import Annotated, Literal

import numpy as np
from pydantic import ConfigDict, Field, model_validator

from meshcore.errors import InputError
from meshcore.limits import MAX_MIN_ANGLE
from meshcore.mesh import quality
from service.methods.domain_schema import (
    ConstraintPolylines,
    DomainIn,
    Position,
    check_resolution,
)
from service.methods.surface_schema import SurfaceIn
from service.schemas import InputModel, MethodParams

#: Requests whose sizes would make more triangles than this are refused (422).
MAX_TRIANGLES = 20_000_000

PositiveFloat = Annotated[float, Field(gt=0, allow_inf_nan=False)]


class CircleCurve(InputModel):
    """A ring that samples a circle: new points on it go on the circle (§9.1.5)."""

    model_config = ConfigDict(extra="forbid")

    ring: int = Field(ge=0, description="Ring index, in the order of the geometry's rings.")
    type: Literal["circle"] = "circle"
    center: Position
    radius: PositiveFloat


class SizeField(InputModel):
    """Target edge lengths at scattered points (the control space of Remark 8.10)."""

    model_config = ConfigDict(extra="forbid")

    points: list[Position] = Field(min_length=1, description="[x, y] positions, distinct.")
    values: list[PositiveFloat] = Field(
        min_length=1, description="Target edge length at each point (same count)."
    )

    @model_validator(mode="after")
    def _same_length(self) -> SizeField:
        if len(self.points) != len(self.values):
            raise ValueError(
                f"size_field has {len(self.points)} points but {len(self.values)} values"
            )
        return self

    def point_count(self) -> int:
        return len(self.points)


class TriangulateParams(MethodParams):
    """A boundary-conforming quality triangle mesh of a planar domain."""

    domain: DomainIn
    segments: ConstraintPolylines | None = None
    curves: list[CircleCurve] | None = Field(
        None, description="Rings that sample circles: added boundary points go on the circle."
    )
    empty: bool = Field(
        False,
        description="Only the boundary points (plus the Steiner points making the boundary "
        "Delaunay-admissible): the empty triangulation. Excludes the size and angle options.",
    )
    min_angle: float | None = Field(
        None,
        gt=0,
        le=MAX_MIN_ANGLE,
        allow_inf_nan=False,
        description="Degrees: refine until every triangle's smallest angle reaches it, except "
        "next to input angles below it. Always terminates up to 30. Default 20 (not empty).",
    )
    max_area: float | None = Field(
        None, gt=0, allow_inf_nan=False, description="Largest triangle area."
    )
    size: float | None = Field(None, gt=0, allow_inf_nan=False, description="Target edge length.")
    size_field: SizeField | None = Field(
        None,
        description="Target edge lengths at scattered points, interpolated linearly "
        "(nearest value outside their hull).",
    )
    keep_boundary: bool = Field(
        False,
        description="Add no point on any input segment (the mesh fits a neighbour's boundary "
        "exactly); refinement stops where it would encroach a segment.",
    )

    def check(self) -> None:
        from meshcore.delaunay.admissible import circles_of
        from meshcore.triangulation.refinement import estimated_triangles

        super().check()
        dom = self.domain.to_domain(self.segments)
        curves = [c.model_dump() for c in self.curves or []]
        circles_of(dom, curves)
        check_resolution(dom.points, self.size, ("size",))
        if self.empty:
            for name in ("min_angle", "max_area", "size", "size_field"):
                if getattr(self, name) is not None:
                    raise InputError(
                        f"empty=true adds no interior point; it excludes {name}",
                        loc=(name,),
                        code="conflicting_parameters",
                    )
            return  # no interior point, no angle bound: a thin strip is two triangles
        check_thinness(dom)
        field = None if self.size_field is None else self.size_field.model_dump()
        estimate = estimated_triangles(
            dom, max_area=self.max_area, size=self.size, size_field=field
        )
        if estimate.triangles > MAX_TRIANGLES:  # some size binds: check_thinness passed
            raise InputError(
                f"these sizes would make about {estimate.triangles:,} triangles on a domain of "
                f"area {dom.area:.6g}; this service makes at most {MAX_TRIANGLES:,}: "
                f"ask for a larger {estimate.binding}",
                loc=(estimate.binding,),
                code="too_many_triangles",
            )


def check_thinness(dom) -> None:
    """Refuse a domain so thin that a mesh meeting the angle bound, whatever the size, would
    be more than ``MAX_TRIANGLES`` triangles (:func:`meshcore.triangulation.check_thinness`)."""
    from meshcore.triangulation.refinement import check_thinness as check_forced_triangles

    check_forced_triangles(
        dom,
        MAX_TRIANGLES,
        code="too_many_triangles",
        advice=f"this service makes at most {MAX_TRIANGLES:,}",
    )


def run_triangulate(params: TriangulateParams, progress) -> dict:
    """The mesh, its quality report and the counts of added points."""
    from meshcore.triangulation.refinement import triangulate

    dom = params.domain.to_domain(params.segments)

    def sub(fraction: float, message: str) -> None:
        progress(0.9 * fraction, message)

    res = triangulate(
        dom,
        curves=[c.model_dump() for c in params.curves or []],
        empty=params.empty,
        min_angle=params.min_angle,
        max_area=params.max_area,
        size=params.size,
        size_field=None if params.size_field is None else params.size_field.model_dump(),
        keep_boundary=params.keep_boundary,
        progress=sub,
    )
    progress(0.9, "quality report")
    report = quality.report(res.mesh, boundary_segments=res.boundary_segments)
    return {
        "mesh": res.mesh,
        "quality": report,
        "stats": {
            "points": len(res.mesh.points),
            "triangles": len(res.mesh.cells[0].data),
            "input_points": len(dom.points),
            "boundary_points_added": res.boundary_points_added,
            "interior_points_added": res.interior_points_added,
            "rounds": res.rounds,
            "given_up": res.given_up,
            "seconds": {k: round(v, 6) for k, v in res.timings.items()},
        },
    }


def _circle(cx: float, cy: float, r: float, n: int) -> list[list[float]]:
    import math

    return [
        [
            round(cx + r * math.cos(2 * math.pi * k / n), 9),
            round(cy + r * math.sin(2 * math.pi * k / n), 9),
        ]
        for k in range(n)
    ]


#: A unit square with a circular hole of radius 0.25, 30 degrees, edge length 0.05.
TRIANGULATE_EXAMPLE = {
    "domain": {
        "type": "Polygon",
        "coordinates": [
            [[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]],
            _circle(0.5, 0.5, 0.25, 32),
        ],
    },
    "curves": [{"ring": 1, "type": "circle", "center": [0.5, 0.5], "radius": 0.25}],
    "min_angle": 30,
    "size": 0.05,
}


# ---------------------------------------------------------------------------
# delaunay_admissible (§9.1.2-§9.1.5)
# ---------------------------------------------------------------------------


class DelaunayAdmissibleParams(MethodParams):
    """A Delaunay-admissible boundary: a planar domain's segments (§9.1) or a closed
    surface's triangles (§9.2-§9.3), and the empty triangulation / tetrahedralization."""

    domain: DomainIn | None = Field(
        None, description="A planar domain (GeoJSON Polygon or MultiPolygon); or give surface."
    )
    surface: SurfaceIn | None = Field(
        None,
        description="A closed triangulated surface (3D, §9.2-§9.3): refined with points on it "
        "until every triangle is a Delaunay face; or give domain.",
    )
    segments: ConstraintPolylines | None = None
    curves: list[CircleCurve] | None = Field(
        None,
        description="Rings that sample circles (rings numbered in the order of the "
        "geometry): points added on them go on the circle, not on the chord (§9.1.5). "
        "With domain only.",
    )

    @model_validator(mode="after")
    def _one_input(self) -> DelaunayAdmissibleParams:
        if (self.domain is None) == (self.surface is None):
            raise ValueError("give exactly one of domain (2D) and surface (3D)")
        if self.surface is not None and (self.segments is not None or self.curves is not None):
            raise ValueError("segments and curves apply to a domain, not to a surface")
        return self

    def point_count(self) -> int:
        """The domain's positions plus the constraint polylines' positions, or the
        surface's points."""
        if self.surface is not None:
            return self.surface.point_count()
        return self.domain.point_count() + sum(len(line) for line in self.segments or [])

    def check(self) -> None:
        from meshcore.delaunay.admissible import circles_of

        super().check()
        if self.surface is not None:
            self.surface.to_surface()
            return
        dom = self.domain.to_domain(self.segments)
        circles_of(dom, [c.model_dump() for c in self.curves or []])


def run_delaunay_admissible(params: DelaunayAdmissibleParams, progress) -> dict:
    """The new boundary discretization, the empty Delaunay triangulation (2D) or
    tetrahedralization (3D) and the counts."""
    from meshcore.delaunay.admissible import make_admissible

    if params.surface is not None:
        return _run_surface_admissible(params.surface.to_surface(), progress)
    dom = params.domain.to_domain(params.segments)
    try:
        res = make_admissible(
            dom, curves=[c.model_dump() for c in params.curves or []], progress=progress
        )
    except InputError as exc:  # located in the domain: prefixed as params.domain's own
        errors = [
            {**e, "loc": list(e["loc"]) if e["loc"][:1] == ["segments"] else ["domain", *e["loc"]]}
            for e in exc.errors
        ]
        raise InputError(exc.message, code=exc.code, errors=errors) from None
    boundary = len(dom.segments)
    ring_of = np.searchsorted(dom.ring_offsets, res.source, side="right") - 1
    return {
        "domain": {
            "points": res.points,
            "segments": res.segments,
            "source": res.source,
            "ring": np.where(res.source < boundary, ring_of, -1),
        },
        "mesh": res.triangulation,
        "stats": {
            "input_points": len(dom.points),
            "input_segments": boundary + len(dom.constraints),
            "segments": len(res.segments),
            "points_added": res.added,
            "cases_before": res.cases_before,
            "cases_after": res.cases_after,
            "rounds": res.rounds,
            "protected_vertices": len(res.protected),
            "triangles": len(res.triangulation.cells[0].data),
        },
    }


def _run_surface_admissible(surface, progress) -> dict:
    """The 3D form (§9.2-§9.3.5): refined surface, empty tetrahedralization, the
    whole Delaunay tetrahedralization holding the surface with its tie cells, counts."""
    from meshcore.delaunay.admissible3d import make_admissible_surface

    res = make_admissible_surface(surface, progress=progress)
    tetra = res.mesh.cells[0].data
    return {
        "surface": {
            "points": res.points,
            "triangles": res.triangles,
            "source": res.source,
        },
        "mesh": res.mesh,
        "delaunay": {
            "tetrahedra": res.tetrahedra,
            "inside": res.inside,
            "ties": res.tie_tetrahedra,
        },
        "stats": {
            "input_points": int(len(surface.vertices)),
            "input_triangles": int(len(surface.triangles)),
            "triangles": len(res.triangles),
            "points_added": res.added_on_edges + res.added_on_faces,
            "points_added_on_edges": res.added_on_edges,
            "points_added_on_faces": res.added_on_faces,
            "cases_before": res.cases_before,
            "cases_after": res.cases_after,
            "rounds": res.rounds,
            "coplanar_swaps": res.swaps,
            "tetrahedra": len(tetra),
            "delaunay_tetrahedra": len(res.tetrahedra),
            "tie_cells": res.tie_flips,
            "tie_tetrahedra": len(res.tie_tetrahedra),
            "seconds": {k: round(v, 6) for k, v in res.timings.items()},
        },
    }


#: A three-pointed star whose tips are 5° corners between sides of lengths 7.5 and 3.
DELAUNAY_ADMISSIBLE_EXAMPLE = {
    "domain": {
        "type": "Polygon",
        "coordinates": [
            [
                [2.51, -0.33],
                [10.0, 0.0],
                [7.0, 0.13],
                [-0.97, 2.33],
                [-5.0, 8.66],
                [-3.61, 6.0],
                [-1.54, -2.01],
                [-5.0, -8.66],
                [-3.39, -6.13],
            ]
        ],
    }
}
