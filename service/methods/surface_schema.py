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
"""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Field

from meshcore.domain.surface import Surface, parse_surface
from meshcore.errors import InputError

# Strict: JSON numbers only (true and "1" are not coordinates); NaN and infinities refused.
FiniteFloat = Annotated[float, Field(allow_inf_nan=False, strict=True)]
Position3 = Annotated[list[FiniteFloat], Field(min_length=3, max_length=3)]
TriangleIndices = Annotated[
    list[Annotated[int, Field(strict=True, ge=0)]], Field(min_length=3, max_length=3)
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

    def point_count(self) -> int:
        """Number of points (for ``MESHSERVICE_MAX_POINTS``)."""
        return len(self.points)

    def to_surface(self, *, loc: tuple[str | int, ...] = ("surface",)) -> Surface:
        """The validated :class:`~meshcore.domain.surface.Surface`.

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
        try:
            return parse_surface(self.points, self.triangles)
        except InputError as exc:
            raise exc.prefixed(*loc) from None
