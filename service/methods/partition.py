"""Params and run function of ``recursive_partition`` (§8.7.2), and the params shared
with the direct quad method ``paving`` (§8.5.1).

:class:`SizedDomainParams` is a planar domain (holes, no interior
constraints) with ``size`` and/or ``size_field`` (the control space of
Remark 8.10); its :meth:`~SizedDomainParams.check` validates the domain and
the size field and refuses runaway sizes, every error located relative to
the params. The 3D form of the recursive partition (``surface``,
``tetra``) is not offered yet: it waits for the 3D input.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from meshcore.errors import InputError
from meshcore.partition import recursive_partition, size_map
from service.methods.domain_schema import DomainIn
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
        super().check()
        dom = self.domain.to_domain()
        sizes = size_map(dom, self.size, self.field())
        estimate = dom.area / sizes.smallest**2
        if estimate > MAX_CELLS:
            name = "size" if self.size is not None and self.size <= sizes.smallest else "size_field"
            raise InputError(
                f"these sizes would make about {estimate:,.0f} cells on a domain of area "
                f"{dom.area:.6g}; at most {MAX_CELLS:,}",
                loc=(name,),
                code="too_many_cells",
            )


class RecursivePartitionParams(SizedDomainParams):
    """Triangles or quads of a planar domain by recursive partition into two (§8.7.2)."""

    element: Literal["triangle", "quad"] = Field(
        "triangle",
        description="triangle: recursion down to triangles; quad: only even parts, down to "
        "strictly convex quads (Remark 8.9).",
    )
    strategy: Literal["balanced", "angle"] = Field(
        "balanced",
        description="balanced: short separators cutting the polygon into parts of similar "
        "size with good angles; angle: separators from the sharpest reflex vertex first.",
    )
    smooth: bool = Field(
        True,
        description="Quads: smoothing and the topological clean-up (§8.4.3), never inverting "
        "a cell nor lowering the least quality.",
    )


def run_recursive_partition(params: RecursivePartitionParams, progress) -> dict:
    """The mesh, its quality report and the recursion's counts."""
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
