"""Wire model of the 3D domain input: a closed triangulated surface.

Methods that mesh a volume (``tetrahedralize``, ``delaunay_admissible``
with a surface, ...) take a ``surface`` field of type :class:`SurfaceIn`
and validate it in their params' ``check()``::

    class TetrahedralizeParams(MethodParams):
        surface: SurfaceIn

        def check(self) -> None:
            super().check()
            self.surface.to_surface()

Parsing (pydantic) rejects malformed JSON shapes, NaN and infinities with
the exact location (``["surface", "points", 3, 1]`` for the y of point 3);
:meth:`SurfaceIn.to_surface` runs
:func:`meshcore.domain.surface.parse_surface` (open or non-manifold edges,
inconsistent orientation, self-intersections, ...) and locates its errors
the same way, under the field. See DESIGN.md "Surface input (3D)" and the
module documentation of :mod:`meshcore.domain.surface`.

:meth:`SurfaceIn.to_surface` keeps the surface it built, and a job gets the
surface its submit validated, as domains do (:mod:`service.methods.domain_schema`):
the submit dumps the params with a marker in place of the points and the
triangles, and ``params.npz`` holds them with the validated surface; the job
validates nothing again.
"""

from __future__ import annotations

from typing import Annotated, Any

import numpy as np
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    PrivateAttr,
    SerializationInfo,
    ValidationInfo,
    field_serializer,
    field_validator,
    model_validator,
)

from meshcore.domain.surface import Surface, parse_surface
from meshcore.errors import InputError
from service.bodies import MARKER
from service.methods.domain_schema import ARRAYS, PACK, SURFACES, pack_surface, validated

# Strict: JSON numbers only (true and "1" are not coordinates); NaN and infinities refused.
FiniteFloat = Annotated[float, Field(allow_inf_nan=False, strict=True)]
Position3 = Annotated[list[FiniteFloat], Field(min_length=3, max_length=3)]
#: Indices are int64 (no surface has more points; a larger one is refused where it is).
TriangleIndices = Annotated[
    list[Annotated[int, Field(strict=True, ge=0, lt=2**63)]], Field(min_length=3, max_length=3)
]

#: The unit cube, 8 corners and 12 triangles oriented outward (volume 1).
UNIT_CUBE: dict[str, Any] = {
    "points": [
        [0, 0, 0],
        [1, 0, 0],
        [0, 1, 0],
        [1, 1, 0],
        [0, 0, 1],
        [1, 0, 1],
        [0, 1, 1],
        [1, 1, 1],
    ],
    "triangles": [
        [0, 2, 3],
        [0, 3, 1],
        [4, 5, 7],
        [4, 7, 6],
        [0, 1, 5],
        [0, 5, 4],
        [2, 6, 7],
        [2, 7, 3],
        [0, 4, 6],
        [0, 6, 2],
        [1, 3, 7],
        [1, 7, 5],
    ],
}


class SurfaceIn(BaseModel):
    """A closed triangulated surface: points and triangles (one or more shells).

    Triangle orientation is free but consistent within a shell; it is
    normalized outward. Validation rejects, naming the triangles, edges or
    points: fewer than 4 points, non-finite numbers, indices out of range,
    degenerate or duplicate triangles, an edge not held by exactly two
    triangles, a non-manifold vertex, inconsistent orientation, and
    self-intersection with the point where two triangles meet (DESIGN.md
    "Surface input (3D)").
    """

    model_config = ConfigDict(extra="forbid", json_schema_extra={"examples": [UNIT_CUBE]})

    points: list[Position3] = Field(description="[x, y, z] rows, at least 4.")
    triangles: list[TriangleIndices] = Field(
        description="[i, j, k] point indices per triangle, at least 4 triangles."
    )
    _surface: Surface | None = PrivateAttr(default=None)

    @model_validator(mode="wrap")
    @classmethod
    def _validated_before(cls, value: Any, handler: Any, info: ValidationInfo) -> Any:
        # A job's params: the surface the submit validated comes with the arrays (unpack).
        model = handler(value)
        model._surface = validated(value, "points", info, SURFACES)
        return model

    @field_validator("points", "triangles", mode="wrap")
    @classmethod
    def _as_array(cls, value: Any, handler: Any, info: ValidationInfo) -> Any:
        # One array, made once: the body hash, params.npz and the validation read it.
        packed = (info.context or {}).get(ARRAYS, {})
        if isinstance(value, str) and value in packed:  # a job's params (unpack)
            return packed[value][info.field_name]
        dtype = np.float64 if info.field_name == "points" else np.int64
        return np.asarray(handler(value), dtype=dtype).reshape(-1, 3)

    @field_serializer("points", "triangles")
    def _arrays_out(self, value: Any, info: SerializationInfo) -> Any:
        packed = (info.context or {}).get(PACK)
        if packed is not None:  # a job's params: arrays apart (pack), a marker here
            marker = next((m for m, model in packed.items() if model is self), None)
            if marker is None:
                marker = f"{MARKER}{len(packed)}"
                packed[marker] = self
            return marker
        return value.tolist()

    def content_arrays(self) -> list[np.ndarray]:
        """The arrays that identify this input (the submit's body hash)."""
        return [self.points, self.triangles]

    def pack_into(self, prefix: str, arrays: dict[str, np.ndarray]) -> dict:
        """Add the points, triangles and validated surface to ``arrays`` under ``prefix``;
        the index entry of :func:`~service.methods.domain_schema.unpack`."""
        return pack_surface(prefix, arrays, self.points, self.triangles, self._surface)

    def point_count(self) -> int:
        """Number of points (for ``MESHSERVICE_MAX_POINTS``)."""
        return len(self.points)

    def to_surface(self, *, loc: tuple[str | int, ...] = ("surface",)) -> Surface:
        """The validated :class:`~meshcore.domain.surface.Surface`, built on the first
        call (or handed over by the submit, see the module docstring) and kept.

        Parameters
        ----------
        loc : tuple
            Where this surface sits in the params object; it prefixes the
            locations of the errors.

        Raises
        ------
        InputError
            As :func:`meshcore.domain.surface.parse_surface`, with every
            ``loc`` relative to the params object, e.g. ``["surface",
            "triangles", 17]``.
        """
        if self._surface is None:
            try:
                self._surface = parse_surface(self.points, self.triangles)
            except InputError as exc:
                raise exc.prefixed(*loc) from None
        return self._surface
