"""Params and run functions of the product methods: extrude, sweep, merge, radial.

Each params model refuses, with the field's location, what JSON Schema can
say (shapes, signs, NaN and infinities, zero axes and vectors, zero layers);
its :meth:`check` runs meshcore's own input checks (row counts against the
mesh, cell types, boundary sizes), which need numpy, and raises
:class:`~meshcore.errors.InputError` located relative to the params.

``extrude`` takes its base as ``mesh`` today; ``domain`` plus ``size``
(meshed by ``triangulate`` first) will join it as an alternative field.

meshcore's method packages are imported in the functions that use them (see
:mod:`service.methods.registry`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated, Literal

import numpy as np
from pydantic import ConfigDict, Field, field_validator, model_validator

from meshcore.errors import InputError
from meshcore.mesh import Mesh, quality
from service.methods.domain_schema import DomainIn
from service.methods.triangulation import TriangulateParams, run_triangulate
from service.schemas import FiniteFloat, InputModel, MeshIn, MethodParams, Progress

if TYPE_CHECKING:
    from meshcore.product import extrusion


Vec3 = Annotated[list[FiniteFloat], Field(min_length=3, max_length=3)]
Vec2 = Annotated[list[FiniteFloat], Field(min_length=2, max_length=2)]
Row4 = Annotated[list[FiniteFloat], Field(min_length=4, max_length=4)]
Matrix4 = Annotated[list[Row4], Field(min_length=4, max_length=4)]
Layers = Annotated[int, Field(ge=1, le=100_000, description="Layers of cells (sections - 1).")]
Degrees = Annotated[float, Field(allow_inf_nan=False, ge=-3600, le=3600)]


def _nonzero(v: list[float], what: str) -> list[float]:
    if not any(v):
        raise ValueError(f"{what} must not be zero")
    return v


class _Path(InputModel):
    model_config = ConfigDict(extra="forbid")


class TranslatePath(_Path):
    """Translation by ``vector``, in ``layers`` equal steps or in ``steps`` (§8.1.2)."""

    type: Literal["translate"]
    vector: Vec3 = Field(description="The whole translation [dx, dy, dz]; not zero.")
    layers: Layers | None = None
    steps: list[Annotated[float, Field(gt=0, allow_inf_nan=False)]] | None = Field(
        None,
        min_length=1,
        max_length=100_000,
        description="Positive relative step sizes, one per layer (variable stepsize); "
        "normalized so that they add up to vector.",
    )

    @field_validator("vector")
    @classmethod
    def _vector(cls, v: list[float]) -> list[float]:
        return _nonzero(v, "vector")

    @model_validator(mode="after")
    def _one_of(self) -> TranslatePath:
        if (self.layers is None) == (self.steps is None):
            raise ValueError("give either layers or steps")
        return self

    def to_path(self) -> extrusion.Path:
        from meshcore.product import extrusion

        steps = None if self.steps is None else tuple(self.steps)
        return extrusion.Translate(self.vector, layers=self.layers, steps=steps)


class RotatePath(_Path):
    """Rotation by ``angle`` degrees about an axis (right-hand rule); 360 closes the ring."""

    type: Literal["rotate"]
    axis_point: Vec3
    axis_direction: Vec3 = Field(description="Not zero.")
    angle: Degrees = Field(description="Degrees, not zero; 360 closes the ring.")
    layers: Layers

    @field_validator("axis_direction")
    @classmethod
    def _axis(cls, v: list[float]) -> list[float]:
        return _nonzero(v, "axis_direction")

    @field_validator("angle")
    @classmethod
    def _angle(cls, v: float) -> float:
        return _nonzero([v], "angle")[0]

    def to_path(self) -> extrusion.Path:
        from meshcore.product import extrusion

        return extrusion.Rotate(self.axis_point, self.axis_direction, self.angle, self.layers)


class HelixPath(_Path):
    """A rotation and a translation together (Figure 8.5, left)."""

    type: Literal["helix"]
    axis_point: Vec3
    axis_direction: Vec3 = Field(description="Not zero.")
    angle: Degrees = Field(description="Degrees, not zero.")
    vector: Vec3 = Field(description="The whole translation; along the axis for a helix.")
    layers: Layers

    @field_validator("axis_direction")
    @classmethod
    def _axis(cls, v: list[float]) -> list[float]:
        return _nonzero(v, "axis_direction")

    @field_validator("angle")
    @classmethod
    def _angle(cls, v: float) -> float:
        return _nonzero([v], "angle")[0]

    def to_path(self) -> extrusion.Path:
        from meshcore.product import extrusion

        return extrusion.Helix(
            self.axis_point, self.axis_direction, self.angle, self.vector, self.layers
        )


class TransformsPath(_Path):
    """One 4x4 affine matrix per section, the first one included (§8.1.2)."""

    type: Literal["transforms"]
    matrices: list[Matrix4] = Field(
        min_length=2, max_length=100_001, description="Last row [0, 0, 0, 1]."
    )

    @field_validator("matrices")
    @classmethod
    def _affine(cls, m: list[list[list[float]]]) -> list[list[list[float]]]:
        for k, mk in enumerate(m):
            if mk[3] != [0.0, 0.0, 0.0, 1.0]:
                raise ValueError(f"matrix {k} is not affine: its last row must be [0, 0, 0, 1]")
        return m

    def to_path(self) -> extrusion.Path:
        from meshcore.product import extrusion

        return extrusion.Transforms(np.asarray(self.matrices, dtype=np.float64))


class SectionsPath(_Path):
    """The position of every base vertex on every section, the first one included."""

    type: Literal["sections"]
    points: list[Annotated[list[Vec3], Field(min_length=1)]] = Field(
        min_length=2, description="One list of [x, y, z] per section, as many as the base's points."
    )

    def point_count(self) -> int:
        return sum(len(s) for s in self.points)

    @model_validator(mode="after")
    def _rectangular(self) -> SectionsPath:
        n = len(self.points[0])
        for k, s in enumerate(self.points):
            if len(s) != n:
                raise ValueError(f"section {k} places {len(s)} points, section 0 places {n}")
        return self

    def to_path(self) -> extrusion.Path:
        from meshcore.product import extrusion

        return extrusion.Sections(np.asarray(self.points, dtype=np.float64))


Path = Annotated[
    TranslatePath | RotatePath | HelixPath | TransformsPath | SectionsPath,
    Field(discriminator="type"),
]


class _ProductOptions(MethodParams):
    model_config = ConfigDict(extra="forbid", validate_by_name=True, serialize_by_alias=True)

    simplices: bool = Field(False, description="Split into triangles and tetrahedra (conforming).")
    on_degenerate: Literal["error", "drop"] = Field(
        "error", description="A base cell whose product has no admissible cell: fail or drop it."
    )
    validate_: bool = Field(
        True,
        alias="validate",
        description="Check every cell's signed volume and the self-overlap of the swept solid "
        "(§8.1.3); invalid output fails the job naming the cells.",
    )


class ExtrudeParams(_ProductOptions):
    """Extrude a base mesh, or a planar domain meshed first, along a path (§8.1.1-§8.1.3)."""

    mesh: MeshIn | None = Field(
        None,
        description="The base: vertex, line, triangle and quad cells; 2D points lie at z = 0.",
    )
    domain: DomainIn | None = Field(
        None, description="Or a planar domain, triangulated at `size` (method triangulate)."
    )
    size: float | None = Field(
        None, gt=0, allow_inf_nan=False, description="Target edge length of the base (domain)."
    )
    path: Path

    @model_validator(mode="after")
    def _one_base(self) -> ExtrudeParams:
        if (self.mesh is None) == (self.domain is None):
            raise ValueError("give the base as either mesh or domain (with size)")
        if (self.domain is None) != (self.size is None):
            raise ValueError("size goes with domain, and domain needs size")
        return self

    def _triangulation(self) -> TriangulateParams:
        return TriangulateParams(domain=self.domain, size=self.size)

    def check(self) -> None:
        from meshcore.product import extrusion

        super().check()
        if self.mesh is not None:
            extrusion.check_extrude(self.mesh.to_mesh(), self.path.to_path())
        else:
            self._triangulation().check()

    def base(self, progress: Progress) -> Mesh:
        """The base mesh: the given one, or the domain triangulated at ``size``."""
        if self.mesh is not None:
            return self.mesh.to_mesh()
        return run_triangulate(self._triangulation(), progress)["mesh"]


class SweepParams(_ProductOptions):
    """Sweep a source section to a target section (§8.1.2, the semi-automatic method)."""

    source: MeshIn = Field(description="Triangles and quads of the first section.")
    target: list[Vec3] = Field(
        min_length=1,
        description="All source vertices placed on the last section, or only its boundary "
        "vertices (in increasing index order); then the interior is computed.",
    )
    sides: list[list[Vec3]] | None = Field(
        None,
        description="The boundary vertices (increasing index order) on each intermediate "
        "section; layers = len(sides) + 1.",
    )
    layers: Layers | None = Field(None, description="Layers of cells, when sides are not given.")

    @model_validator(mode="after")
    def _layers_or_sides(self) -> SweepParams:
        if self.sides is None and self.layers is None:
            raise ValueError("give layers or sides")
        return self

    def point_count(self) -> int:
        return len(self.source.points) + len(self.target) + sum(map(len, self.sides or []))

    def check(self) -> None:
        from meshcore.product import extrusion

        super().check()
        extrusion.check_sweep(self.source.to_mesh(), self.target, self.sides, self.layers)


class MergeParams(MethodParams):
    """Merge meshes along shared interfaces (Figure 8.5, right)."""

    # "meshes" on the wire; another name in Python, where MethodParams.meshes() is taken
    model_config = ConfigDict(extra="forbid", validate_by_name=True, serialize_by_alias=True)

    inputs: list[MeshIn] = Field(alias="meshes", min_length=1, max_length=1000)
    tolerance: Annotated[float, Field(ge=0, allow_inf_nan=False)] | None = Field(
        None,
        description="Points closer than this are one point; by default 1e-9 times the "
        "diameter of all points.",
    )

    def check(self) -> None:
        for i, m in enumerate(self.inputs):
            try:
                m.to_mesh()
            except InputError as exc:
                raise exc.prefixed("meshes", i) from None


class RadialParams(MethodParams):
    """A radial mesh of a disk, ring or sector (§8.7.1)."""

    center: Vec2 = Field([0.0, 0.0])
    inner_radius: Annotated[float, Field(ge=0, allow_inf_nan=False)] = Field(
        0.0, description="0 for a full disk."
    )
    outer_radius: Annotated[float, Field(gt=0, allow_inf_nan=False)]
    angle: Annotated[float, Field(gt=0, le=360, allow_inf_nan=False)] = Field(
        360.0, description="Degrees; 360 for a full ring."
    )
    radial_layers: Annotated[int, Field(ge=1, le=10_000)]
    segments: Annotated[int, Field(ge=1, le=1_000_000, description="Edges on the outer ring.")]
    balance: bool = Field(
        False, description="Collapse ring edges so that cell sizes stay balanced (Figure 8.16)."
    )

    @field_validator("outer_radius")
    @classmethod
    def _outside(cls, v: float, info) -> float:
        inner = info.data.get("inner_radius")
        if inner is not None and v <= inner:
            raise ValueError(f"outer_radius must exceed inner_radius ({inner})")
        return v

    @field_validator("segments")
    @classmethod
    def _ring(cls, v: int, info) -> int:
        if info.data.get("angle") == 360 and v < 3:
            raise ValueError("a full ring needs at least 3 segments")
        return v

    def point_count(self) -> int:
        return (self.radial_layers + 1) * (self.segments + 1)


# ----------------------------------------------------------------------------- run functions


def _scaled(progress: Progress, lo: float, hi: float) -> Progress:
    def inner(fraction: float, message: str) -> None:
        progress(lo + (hi - lo) * fraction, message)

    return inner


def _product_result(res: extrusion.ProductResult, progress: Progress) -> dict:
    stats = res.stats()
    if res.boundary_vertices is not None:
        stats["boundary_vertices"] = res.boundary_vertices
    return {
        "mesh": res.mesh,
        "quality": quality.report(res.mesh, progress=_scaled(progress, 0.8, 1.0)),
        "stats": stats,
    }


def run_extrude(params: ExtrudeParams, progress: Progress) -> dict:
    """The product mesh of the base and the path."""
    from meshcore.product import extrusion

    res = extrusion.extrude(
        params.base(_scaled(progress, 0.0, 0.2)),
        params.path.to_path(),
        simplices=params.simplices,
        on_degenerate=params.on_degenerate,
        validate=params.validate_,
        progress=_scaled(progress, 0.2, 0.8),
    )
    return _product_result(res, progress)


def run_sweep(params: SweepParams, progress: Progress) -> dict:
    """The swept mesh between source and target."""
    from meshcore.product import extrusion

    res = extrusion.sweep(
        params.source.to_mesh(),
        params.target,
        sides=params.sides,
        layers=params.layers,
        simplices=params.simplices,
        on_degenerate=params.on_degenerate,
        validate=params.validate_,
        progress=_scaled(progress, 0.0, 0.8),
    )
    return _product_result(res, progress)


def run_merge(params: MergeParams, progress: Progress) -> dict:
    """One conforming mesh from several."""
    from meshcore.product import merge

    res = merge.merged(
        [m.to_mesh() for m in params.inputs],
        params.tolerance,
        progress=_scaled(progress, 0.0, 0.8),
    )
    return {
        "mesh": res.mesh,
        "quality": quality.report(res.mesh, progress=_scaled(progress, 0.8, 1.0)),
        "stats": res.stats(),
    }


def run_radial(params: RadialParams, progress: Progress) -> dict:
    """A radial mesh, with the classical mesh's quality as ``stats.quality_before`` if balanced."""
    from meshcore.product import radial_mesh

    res = radial_mesh.radial(
        params.center,
        params.inner_radius,
        params.outer_radius,
        params.angle,
        params.radial_layers,
        params.segments,
        balance=params.balance,
        progress=_scaled(progress, 0.0, 0.8),
    )
    return {
        "mesh": res.mesh,
        "quality": quality.report(res.mesh, progress=_scaled(progress, 0.8, 1.0)),
        "stats": res.stats(),
    }


# ----------------------------------------------------------------------------- examples

SQUARE = {
    "points": [[0, 0], [1, 0], [1, 1], [0, 1]],
    "cells": [{"type": "triangle", "data": [[0, 1, 2], [0, 2, 3]]}],
}

EXTRUDE_EXAMPLE = {
    "mesh": SQUARE,
    "path": {"type": "translate", "vector": [0, 0, 1], "layers": 10},
}

SWEEP_EXAMPLE = {
    "source": {
        "points": [[0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0.5]],
        "cells": [{"type": "triangle", "data": [[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]]}],
    },
    "target": [[0, 0, 2], [0.8, 0, 2], [0.8, 0.8, 2], [0, 0.8, 2]],
    "layers": 4,
}

MERGE_EXAMPLE = {
    "meshes": [
        SQUARE,
        {
            "points": [[1, 0], [2, 0], [2, 1], [1, 1]],
            "cells": [{"type": "quad", "data": [[0, 1, 2, 3]]}],
        },
    ]
}

RADIAL_EXAMPLE = {"outer_radius": 1.0, "radial_layers": 8, "segments": 32, "balance": True}
