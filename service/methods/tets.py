"""Params and run function of ``tetrahedralize`` (§9.2, §9.3, §9.5; Delaunay refinement).

The params model refuses, with the field's location, what JSON Schema can
say (shapes, signs, ranges, NaN and infinities); its :meth:`check` runs
:func:`meshcore.domain.surface.parse_surface` (open, non-manifold,
inconsistently oriented or self-intersecting surfaces, ...) and raises
:class:`~meshcore.errors.InputError` located under ``surface``.

meshcore's method packages are imported in the functions that use them (see
:mod:`service.methods.registry`).
"""

from __future__ import annotations

from typing import Annotated

import numpy as np
from pydantic import Field

from meshcore.domain.planar import parse_size_field
from meshcore.errors import InputError
from meshcore.limits import MIN_RADIUS_EDGE
from meshcore.mesh import quality
from service.methods.domain_schema import check_resolution
from service.methods.surface_schema import UNIT_CUBE, Position3, SurfaceIn
from service.methods.triangulation import SizeField
from service.schemas import MethodParams

PositiveFloat = Annotated[float, Field(gt=0, allow_inf_nan=False)]


class SizeField3(SizeField):
    """Target edge lengths at scattered 3D points (the control space of Remark 8.10)."""

    points: list[Position3] = Field(min_length=1, description="[x, y, z] positions, distinct.")


class TetrahedralizeParams(MethodParams):
    """Tetrahedra filling a closed surface, refined to the given bounds."""

    surface: SurfaceIn
    empty: bool = Field(
        default=False,
        description="Only the surface points and the Steiner points on the surface that make "
        "every input triangle a union of Delaunay faces (the empty tetrahedralization of §9.5); "
        "the bounds below are ignored.",
    )
    max_radius_edge: Annotated[float, Field(ge=MIN_RADIUS_EDGE, allow_inf_nan=False)] | None = (
        Field(
            default=2.0,
            description="Circumradius over shortest edge of every tetrahedron at most this "
            "(TetGen's -q), except where the refinement gives up (stats.given_up); null for no "
            "bound.",
        )
    )
    min_dihedral: Annotated[float, Field(gt=0, le=70, allow_inf_nan=False)] | None = Field(
        default=None,
        description="Degrees: slivers removed after refinement for the tetrahedra whose least "
        "dihedral angle is below it: edge removal, flips, smoothing and point insertion, "
        "each raising the local least angle and keeping "
        "max_radius_edge (where that is not enough, a second stage trades the ratio: "
        "stats.left.improvement.radius_edge_traded); the output is then not Delaunay. "
        "Best effort: quality.tetra.dihedral says what was reached, stats.left counts "
        "the tetrahedra still below it by cause (fold: between two input triangles at nearly "
        "180 degrees; surface; interior; input_angle: skinny because of an input angle below "
        "60 degrees, with stats.left.input_angles naming the input vertices and segments).",
    )
    max_volume: PositiveFloat | None = Field(
        default=None, description="Largest tetrahedron volume."
    )
    size: PositiveFloat | None = Field(default=None, description="Target edge length.")
    size_field: SizeField3 | None = Field(
        default=None,
        description="Target edge lengths at scattered points, interpolated linearly on their "
        "Delaunay tetrahedralization (nearest value outside their hull); with size, the "
        "smaller of the two.",
    )
    keep_boundary: bool = Field(
        default=False,
        description="No point on the surface: the boundary faces are exactly the input "
        "triangles (interior Steiner points only: none for a Delaunay-admissible surface, one "
        "per star-shaped region, e.g. Schönhardt's prism, else the conforming recovery's "
        "surface points moved inside).",
    )

    def check(self) -> None:
        from meshcore.tets.sizing import MAX_TETRAHEDRA, SizeField3d, estimated_tetrahedra

        super().check()
        surface = self.surface.to_surface()
        if self.empty or self.keep_boundary:  # no interior refinement to the bounds
            if self.size_field is not None:  # a bad field is refused all the same, located
                parse_size_field(self.size_field, dim=3)  # (not interpolated: no Delaunay)
            return
        # a bad field is refused here, located
        field = SizeField3d(self.size_field) if self.size_field is not None else None
        check_resolution(surface.points, self.size, ("size",))
        estimate = estimated_tetrahedra(
            surface, size=self.size, max_volume=self.max_volume, size_field=field
        )
        if estimate.tetrahedra > MAX_TETRAHEDRA:
            raise InputError(
                f"these bounds would make about {estimate.tetrahedra:,} tetrahedra in a volume "
                f"of {surface.volume:.6g}; this service makes at most {MAX_TETRAHEDRA:,}: "
                "ask for a larger size, max_volume or size_field",
                loc=(estimate.binding,),
                code="too_many_tetrahedra",
            )


def run_tetrahedralize(params: TetrahedralizeParams, progress) -> dict:
    """The tetrahedral mesh, its quality report (with dihedral angles) and the counts."""
    from meshcore.tets import tetra_dihedral_angles, tetrahedralize

    surface = params.surface.to_surface()

    def sub(fraction: float, message: str) -> None:
        progress(0.9 * fraction, message)

    res = tetrahedralize(
        surface,
        empty=params.empty,
        max_radius_edge=params.max_radius_edge,
        min_dihedral=params.min_dihedral,
        max_volume=params.max_volume,
        size=params.size,
        size_field=params.size_field,
        keep_boundary=params.keep_boundary,
        progress=sub,
    )
    progress(0.9, "quality report")
    report = quality.report(res.mesh)
    P, K = res.mesh.points, res.mesh.cells[0].data
    dihedral = tetra_dihedral_angles(P, K) if len(K) else np.zeros((0, 6))
    report["tetra"]["dihedral"] = {
        "min": float(dihedral.min()) if len(K) else None,
        "max": float(dihedral.max()) if len(K) else None,
    }
    return {
        "mesh": res.mesh,
        "quality": report,
        "stats": {
            "points": len(P),
            "tetrahedra": len(K),
            "regions": {k: len(v[0]) for k, v in res.mesh.cell_sets.items()},
            "input_points": int(len(surface.vertices)),
            "input_triangles": int(len(surface.triangles)),
            "volume": surface.volume,
            "surface_points_added": res.surface_points_added,
            "interior_points_added": res.interior_points_added,
            "rounds": res.rounds,
            "given_up": res.given_up,
            "left": res.left,
            "seconds": {k: round(v, 6) for k, v in res.timings.items()},
        },
    }


#: The unit cube, refined to edges of about 0.25.
TETRAHEDRALIZE_EXAMPLE = {"surface": UNIT_CUBE, "size": 0.25, "max_radius_edge": None}
