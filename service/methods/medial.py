"""Params and run functions of the medial-axis methods (§9.4, §9.6, §9.7).

``medial_axis`` computes the axis of a polygon (holes allowed) or of a point
cloud sampling a boundary; ``medial_transform`` rebuilds a boundary from an
axis and its radii; ``partition``, ``quad_medial`` and ``simplify`` are the
applications of §9.7. Each params model refuses, with the field's location,
what JSON Schema can say; its :meth:`check` runs the meshcore checks that
need numpy and raises :class:`~meshcore.errors.InputError` located relative
to the params.

meshcore's method packages are imported in the functions that use them (see
:mod:`service.methods.registry`).
"""

from __future__ import annotations

from typing import Annotated, Literal

import numpy as np
from pydantic import ConfigDict, Field, model_validator

from meshcore.errors import InputError
from meshcore.limits import DEFAULT_PRUNE, DEFAULT_THRESHOLD, MAX_QUADS
from service.methods.domain_schema import DomainIn, Position, check_resolution
from service.schemas import InputModel, MethodParams

PositiveFloat = Annotated[float, Field(gt=0, allow_inf_nan=False)]
NonNegativeFloat = Annotated[float, Field(ge=0, allow_inf_nan=False)]


StepField = Field(
    None,
    gt=0,
    allow_inf_nan=False,
    description="Boundary sampling step. Default: half the smallest distance between "
    "non-consecutive boundary vertices (§9.4.1), bounded so the job stays fast.",
)
PruneField = Field(
    DEFAULT_PRUNE,
    ge=0,
    le=180,
    allow_inf_nan=False,
    description="Degrees: terminal branches whose boundary feature subtends less than this "
    "angle at the junction they leave are removed, least significant first (the spurious "
    "branches of a discretized boundary, Remarks 9.10-9.13); a corner of interior angle A "
    "makes a branch of 180 - A. 0 keeps every branch.",
)


def _domain_geometry(domain: DomainIn) -> dict:
    return domain.geometry()


# ---------------------------------------------------------------------------
# medial_axis (§9.4.1, §9.4.2)
# ---------------------------------------------------------------------------


class MedialAxisParams(MethodParams):
    """The medial axis of a polygon or of a point cloud sampling a boundary."""

    domain: DomainIn | None = Field(None, description="A polygon, holes allowed (§9.4.1).")
    points: list[Position] | None = Field(
        None,
        description="Or: a point cloud sampling one or more closed boundary curves densely "
        "(§9.4.2); the curves are reconstructed from the samples, which are used as given.",
    )
    h: float | None = StepField
    prune: float = PruneField
    approximation: Literal["voronoi", "midpoints"] = Field(
        "voronoi",
        description="voronoi: circumcentres joined across interior edges (Theorem 9.1); "
        "midpoints: midpoints of interior edges, Type 0 nodes at centroids (Remark 9.14).",
    )

    @model_validator(mode="after")
    def _one_input(self) -> MedialAxisParams:
        if (self.domain is None) == (self.points is None):
            raise ValueError("give exactly one of domain and points")
        return self

    def point_count(self) -> int:
        return self.domain.point_count() if self.domain is not None else len(self.points)

    def check(self) -> None:
        super().check()
        if self.domain is not None:
            self.domain.to_domain()
        else:
            from meshcore.medial.axis import cloud_points

            cloud_points(self.points)


def run_medial_axis(params: MedialAxisParams, progress) -> dict:
    """The axis (nodes, radii, edges, kinds, branches), as a line mesh too, the domain
    (for a point cloud: the one reconstructed from it) and counts."""
    from meshcore.medial.axis import medial_axis

    cloud = params.domain is None
    axis = medial_axis(
        None if cloud else params.domain.to_domain(),
        points=np.asarray(params.points, dtype=float) if cloud else None,
        h=params.h,
        prune=params.prune,
        approximation=params.approximation,
        progress=progress,
    )
    # for a point cloud: the curves reconstructed from it
    domain = axis.domain.as_geojson() if cloud else _domain_geometry(params.domain)
    return {"axis": axis.to_json(), "mesh": axis.to_mesh(), "domain": domain, "stats": axis.stats}


#: The rectangle 2 x 1 of the tests: one segment and four corner branches.
MEDIAL_AXIS_EXAMPLE = {
    "domain": {"type": "Polygon", "coordinates": [[[0, 0], [2, 0], [2, 1], [0, 1], [0, 0]]]}
}


# ---------------------------------------------------------------------------
# medial_transform (§9.6)
# ---------------------------------------------------------------------------


class AxisIn(InputModel):
    """A medial axis: nodes, their radii and the edges joining them (a previous result's
    ``axis``; ``kind`` and ``branches`` may be present and are not used)."""

    model_config = ConfigDict(extra="ignore")

    nodes: list[Position] = Field(min_length=1)
    radius: list[NonNegativeFloat] = Field(min_length=1)
    edges: list[Annotated[list[Annotated[int, Field(ge=0)]], Field(min_length=2, max_length=2)]]

    def point_count(self) -> int:
        return len(self.nodes)


class MedialTransformParams(MethodParams):
    """The domain rebuilt from its medial axis and radii."""

    axis: AxisIn
    domain: DomainIn | None = Field(
        None, description="The original domain: the Hausdorff distance to it is reported."
    )
    h: float | None = Field(
        None,
        gt=0,
        allow_inf_nan=False,
        description="Accuracy of the rebuilt boundary (circles are sampled to within it).",
    )

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return (
            np.asarray(self.axis.nodes, dtype=float),
            np.asarray(self.axis.radius, dtype=float),
            np.asarray(self.axis.edges, dtype=np.int64).reshape(-1, 2),
        )

    def check(self) -> None:
        from meshcore.medial.transform import checked_axis

        super().check()
        boundary = None if self.domain is None else self.domain.to_domain()
        try:
            checked_axis(*self.arrays(), boundary, self.h)
        except InputError as exc:
            if exc.errors[0]["loc"][:1] in (["nodes"], ["radius"], ["edges"]):
                raise exc.prefixed("axis") from None
            raise


def run_medial_transform(params: MedialTransformParams, progress) -> dict:
    """The rebuilt domain, its area and the Hausdorff distance to the original."""
    from meshcore.medial.transform import medial_transform

    boundary = None if params.domain is None else params.domain.to_domain()
    res = medial_transform(*params.arrays(), boundary=boundary, h=params.h, progress=progress)
    return {
        "domain": res.domain,
        "stats": {**res.stats, "hausdorff": res.hausdorff, "area": res.area, "h": res.h},
    }


MEDIAL_TRANSFORM_EXAMPLE = {
    "axis": {
        "nodes": [[0.5, 0.5], [1.5, 0.5], [0, 0], [0, 1], [2, 0], [2, 1]],
        "radius": [0.5, 0.5, 0, 0, 0, 0],
        "edges": [[0, 1], [0, 2], [0, 3], [1, 4], [1, 5]],
    },
    "domain": MEDIAL_AXIS_EXAMPLE["domain"],
}


# ---------------------------------------------------------------------------
# partition (§9.7.1) and quad_medial (§9.7.2, §8.5.3)
# ---------------------------------------------------------------------------


class PartitionParams(MethodParams):
    """Regions of a domain along cut lines of its medial axis."""

    domain: DomainIn
    method: Literal["critical", "terminal"] = Field(
        "critical",
        description="critical: each Type 0 node joined to its triangle's vertices, consecutive "
        "Type 0 nodes joined along the axis (triangles and quads); terminal: the axis paths "
        "between Type 2 terminals (3 to 6 sides).",
    )
    h: float | None = StepField
    prune: float = PruneField

    def check(self) -> None:
        super().check()
        self.domain.to_domain()


def run_partition(params: PartitionParams, progress) -> dict:
    """The regions (GeoJSON Polygons with their side counts), the cut lines and the axis."""
    from meshcore.medial.partitioning import partition

    part = partition(
        params.domain.to_domain(),
        method=params.method,
        h=params.h,
        prune=params.prune,
        progress=progress,
    )
    return {
        "regions": part.regions,
        "axis": part.axis.to_json(),
        "domain": _domain_geometry(params.domain),
        "stats": {**part.stats, "cuts": part.cuts.tolist()},
    }


PARTITION_EXAMPLE = {
    "domain": {
        "type": "Polygon",
        "coordinates": [[[0, 0], [3, 0], [3, 1], [2, 1], [2, 3], [1, 3], [1, 1], [0, 1], [0, 0]]],
    }
}


class QuadMedialParams(PartitionParams):
    """An all-quad mesh on the medial-axis partition."""

    size: float | None = Field(
        None,
        gt=0,
        allow_inf_nan=False,
        description="Target edge length of the transfinite fill (excludes levels).",
    )
    levels: int | None = Field(
        None,
        ge=0,
        le=10,
        description="Midpoint subdivisions after the first (excludes size). Default: 2.",
    )

    @model_validator(mode="after")
    def _size_or_levels(self) -> QuadMedialParams:
        if self.size is not None and self.levels is not None:
            raise ValueError("give size or levels, not both")
        return self

    def check(self) -> None:
        super().check()
        dom = self.domain.to_domain()
        check_resolution(dom.points, self.size, ("size",))
        if self.size is not None:
            estimate = dom.area / self.size / self.size  # not size**2: it overflows
            if estimate > MAX_QUADS:
                raise InputError(
                    f"size {self.size:g} would make about {estimate:,.0f} quads on a domain of "
                    f"area {dom.area:.6g}; at most {MAX_QUADS:,}",
                    loc=("size",),
                    code="too_many_quads",
                )


def run_quad_medial(params: QuadMedialParams, progress) -> dict:
    """The quad mesh, its quality report, the regions and the counts."""
    from meshcore.medial.partitioning import quad_medial

    res = quad_medial(
        params.domain.to_domain(),
        method=params.method,
        size=params.size,
        levels=params.levels,
        h=params.h,
        prune=params.prune,
        progress=progress,
    )
    stats = {k: v for k, v in res.stats.items() if k != "quality"}
    return {
        "mesh": res.mesh,
        "quality": res.stats["quality"],
        "regions": res.partition.regions,
        "stats": stats,
    }


QUAD_MEDIAL_EXAMPLE = {**PARTITION_EXAMPLE, "size": 0.1}


# ---------------------------------------------------------------------------
# simplify (§9.7.4)
# ---------------------------------------------------------------------------


class SimplifyParams(MethodParams):
    """The domain without the holes and details small against the local axis radius."""

    domain: DomainIn
    threshold: float = Field(
        DEFAULT_THRESHOLD,
        ge=0,
        allow_inf_nan=False,
        description="Features whose size over the local radius of the axis is under this are "
        "removed; 0 removes nothing.",
    )
    h: float | None = StepField

    def check(self) -> None:
        super().check()
        self.domain.to_domain()


def run_simplify(params: SimplifyParams, progress) -> dict:
    """The simplified domain and the removed features with their sizes."""
    from meshcore.medial.simplification import simplify

    res = simplify(
        params.domain.to_domain(), threshold=params.threshold, h=params.h, progress=progress
    )
    return {"domain": res.domain, "stats": {**res.stats, "removed": res.removed}}


SIMPLIFY_EXAMPLE = {
    "domain": {
        "type": "Polygon",
        "coordinates": [
            [[0, 0], [4, 0], [4, 1.9], [2.1, 1.9], [2.1, 2], [0, 2], [0, 0]],
            [[1, 1], [1.05, 1], [1.05, 1.05], [1, 1.05], [1, 1]],
        ],
    }
}
