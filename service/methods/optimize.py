"""Params and run function of ``optimize``: Coupez's optimization-based method (§8.3).

The params model refuses, with the field's location, what JSON Schema can
say (choices, ranges, NaN and infinities, exactly one of mesh or domain,
options that go with one input only); its :meth:`check` runs meshcore's
checks before the job is queued: the domain's validation, or the mesh's
shape, cell types and topology (an edge or face in three or more cells, a
neighbour oriented against another, each named by ``loc``).

meshcore's method packages are imported in the functions that use them (see
:mod:`service.methods.registry`).
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from pydantic import Field, model_validator

from meshcore.errors import InputError
from service.methods.domain_schema import DomainIn, check_resolution
from service.methods.surface_schema import SurfaceIn
from service.schemas import MeshIn, MethodParams, Progress

#: Domain requests whose size would make more triangles than this are refused (422).
MAX_TRIANGLES = 2_000_000
#: Surface requests whose size would make more tetrahedra than this are refused (422).
MAX_TETRAHEDRA = 200_000


class OptimizeParams(MethodParams):
    """Generate, correct or optimize a simplicial mesh by local sub-topology replacement (§8.3)."""

    mesh: MeshIn | None = Field(
        None,
        description="Triangles ([x, y] points) or tetrahedra ([x, y, z]): a mesh topology, "
        "possibly tangled (inverted cells), to make valid and optimize; its boundary is kept.",
    )
    domain: DomainIn | None = Field(
        None,
        description="Or a planar domain: triangles generated from its boundary discretization "
        "(Figure 8.10), used as given unless keep_boundary is false.",
    )
    surface: SurfaceIn | None = Field(
        None,
        description="Or one closed triangulated surface (one shell): tetrahedra generated from "
        "it (Figure 8.11); its points and triangles are kept.",
    )
    insert_points: bool | None = Field(
        None,
        description="Domain (default true): the second stage adds interior points up to size "
        "and min_angle; false keeps the boundary points only. Surface (default true): points "
        "where the first stage is stuck, then up to size. Mesh (default false): true lets "
        "a fan remove a free vertex where its ball is inverted; false keeps the point set.",
    )
    size: float | None = Field(
        None,
        gt=0,
        allow_inf_nan=False,
        description="Domain or surface input: target edge length (default: the median "
        "boundary segment or surface edge).",
    )
    quality: Literal["shape", "radius_ratio"] = Field(
        "shape",
        description="The measure of (8.2): shape (4√3A/Σl², 12(3V)^(2/3)/Σl²) or "
        "radius_ratio (2r/R, 3r/R), from unsigned areas as the text says.",
    )
    max_sweeps: int = Field(200, ge=1, le=10_000, description="Most passes per stage.")
    keep_boundary: bool = Field(
        True,
        description="True: boundary vertices, edges and faces never move or change. False "
        "(domain input only): the boundary segments are first split evenly to at most size.",
    )
    min_angle: float = Field(
        25.0,
        gt=0,
        le=30,
        allow_inf_nan=False,
        description="Domain input with insertion: triangles below this least angle (degrees) "
        "get a point (their circumcentre or off-centre), except where it would encroach a "
        "boundary segment.",
    )

    @model_validator(mode="after")
    def _one_input(self) -> OptimizeParams:
        if sum(x is not None for x in (self.mesh, self.domain, self.surface)) != 1:
            raise ValueError("give exactly one of mesh, domain or surface")
        if self.mesh is not None and self.size is not None:
            raise ValueError("size goes with domain input, not with mesh")
        if self.domain is None and not self.keep_boundary:
            raise ValueError("keep_boundary=false goes with domain input")
        return self

    def check(self) -> None:
        from meshcore.optimize import check_input

        super().check()
        if self.mesh is not None:
            check_input(self.mesh.to_mesh())
            return
        if self.surface is not None:
            surf = self.surface.to_surface()
            check_input(surface=surf)
            check_resolution(surf.points, self.size, ("size",))
            if self.size is not None and self.insert_points is not False:
                # a regular tetrahedron of edge size has volume size³ / (6 √2)
                estimate = 6.0 * math.sqrt(2.0) * float(surf.volume) / self.size / self.size
                estimate /= self.size
                if estimate > MAX_TETRAHEDRA:
                    raise InputError(
                        f"size {self.size:.6g} would make about {estimate:.3g} tetrahedra in "
                        f"a volume of {surf.volume:.6g}; this service makes at most "
                        f"{MAX_TETRAHEDRA:,} here: ask for a larger size",
                        loc=("size",),
                        code="too_many_tetrahedra",
                    )
            return
        dom = self.domain.to_domain()
        check_input(domain=dom)
        check_resolution(dom.points, self.size, ("size",))
        if self.size is None:
            return
        # with insertion, about two triangles per equilateral triangle of side size in the
        # area; without, the boundary split to size (keep_boundary false) makes them all
        if self.insert_points is not False:
            estimate = 2.0 * dom.area / 0.433 / self.size / self.size
        elif not self.keep_boundary:
            seg = dom.points[dom.segments[:, 1]] - dom.points[dom.segments[:, 0]]
            estimate = float(np.sum(np.ceil(np.hypot(seg[:, 0], seg[:, 1]) / self.size)))
        else:
            return
        if estimate > MAX_TRIANGLES:
            raise InputError(
                f"size {self.size:.6g} would make about {estimate:.3g} triangles on a "
                f"domain of area {dom.area:.6g}; this service makes at most "
                f"{MAX_TRIANGLES:,} here: ask for a larger size",
                loc=("size",),
                code="too_many_triangles",
            )

    def optimize_kwargs(self) -> dict:
        """Keyword arguments of :func:`meshcore.optimize.optimize`."""
        kw: dict = {
            "insert_points": self.insert_points,
            "quality": self.quality,
            "max_sweeps": self.max_sweeps,
            "keep_boundary": self.keep_boundary,
            "min_angle": self.min_angle,
        }
        if self.mesh is not None:
            kw["mesh"] = self.mesh.to_mesh()
        elif self.surface is not None:
            kw.update(surface=self.surface.to_surface(), size=self.size)
        else:
            kw.update(domain=self.domain.to_domain(), size=self.size)
        return kw


def run_optimize(params: OptimizeParams, progress: Progress) -> dict:
    """The valid mesh, its quality report and the run's figures (the Sur series per pass)."""
    from meshcore.optimize import optimize

    res = optimize(**params.optimize_kwargs(), progress=progress)
    return {"mesh": res.mesh, "quality": res.quality, "stats": res.stats}


#: An L-shaped domain meshed from its boundary at size 0.1, boundary split to that size.
OPTIMIZE_EXAMPLE = {
    "domain": {
        "type": "Polygon",
        "coordinates": [[[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2], [0, 0]]],
    },
    "size": 0.1,
    "keep_boundary": False,
}
