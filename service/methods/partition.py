"""Params and run function of ``recursive_partition`` (§8.7.2), and the params shared
with the direct quad method ``paving`` (§8.5.1).

:class:`SizedDomainParams` is a planar domain (holes, no interior
constraints) with ``size`` and/or ``size_field`` (the control space of
Remark 8.10); its :meth:`~SizedDomainParams.check` validates the domain and
the size field and refuses runaway sizes, every error located relative to
the params. :class:`RecursivePartitionParams` takes a ``surface``
instead of the ``domain`` for the 3D form (``tetra``).

meshcore's method packages are imported in the functions that use them (see
:mod:`service.methods.registry`).
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from meshcore.errors import InputError
from service.methods.domain_schema import DomainIn, check_resolution
from service.methods.surface_schema import UNIT_CUBE, SurfaceIn
from service.methods.triangulation import SizeField
from service.schemas import MethodParams

#: Requests whose sizes would make more cells than this are refused (422).
MAX_CELLS = 4_000_000


class SizedDomainParams(MethodParams):
    """A planar domain and the sizes to mesh it at."""

    domain: DomainIn
    size: float | None = Field(None, gt=0, allow_inf_nan=False, description="Target edge length.")
    size_field: SizeField | None = Field(
        None,
        description="Target edge lengths at scattered points (Remark 8.10), inverse squared "
        "distance to the 4 nearest; size bounds it.",
    )

    @model_validator(mode="after")
    def _some_size(self) -> SizedDomainParams:
        if self.size is None and self.size_field is None:
            raise ValueError("give size or size_field")
        return self

    def field(self) -> dict | None:
        return None if self.size_field is None else self.size_field.model_dump()

    def check(self) -> None:
        from meshcore.partition import size_map

        super().check()
        dom = self.domain.to_domain()
        sizes = size_map(dom, self.size, self.field())
        estimate = dom.area / sizes.smallest / sizes.smallest  # not **2: it overflows
        name = "size" if self.size is not None and self.size <= sizes.smallest else "size_field"
        if estimate > MAX_CELLS:
            raise InputError(
                f"these sizes would make about {estimate:,.0f} cells on a domain of area "
                f"{dom.area:.6g}; at most {MAX_CELLS:,}",
                loc=(name,),
                code="too_many_cells",
            )
        check_resolution(dom.points, sizes.smallest, (name,))


class RecursivePartitionParams(SizedDomainParams):
    """Triangles or quads of a planar domain, or tetrahedra of a closed surface, by recursive
    partition into two (§8.7.2)."""

    domain: DomainIn | None = Field(
        None, description="2D: a GeoJSON Polygon or MultiPolygon (holes, no interior segments)."
    )
    surface: SurfaceIn | None = Field(
        None,
        description="3D, instead of domain: a closed surface (bodies, no cavity); every input "
        "triangle stays a face, so give one sampled at about the size.",
    )
    element: Literal["triangle", "quad", "tetra"] | None = Field(
        None,
        description="triangle (the 2D default): recursion down to triangles; quad: only even "
        "parts, down to strictly convex quads (Remark 8.9); tetra (the 3D default, with a "
        "surface).",
    )
    strategy: Literal["balanced", "angle"] = Field(
        "balanced",
        description="balanced: short separators cutting the part into halves of similar "
        "size with good angles (3D: planes across the longest extent); angle: separators "
        "from the sharpest reflex vertex first (3D: the face planes at the most reflex edges).",
    )
    smooth: bool = Field(
        True,
        description="Quads: smoothing, the topological clean-up (§8.4.3) and the corners "
        "squared, never inverting a cell nor lowering the least quality.",
    )

    @model_validator(mode="after")
    def _one_input(self) -> RecursivePartitionParams:
        if (self.domain is None) == (self.surface is None):
            raise ValueError("give a domain (2D) or a surface (3D), not both")
        return self

    def check(self) -> None:
        if self.surface is None:
            if self.element == "tetra":
                raise InputError(
                    "element tetra needs a surface", loc=("element",), code="bad_parameter"
                )
            super().check()
            return
        MethodParams.check(self)
        if self.element not in (None, "tetra"):
            raise InputError(
                f"element must be tetra with a surface, got {self.element}",
                loc=("element",),
                code="bad_parameter",
            )
        if self.size_field is not None:
            raise InputError(
                "size_field is planar; with a surface give size",
                loc=("size_field",),
                code="unsupported",
            )
        surface = self.surface.to_surface()
        estimate = 6.0 * surface.volume / self.size / self.size / self.size
        if estimate > MAX_CELLS:
            raise InputError(
                f"this size would make about {estimate:,.0f} tetrahedra in a volume of "
                f"{surface.volume:.6g}; at most {MAX_CELLS:,}",
                loc=("size",),
                code="too_many_cells",
            )
        check_resolution(surface.points, self.size, ("size",))


def run_recursive_partition(params: RecursivePartitionParams, progress) -> dict:
    """The mesh, its quality report and the recursion's counts."""
    from meshcore.partition import recursive_partition

    if params.surface is not None:
        res = recursive_partition(
            surface=params.surface.to_surface(),
            size=params.size,
            strategy=params.strategy,
            progress=progress,
        )
        return {"mesh": res.mesh, "quality": res.quality, "stats": res.stats}
    res = recursive_partition(
        params.domain.to_domain(),
        size=params.size,
        size_field=params.field(),
        element=params.element,
        strategy=params.strategy,
        smooth=params.smooth,
        progress=progress,
    )
    return {"mesh": res.mesh, "quality": res.quality, "stats": res.stats}


#: The unit square with a round hole, triangles of side 0.05.
RECURSIVE_PARTITION_EXAMPLE = {
    "domain": {
        "type": "Polygon",
        "coordinates": [
            [[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]],
            [[0.75, 0.5], [0.5, 0.75], [0.25, 0.5], [0.5, 0.25], [0.75, 0.5]],
        ],
    },
    "size": 0.05,
    "element": "triangle",
}

#: The unit cube of 12 triangles: six tetrahedra, no point added.
RECURSIVE_PARTITION_3D_EXAMPLE = {"surface": UNIT_CUBE, "size": 0.5, "element": "tetra"}
