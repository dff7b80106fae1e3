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

After validation ``DomainIn.coordinates`` holds numpy arrays: a Polygon's
rings as ``(k, 2)`` float64 arrays, a MultiPolygon's polygons as lists of
them (plain JSON again when dumped; a big body's rings come straight from
its bytes, see :mod:`service.bodies`). :meth:`DomainIn.to_domain` keeps
what it built, so the checks run once per model, and the job gets the
domain the submit validated: the submit dumps the params with a marker in
place of each domain's coordinates and :func:`pack` stores the arrays and
the validated :class:`~meshcore.domain.planar.Domain` beside them
(``params.npz``); the job's :func:`unpack` hands both back to the model.
A restarted or distributed job reads the same two files. Surfaces
(:class:`service.methods.surface_schema.SurfaceIn`) travel the same way:
their points and triangles as arrays, with the validated
:class:`~meshcore.domain.surface.Surface` beside them.
"""

from __future__ import annotations

import hashlib
import io
import json
import zipfile
from typing import Annotated, Any, BinaryIO, Literal

import numpy as np
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    PrivateAttr,
    SerializationInfo,
    TypeAdapter,
    ValidationInfo,
    WithJsonSchema,
    field_serializer,
    field_validator,
    model_validator,
)

from meshcore.domain.planar import DOMAIN_ARRAYS, Domain, parse_domain
from meshcore.domain.surface import Surface
from meshcore.errors import InputError
from service.bodies import MARKER

#: Validation context keys: coordinate arrays by marker (service.bodies, unpack), the
#: domains and the surfaces validated at submit by marker; serialization context key
#: collecting the models to pack (DomainIn, SurfaceIn), by the marker written in their place.
ARRAYS, DOMAINS, SURFACES, PACK = (
    "coordinate_arrays",
    "validated_domains",
    "validated_surfaces",
    "pack_domains",
)
#: Bytes per write when an array goes to a file (:func:`write_npz`).
_SLICE = 1 << 20
_SURFACE_ARRAYS = (
    "points",
    "triangles",
    "triangle_reversed",
    "triangle_shell",
    "shell_parent",
    "shell_depth",
    "shell_region",
    "shell_volume",
)

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
    _domains: dict[str, Domain] = PrivateAttr(default_factory=dict)

    @model_validator(mode="wrap")
    @classmethod
    def _validated_before(cls, value: Any, handler: Any, info: ValidationInfo) -> Any:
        # A job's params: the domains the submit validated come with the arrays (unpack).
        model = handler(value)
        model._domains.update(validated(value, "coordinates", info, DOMAINS) or {})
        return model

    @field_validator("coordinates", mode="wrap")
    @classmethod
    def _nested_positions(cls, value: Any, handler: Any, info: ValidationInfo) -> Any:
        # Validate at the depth the type asks for, so that errors carry the exact
        # path (["coordinates", ring, vertex, axis]) rather than a union's branches.
        gtype = info.data.get("type")
        arrays = (info.context or {}).get(ARRAYS, {})
        if isinstance(value, str) and value in arrays:  # parsed from the bytes (service.bodies)
            value = arrays[value]
            if (gtype == "Polygon") == isinstance(value[0], np.ndarray):
                return value
            value = _lists(value)  # the other depth: the ordinary path says where
        if gtype == "Polygon":
            return [_ring_array(r) for r in _POLYGON.validate_python(value)]
        if gtype == "MultiPolygon":
            polygons = _MULTIPOLYGON.validate_python(value)
            return [[_ring_array(r) for r in poly] for poly in polygons]
        return handler(value)  # the type itself is invalid and already reported

    @field_serializer("coordinates")
    def _coordinates_out(self, value: list, info: SerializationInfo) -> Any:
        packed = (info.context or {}).get(PACK)
        if packed is not None:  # a job's params: arrays apart (pack), a marker here
            marker = f"{MARKER}{len(packed)}"
            packed[marker] = self
            return marker
        return _lists(value)

    def rings(self) -> list[np.ndarray]:
        """Every ring's ``(k, 2)`` positions, polygon after polygon."""
        if self.type == "Polygon":
            return list(self.coordinates)
        return [ring for poly in self.coordinates for ring in poly]

    def content_arrays(self) -> list[np.ndarray]:
        """The arrays that identify this input (the submit's body hash): its rings."""
        return self.rings()

    def pack_into(self, prefix: str, arrays: dict[str, np.ndarray]) -> dict:
        """Add this model's coordinates and validated domains to ``arrays`` under
        ``prefix``; the index entry that :func:`unpack` reads them back with."""
        rings = self.rings()
        if len(rings) == 1:
            arrays[f"{prefix}.points"] = rings[0]
        else:
            arrays[f"{prefix}.points"] = np.concatenate(rings) if rings else np.zeros((0, 2))
        arrays[f"{prefix}.counts"] = np.array([len(r) for r in rings], dtype=np.int64)
        sizes = [1] * len(rings) if self.type == "Polygon" else [len(p) for p in self.coordinates]
        arrays[f"{prefix}.polygon_sizes"] = np.array(sizes, dtype=np.int64)
        domains = []
        for j, (key, dom) in enumerate(self._domains.items()):
            for name in DOMAIN_ARRAYS:
                arrays[f"{prefix}.{j}.{name}"] = getattr(dom, name)
            domains.append([key, dom.area, dom.diameter, dom.multi])
        return {"kind": "domain", "multi": self.type != "Polygon", "domains": domains}

    def geometry(self) -> dict:
        """The geometry as plain JSON values: ``{"type", "coordinates"}``."""
        return {"type": self.type, "coordinates": _lists(self.coordinates)}

    def point_count(self) -> int:
        """Number of positions in the geometry (for ``MESHSERVICE_MAX_POINTS``)."""
        return sum(len(ring) for ring in self.rings())

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
        key = _segments_key(segments)
        known = self._domains.get(key)
        if known is not None:
            return known
        geometry = {"type": self.type, "coordinates": self.coordinates}
        try:
            domain = parse_domain(geometry, segments)
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
        self._domains[key] = domain
        return domain


#: Sizes below this fraction of a domain's largest coordinate magnitude are refused: float64
#: numbers there are about 2**-52 of it apart, so a cell would span fewer than 4096 of them;
#: the methods' points then collide or their tolerances fail (probed on the unit square
#: with a hole: a grid at 1e15 with cells of 0.05 had coincident corners and a NaN quality,
#: a 500; paving lost a front at 1e12; quad_grid's merge failed at 1e14).
MIN_RELATIVE_SIZE = 2.0**-40


def check_resolution(points: np.ndarray, size: float | None, loc: tuple[str | int, ...]) -> None:
    """Refuse a target ``size`` too small for the float64 spacing at the input's coordinates
    (a domain's or a surface's ``points``).

    Raises
    ------
    InputError
        ``below_resolution`` at ``loc`` when ``size < MIN_RELATIVE_SIZE * max |x|``.
    """
    if size is None:
        return
    magnitude = float(np.abs(points).max())
    if size < MIN_RELATIVE_SIZE * magnitude:
        raise InputError(
            f"size {size:.6g} is too small for the input's coordinates (magnitude "
            f"{magnitude:.6g}, where float64 numbers are {np.spacing(magnitude):.3g} apart): "
            f"give a size of at least {MIN_RELATIVE_SIZE * magnitude:.3g}, or move the input "
            "nearer the origin",
            loc=loc,
            code="below_resolution",
        )


def validated(value: Any, field: str, info: ValidationInfo, key: str) -> Any:
    """What the submit validated for a packed model (context ``key``, by the marker
    a job's params hold in place of ``field``), or None for a plain value."""
    marker = value.get(field) if isinstance(value, dict) else None
    return (info.context or {}).get(key, {}).get(marker) if isinstance(marker, str) else None


def _ring_array(ring: list) -> np.ndarray:
    """Positions as a read-only (k, 2) array: parse_domain uses it without a copy."""
    arr = np.array(ring, dtype=np.float64).reshape(-1, 2)
    arr.setflags(write=False)
    return arr


def _lists(value: Any) -> Any:
    """Nested arrays and lists as plain lists of floats."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    return [_lists(v) for v in value]


def _segments_key(segments: list | None) -> str:
    """Which constraints a domain was built with (the key of :meth:`DomainIn.to_domain`'s memo)."""
    if segments is None:
        return ""
    return hashlib.sha256(json.dumps(segments).encode()).hexdigest()


def pack_arrays(packed: dict[str, Any]) -> dict[str, np.ndarray]:
    """The arrays of the models a params dump collected (``context={PACK: packed}``).

    Each model's coordinates (a surface's points and triangles) and what its
    validation built (domains, the surface), so the job reads them instead
    of parsing and validating again (:func:`unpack`); the arrays themselves,
    not copies (a single ring's positions are not concatenated). Empty when
    there is nothing to pack. :func:`write_npz` writes them.
    """
    arrays: dict[str, np.ndarray] = {}
    if not packed:
        return arrays
    index = [
        {"marker": marker, **model.pack_into(str(i), arrays)}
        for i, (marker, model) in enumerate(packed.items())
    ]
    arrays["index"] = np.frombuffer(json.dumps(index).encode(), np.uint8)
    return arrays


def pack_surface(
    prefix: str,
    arrays: dict[str, np.ndarray],
    points: np.ndarray,
    triangles: np.ndarray,
    surface: Surface | None,
) -> dict:
    """Add a surface's points, triangles and (once validated) :class:`Surface` to
    ``arrays`` under ``prefix``; the index entry :func:`unpack` reads them back with."""
    arrays[f"{prefix}.points"] = points
    arrays[f"{prefix}.triangles"] = triangles
    if surface is None:
        return {"kind": "surface", "surface": None}
    for name in _SURFACE_ARRAYS:
        arrays[f"{prefix}.surface.{name}"] = getattr(surface, name)
    return {"kind": "surface", "surface": [surface.volume, surface.diameter]}


def write_npz(arrays: dict[str, np.ndarray], out: BinaryIO) -> None:
    """Write ``arrays`` to ``out`` as an uncompressed npz (what :func:`numpy.load` reads).

    Unlike :func:`numpy.savez`, whose members are written in 16 MiB copies,
    each array's memory goes to the file in 1 MiB slices of itself: writing
    a million-vertex domain holds no second copy of it.
    """
    with zipfile.ZipFile(out, "w", zipfile.ZIP_STORED, allowZip64=True) as zf:
        for name, arr in arrays.items():
            arr = np.ascontiguousarray(arr)
            with zf.open(f"{name}.npy", "w", force_zip64=True) as member:
                np.lib.format.write_array_header_1_0(
                    member, np.lib.format.header_data_from_array_1_0(arr)
                )
                flat = memoryview(arr.reshape(-1)).cast("B")
                for lo in range(0, len(flat), _SLICE):
                    member.write(flat[lo : lo + _SLICE])


def unpack(data: bytes) -> dict[str, dict]:
    """The validation context of a job's params from the npz :func:`write_npz` wrote
    (``{}`` if empty)."""
    if not data:
        return {}
    arrays, domains, surfaces = {}, {}, {}
    with np.load(io.BytesIO(data)) as npz:
        for i, entry in enumerate(json.loads(npz["index"].tobytes())):
            marker = entry["marker"]
            if entry.get("kind", "domain") == "surface":
                arrays[marker] = {"points": npz[f"{i}.points"], "triangles": npz[f"{i}.triangles"]}
                if entry["surface"] is not None:
                    volume, diameter = entry["surface"]
                    surfaces[marker] = Surface(
                        **{name: npz[f"{i}.surface.{name}"] for name in _SURFACE_ARRAYS},
                        volume=volume,
                        diameter=diameter,
                    )
                continue
            points = npz[f"{i}.points"]
            bounds = np.cumsum([0, *npz[f"{i}.counts"].tolist()])
            rings = [points[a:b] for a, b in zip(bounds[:-1], bounds[1:], strict=True)]
            if entry["multi"]:
                cuts = np.cumsum([0, *npz[f"{i}.polygon_sizes"].tolist()])
                coords: list = [rings[a:b] for a, b in zip(cuts[:-1], cuts[1:], strict=True)]
            else:
                coords = rings
            arrays[marker] = coords
            domains[marker] = {
                key: Domain(
                    **{name: npz[f"{i}.{j}.{name}"] for name in DOMAIN_ARRAYS},
                    area=area,
                    diameter=diameter,
                    multi=multi,
                )
                for j, (key, area, diameter, multi) in enumerate(entry["domains"])
            }
    return {ARRAYS: arrays, DOMAINS: domains, SURFACES: surfaces}
