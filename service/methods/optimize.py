"""Params and run function of ``optimize``: Coupez's optimization-based method (§8.3).

The params model refuses, with the field's location, what JSON Schema can
say (choices, ranges, NaN and infinities, exactly one of mesh or domain,
options that go with one input only); its :meth:`check` runs meshcore's
checks before the job is queued: the domain's validation, or the mesh's
shape, cell types and topology (an edge or face in three or more cells, a
neighbour oriented against another, each named by ``loc``).
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from meshcore.errors import InputError
from meshcore.optimize import check_input, optimize
from service.methods.domain_schema import DomainIn
from service.schemas import MeshIn, MethodParams

Progress = object  # the registry's Progress: callable(fraction, message)

#: Domain requests whose size would make more triangles than this are refused (422).
MAX_TRIANGLES = 2_000_000


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
    insert_points: bool | None = Field(
        None,
        description="Domain (default true): the second stage adds interior points up to size "
        "and min_angle; false keeps the boundary points only. Mesh (default false): true lets "
        "a fan remove a free vertex where its ball is inverted; false keeps the point set.",
    )
    size: float | None = Field(
        None,
        gt=0,
        allow_inf_nan=False,
        description="Domain input: target edge length (default: the median boundary segment).",
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
        "get a point while their longest edge exceeds size / 2.",
    )

    @model_validator(mode="after")
    def _one_input(self) -> OptimizeParams:
        if (self.mesh is None) == (self.domain is None):
            raise ValueError("give either mesh or domain")
        if self.mesh is not None and self.size is not None:
            raise ValueError("size goes with domain input, not with mesh")
        if self.mesh is not None and not self.keep_boundary:
            raise ValueError("keep_boundary=false goes with domain input")
        return self

    def check(self) -> None:
        super().check()
        if self.mesh is not None:
            check_input(self.mesh.to_mesh())
            return
        dom = self.domain.to_domain()
        check_input(domain=dom)
        if self.size is not None and self.insert_points is not False:
            estimate = 2.0 * dom.area / (0.433 * self.size**2)
            if estimate > MAX_TRIANGLES:
                raise InputError(
                    f"size {self.size:.6g} would make about {int(estimate):,} triangles on a "
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
        else:
            kw.update(domain=self.domain.to_domain(), size=self.size)
        return kw


def run_optimize(params: OptimizeParams, progress: Progress) -> dict:
    """The valid mesh, its quality report and the run's figures (the Sur series per pass)."""
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
