"""Params and run functions of ``quad_combine`` (triangle combination, §8.4) and
``paving`` (rows of quads from the boundary inward, §8.5.1).

The params model refuses, with the field's location, what JSON Schema can
say (choices, ranges, shapes, NaN and infinities, mesh or domain but not
both); its :meth:`check` runs meshcore's checks before the job is queued: the
mesh's topology and orientation (non-triangle blocks, indices out of range,
inverted, flat, non-manifold or inconsistently oriented triangles, each
named by ``loc``), the metric (symmetric positive definite, one per point
when given per point), and for domain input the triangulation's own checks
(the domain, the size field, runaway sizes).

meshcore's method packages are imported in the functions that use them (see
:mod:`service.methods.registry`).
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, model_validator

from service.methods.domain_schema import ConstraintPolylines, DomainIn
from service.methods.partition import SizedDomainParams
from service.methods.triangulation import (
    MAX_MIN_ANGLE,
    SizeField,
    TriangulateParams,
)
from service.schemas import FiniteFloat, MeshIn, MethodParams, Progress

MetricRow = Annotated[list[FiniteFloat], Field(min_length=2, max_length=3)]
Metric = Annotated[list[MetricRow], Field(min_length=2, max_length=3)]


class QuadCombineParams(MethodParams):
    """Quads by combining the triangles of a mesh, or of a domain meshed first (§8.4)."""

    mesh: MeshIn | None = Field(
        None,
        description="A triangle mesh: planar ([x, y], counter-clockwise) or a surface "
        "([x, y, z], consistently oriented, §8.4.5).",
    )
    domain: DomainIn | None = Field(
        None, description="Or a planar domain, triangulated first (method triangulate)."
    )
    segments: ConstraintPolylines | None = None
    size: float | None = Field(
        None, gt=0, allow_inf_nan=False, description="Domain input: target edge length."
    )
    size_field: SizeField | None = Field(
        None, description="Domain input: target edge lengths at scattered points."
    )
    min_angle: float | None = Field(
        None,
        gt=0,
        le=MAX_MIN_ANGLE,
        allow_inf_nan=False,
        description="Domain input: smallest triangle angle (degrees, default 20).",
    )
    keep_boundary: bool = Field(
        False, description="Domain input: add no point on the input segments."
    )
    pattern: Literal["squares", "equilateral"] = Field(
        "squares",
        description="Domain input: lay the triangles so that pairs make near-squares (the "
        "triangulator's lattice in a sheared frame), or its equilateral lattice.",
    )
    algorithm: Literal["stack", "heap", "frontal", "matching"] = Field(
        "matching",
        description="stack: the path of §8.4.2; heap: best quality first (§8.4.4); frontal: "
        "from the boundary inward (Remark 8.8); matching: heap then augmenting paths, the "
        "fewest triangles left.",
    )
    quality: Literal["angle", "simplified", "shape"] = Field(
        "angle",
        description="Quad measure weighting the pairs: (8.3)/(8.4), (8.7) or (8.8).",
    )
    metric: Metric | list[Metric] | None = Field(
        None,
        description="A constant SPD matrix (d x d), or one per mesh point: angles measured in "
        "the metric, (8.5)-(8.7). Domain input: constant only.",
    )
    min_quality: float = Field(
        0.0, ge=0, le=1, allow_inf_nan=False, description="Pairs forming worse quads stay apart."
    )
    all_quad: bool = Field(
        False,
        description="Split quads into four and leftover triangles into three: only quads, "
        "conforming (Figure 8.13).",
    )
    twice_size: bool = Field(
        False,
        description="Domain input with all_quad: mesh at twice size first, so the final quads "
        "have the size asked for (§8.4.2).",
    )
    optimize: bool = Field(
        False,
        description="Apply the operators of §8.4.3 and smoothing that never inverts a cell, "
        "each change kept only when quality improves; counts in stats.operators.",
    )

    @model_validator(mode="after")
    def _one_input(self) -> QuadCombineParams:
        if (self.mesh is None) == (self.domain is None):
            raise ValueError("give either mesh or domain")
        if self.mesh is not None:
            for name in ("segments", "size", "size_field", "min_angle"):
                if getattr(self, name) is not None:
                    raise ValueError(f"{name} goes with domain input, not with mesh")
        if self.twice_size and (self.domain is None or not self.all_quad):
            raise ValueError("twice_size needs domain input and all_quad=true")
        return self

    def _triangulation(self) -> TriangulateParams:
        size = self.size
        if self.twice_size and size is not None:
            size = 2.0 * size
        return TriangulateParams(
            domain=self.domain,
            segments=self.segments,
            size=size,
            size_field=self.size_field,
            min_angle=self.min_angle,
            keep_boundary=self.keep_boundary,
        )

    def check(self) -> None:
        from meshcore.quads import combination

        super().check()
        if self.mesh is not None:
            combination.check_input(self.mesh.to_mesh(), self.metric)
        else:
            self._triangulation().check()
            combination.check_thinness(self.domain.to_domain(self.segments))
            if self.metric is not None:
                combination.check_metric_2d(self.metric)

    def combine_kwargs(self) -> dict:
        """Keyword arguments of :func:`meshcore.quads.combination.combine`."""
        kw: dict = {
            "algorithm": self.algorithm,
            "measure": self.quality,
            "metric": self.metric,
            "min_quality": self.min_quality,
            "all_quad": self.all_quad,
            "twice_size": self.twice_size,
            "optimize": self.optimize,
        }
        if self.mesh is not None:
            kw["mesh"] = self.mesh.to_mesh()
        else:
            kw.update(
                domain=self.domain.to_domain(self.segments),
                size=self.size,
                size_field=None if self.size_field is None else self.size_field.model_dump(),
                min_angle=self.min_angle,
                keep_boundary=self.keep_boundary,
                pattern=self.pattern,
            )
        return kw


def run_quad_combine(params: QuadCombineParams, progress: Progress) -> dict:
    """The quad mesh, its quality report (after optimization) and the counts."""
    from meshcore.quads import combination

    res = combination.combine(**params.combine_kwargs(), progress=progress)
    stats = {
        "quads": int(sum(len(b) for b in res.mesh.cells if b.type == "quad")),
        "triangles": int(sum(len(b) for b in res.mesh.cells if b.type == "triangle")),
        "triangles_left": res.triangles_left,
        "pairs": res.pairs,
        "triples": res.triples,
        "points": len(res.mesh.points),
        "operators": res.operators,
        "quality_before": res.quality_before,
        **res.stats,
    }
    return {"mesh": res.mesh, "quality": res.quality_after, "stats": stats}


def _circle(cx: float, cy: float, r: float, n: int) -> list[list[float]]:
    import math

    return [
        [
            round(cx + r * math.cos(2 * math.pi * k / n), 9),
            round(cy + r * math.sin(2 * math.pi * k / n), 9),
        ]
        for k in range(n)
    ]


#: A unit square with a round hole, quads of side 0.05, only quads, optimized.
QUAD_COMBINE_EXAMPLE = {
    "domain": {
        "type": "Polygon",
        "coordinates": [[[0, 0], [1, 0], [1, 1], [0, 1], [0, 0]], _circle(0.5, 0.5, 0.25, 32)],
    },
    "size": 0.05,
    "algorithm": "matching",
    "all_quad": True,
    "twice_size": True,
    "optimize": True,
}


class PavingParams(SizedDomainParams):
    """An all-quad mesh by paving: rows of quads from the boundary inward (§8.5.1)."""

    smooth: bool = Field(
        True,
        description="Length-weighted Laplacian smoothing with the boundary angle correction, "
        "then the topological clean-up (§8.4.3) where quads are poor or valences irregular, "
        "then the corners squared (steepest descent on their skew); "
        "never inverting a cell nor lowering the least quality.",
    )
    max_rows: int | None = Field(
        None, ge=0, le=100_000, description="Rows per front at most (default: until frozen)."
    )


def run_paving(params: PavingParams, progress: Progress) -> dict:
    """The quad mesh, its quality report, rows, seams, closures and valences."""
    from meshcore.quads import paving

    res = paving(
        params.domain.to_domain(),
        size=params.size,
        size_field=params.field(),
        smooth=params.smooth,
        max_rows=params.max_rows,
        progress=progress,
    )
    return {"mesh": res.mesh, "quality": res.quality, "stats": res.stats}


#: The unit square with a round hole, quads of side 0.05.
PAVING_EXAMPLE = {
    "domain": QUAD_COMBINE_EXAMPLE["domain"],
    "size": 0.05,
}
