"""Wire model of the 2D domain input: a GeoJSON Polygon or MultiPolygon.

Methods that mesh a planar domain (``delaunay_admissible``, ``triangulate``,
...) take a ``domain`` field of type :class:`DomainIn` and an optional
``segments`` field of type :data:`ConstraintPolylines`, and validate both
in their params' ``check()``::

    class TriangulateParams(MethodParams):
        domain: DomainIn
        segments: ConstraintPolylines | None = None

        def check(self) -> None:
            super().check()
            self.domain.to_domain(self.segments)

Parsing (pydantic) rejects malformed JSON shapes, NaN and infinities with
the exact location (``["domain", "coordinates", 0, 3, 1]`` for the y of
vertex 3 of ring 0); :meth:`DomainIn.to_domain` runs
:func:`meshcore.domain.planar.parse_domain` (self-intersections, holes outside,
duplicates, ...) and locates its errors the same way, relative to the
params object. See DESIGN.md "Domain input (2D)" and the module
documentation of :mod:`meshcore.domain.planar` for what is accepted.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    TypeAdapter,
    ValidationInfo,
    WithJsonSchema,
    field_validator,
)

from meshcore.domain.planar import Domain, parse_domain
from meshcore.errors import InputError

# Strict: JSON numbers only (true and "1" are not coordinates); NaN and infinities refused.
FiniteFloat = Annotated[float, Field(allow_inf_nan=False, strict=True)]
Position = Annotated[list[FiniteFloat], Field(min_length=2, max_length=2)]
Ring = list[Position]
PolygonCoordinates = Annotated[list[Ring], Field(min_length=1)]
MultiPolygonCoordinates = Annotated[list[PolygonCoordinates], Field(min_length=1)]

_POLYGON = TypeAdapter(PolygonCoordinates)
_MULTIPOLYGON = TypeAdapter(MultiPolygonCoordinates)

_POSITION_SCHEMA = {
    "type": "array",
    "items": {"type": "number"},
    "minItems": 2,
    "maxItems": 2,
    "description": "[x, y]",
}
_RING_SCHEMA = {
    "type": "array",
    "items": _POSITION_SCHEMA,
    "description": "A ring: positions, closed (last = first) or not, either orientation.",
}
_POLYGON_SCHEMA = {
    "type": "array",
    "items": _RING_SCHEMA,
    "minItems": 1,
    "description": "Polygon: the outer ring, then its holes.",
}
_COORDINATES_SCHEMA = {
    "anyOf": [
        _POLYGON_SCHEMA,
        {
            "type": "array",
            "items": _POLYGON_SCHEMA,
            "minItems": 1,
            "description": "MultiPolygon: a list of polygons.",
        },
    ],
    "description": "Polygon: [outer, hole, ...]; MultiPolygon: [[outer, hole, ...], ...].",
}

#: A square of side 4 with a square hole of side 2 (area 12).
SQUARE_WITH_HOLE: dict[str, Any] = {
    "type": "Polygon",
    "coordinates": [
        [[0, 0], [4, 0], [4, 4], [0, 4], [0, 0]],
        [[1, 1], [1, 3], [3, 3], [3, 1], [1, 1]],
    ],
}

#: Interior constraint polylines: lists of at least two [x, y] positions.
ConstraintPolylines = Annotated[
    list[Annotated[list[Position], Field(min_length=2)]],
    Field(
        description="Interior constraint polylines, each a list of at least two [x, y] "
        "positions. They lie in the domain and meet the boundary and each other only at "
        "common vertices.",
        examples=[[[[0.5, 0.5], [0.5, 3.5]]]],
    ),
]


class DomainIn(BaseModel):
    """A planar domain: a GeoJSON Polygon or MultiPolygon geometry.

    Rings may repeat their first position at the end or not; orientation is
    free (it is normalized). Validation rejects, naming the ring and vertex:
    fewer than 3 distinct points, non-finite numbers, duplicate consecutive
    points, self-intersecting or mutually intersecting rings, holes outside
    their outer ring, overlapping polygons (DESIGN.md "Domain input (2D)").
    """

    model_config = ConfigDict(
        extra="forbid",
        json_schema_extra={"examples": [SQUARE_WITH_HOLE]},
    )

    type: Literal["Polygon", "MultiPolygon"] = Field(description="The GeoJSON geometry type.")
    coordinates: Annotated[list, WithJsonSchema(_COORDINATES_SCHEMA)]
    bbox: list[FiniteFloat] | None = Field(
        default=None, description="GeoJSON bounding box; accepted and ignored."
    )

    @field_validator("coordinates", mode="wrap")
    @classmethod
    def _nested_positions(cls, value: Any, handler: Any, info: ValidationInfo) -> Any:
        # Validate at the depth the type asks for, so that errors carry the exact
        # path (["coordinates", ring, vertex, axis]) rather than a union's branches.
        gtype = info.data.get("type")
        if gtype == "Polygon":
            return _POLYGON.validate_python(value)
        if gtype == "MultiPolygon":
            return _MULTIPOLYGON.validate_python(value)
        return handler(value)  # the type itself is invalid and already reported

    def point_count(self) -> int:
        """Number of positions in the geometry (for ``MESHSERVICE_MAX_POINTS``)."""
        polygons = [self.coordinates] if self.type == "Polygon" else self.coordinates
        return sum(len(ring) for poly in polygons for ring in poly)

    def to_domain(
        self,
        segments: list | None = None,
        *,
        loc: tuple[str | int, ...] = ("domain",),
        segments_loc: tuple[str | int, ...] = ("segments",),
    ) -> Domain:
        """The validated :class:`~meshcore.domain.planar.Domain`.

        Parameters
        ----------
        segments : list of polylines, optional
            Interior constraints (:data:`ConstraintPolylines`).
        loc, segments_loc : tuple
            Where this geometry and the constraints sit in the params object;
            they prefix the locations of the errors.

        Raises
        ------
        InputError
            As :func:`meshcore.domain.planar.parse_domain`, with every ``loc``
            relative to the params object, e.g. ``["domain", "coordinates",
            1, 0]`` or ``["segments", 2, 5]``.
        """
        geometry = {"type": self.type, "coordinates": self.coordinates}
        try:
            return parse_domain(geometry, segments)
        except InputError as exc:
            errors = []
            for e in exc.errors:
                path = list(e["loc"])
                if path[:1] == ["segments"]:
                    path = [*segments_loc, *path[1:]]
                else:
                    path = [*loc, *path]
                errors.append({**e, "loc": path})
            raise InputError(exc.message, code=exc.code, errors=errors) from None
