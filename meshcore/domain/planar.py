"""The 2D domain input: GeoJSON polygons and interior constraints, validated.

A domain is given as a GeoJSON ``Polygon`` or ``MultiPolygon`` geometry plus
optional interior constraint polylines (DESIGN.md, "Domain input (2D)").
:func:`parse_domain` checks it and returns a frozen :class:`Domain`: the ring
vertices, the boundary segments oriented with the domain on their left, the
constraint segments, the exact area and the diameter. Every method that meshes
a planar domain (admissible boundaries §9.1, triangulation, medial axis §9.4)
starts from a :class:`Domain`.

Terminology (§9.1.1): the boundary discretization is a set 𝓕 of segments
``f = AB`` whose endpoints form the point set 𝓢. Here 𝓢 is
:attr:`Domain.points` and 𝓕 is :attr:`Domain.segments` (the ring edges)
together with :attr:`Domain.constraints` (interior segments the mesh must
contain as well).

What is accepted
----------------
* A ``Polygon`` is a list of rings, the first the outer ring, the others its
  holes; a ``MultiPolygon`` is a list of such polygons. A ring is a list of
  ``[x, y]`` positions, closed or not: a last position equal to the first is
  dropped. Orientation is free; it is normalized (outer rings
  counter-clockwise, holes clockwise, so the domain lies left of every
  segment, as RFC 7946 asks).
* Collinear consecutive vertices (straight runs of boundary samples) are
  allowed: they are ordinary vertices.
* Constraint polylines (``segments``: a list of polylines, each a list of
  at least two ``[x, y]`` positions) lie in the domain. All segments,
  boundary and constraints together, form a planar straight-line graph:
  two segments meet at most at a common vertex. A constraint vertex may
  coincide with a ring vertex (an interface running from boundary to
  boundary) or with a vertex of another polyline (polylines may meet, branch
  and close into loops); its segments are then attached to that vertex.

What is rejected
----------------
Each rejection is an :class:`~meshcore.errors.InputError` whose ``code`` is
one of the following and whose message names the ring (``ring r`` for a
Polygon, ``polygon p, ring r`` for a MultiPolygon) or constraint and the
vertex. ``loc`` points into the arguments: ``("coordinates", r, v)`` for a
Polygon, ``("coordinates", p, r, v)`` for a MultiPolygon,
``("segments", i, j)`` for vertex ``j`` of constraint polyline ``i``; vertex
indices are those of the input lists.

``bad_geometry``
    Not a Polygon / MultiPolygon object, empty coordinate lists, a position
    that is not two numbers (3D positions are refused: the domain is planar).
``non_finite``, ``out_of_range``
    NaN or infinite coordinates; magnitudes above ``1e150`` (the area would
    overflow); a diameter below ``1e-100`` (it would underflow), at ``("coordinates",)``.
``too_few_points``
    A ring with fewer than 3 distinct points, a polyline with fewer than 2.
``duplicate_point``
    Two consecutive equal positions (besides the closing one).
``zero_area``
    A ring whose vertices are all collinear.
``self_intersection``
    A ring whose segments cross, touch or overlap: crossings, a vertex on
    another segment, a vertex repeated non-consecutively (a ring touching
    itself at a vertex is rejected: it would make a non-manifold boundary
    vertex), a spike doubling back over the previous segment. The message
    names both segments and the point.
``ring_intersection``
    Two distinct rings sharing any point (crossing, touching at a vertex or
    on a segment, overlapping): rings must be pairwise disjoint.
``hole_outside``
    A hole not inside its outer ring, or inside another hole of its polygon.
``polygon_overlap``
    A polygon of a MultiPolygon inside another (not inside one of its
    holes). Parts whose boundaries cross or touch are ``ring_intersection``.
``constraint_intersection``
    A constraint segment crossing, overlapping or touching another segment
    anywhere but at a common vertex (a constraint vertex on the interior of
    a boundary segment is refused: add that vertex to the ring).
``constraint_outside``
    A constraint segment outside the domain.

Robustness
----------
Every decision is a sign of :func:`~meshcore.geometry.predicates.orient2d`
or an exact comparison of input coordinates; no tolerance decides anything
(DESIGN.md, "Geometry robustness"). The predicates see the coordinates
scaled by a power of two (exact), so the outcome is the same after any
translation or power-of-two scaling that is exact in floating point.
Candidate segment pairs come from :mod:`meshcore.domain.crossings`: the
ring segments are cut into short monotone runs ("pieces", whose own
segments cannot meet), the pieces hashed into a uniform grid (long single
segments rasterized through the cells they cross); cell assignment is
conservative (it may only add candidates). The pieces sharing a cell are
compared in a compiled loop (bounding boxes compared exactly, then the
segments near the other piece with
:func:`~meshcore.geometry.predicates.orient2d_scalar`), without building
pair arrays. The ring checks, orientation and exact area are compiled
passes too, and nothing is allocated per vertex beyond the returned arrays:
a ring given as a read-only float64 array (as the service hands it over) is
not even copied, and the oriented segments are derived from the rings on
first use (:attr:`Domain.segments`). The cost is linear in the number of
pieces, (piece, cell) entries and nearby pairs: near linear for boundary
samples (1M vertices in about 0.02 s, 4-5 times GEOS), quadratic in the
worst case where very many long segments run close together (dense spike
fans), as GEOS's validity check is (``benchmarks/domain.py``).

References
----------
DESIGN.md "Domain input (2D)", "Errors", "Geometry robustness"; methods
text §9.1.1 (boundary discretization, segments).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numba import njit

from meshcore.domain.area import _area
from meshcore.domain.crossings import (
    _CROSS,
    _ENTRIES_PER_SEGMENT,
    _TOUCH,
    _crossing_point,
    _floor_index,
    _intersections,
)
from meshcore.domain.numbers import is_number, refuse_non_numbers
from meshcore.errors import InputError
from meshcore.geometry.predicates import orient2d, orient2d_scalar
from meshcore.geometry.tolerances import MAX_COORDINATE, MAX_COORDINATE_3D, MIN_DIAMETER

__all__ = ["DOMAIN_ARRAYS", "Domain", "as_domain", "parse_domain", "parse_size_field"]

# Ray-test candidate pairs processed per chunk (bounds memory).
_PAIR_CHUNK = 1 << 22
# At most this many faults are listed in an error's ``errors``.
_MAX_LISTED = 10


#: The arrays of a :class:`Domain` and their dtypes: each is made read-only (a copy of
#: its own where the caller's was writable) and compared by ``==``; the service stores
#: a validated domain as these arrays.
DOMAIN_ARRAYS = {
    "points": np.float64,
    "ring_offsets": np.int64,
    "ring_polygon": np.int64,
    "ring_is_hole": np.bool_,
    "ring_reversed": np.bool_,
    "constraints": np.int64,
    "constraint_source": np.int64,
}


@dataclass(frozen=True, eq=False)
class Domain:
    """A validated planar domain: rings, oriented boundary segments, constraints.

    Build it with :func:`parse_domain`. Ring ``k`` is the ``k``-th ring in
    the order of the geometry (for a MultiPolygon: polygon 0's outer ring,
    its holes, then polygon 1's outer ring, ...). Its vertices are
    ``points[ring_offsets[k]:ring_offsets[k + 1]]`` in the order of the
    input (the closing position dropped), and boundary segment
    ``ring_offsets[k] + v`` is the input edge from vertex ``v`` to vertex
    ``v + 1`` (cyclically), oriented so that the domain lies on its left.

    Attributes
    ----------
    points : (n, 2) float64
        Ring vertices (the first ``boundary_point_count`` rows, ring after
        ring), then the constraint vertices that are not ring vertices, in
        order of first appearance. All rows are distinct.
    ring_offsets : (R + 1,) int64
        Ring ``k`` owns vertices and segments ``ring_offsets[k]`` to
        ``ring_offsets[k + 1] - 1``.
    ring_polygon : (R,) int64
        Index of the polygon each ring belongs to (0 for a Polygon).
    ring_is_hole : (R,) bool
        False for a polygon's outer ring (its first ring), True for holes.
    ring_reversed : (R,) bool
        Whether the input ring ran the other way (clockwise outer ring,
        counter-clockwise hole): its segments go from vertex ``v + 1`` to
        ``v``.
    segments : (m, 2) int64
        Boundary segments, ``m = ring_offsets[-1]``, one per input edge,
        oriented with the domain on the left: outer rings counter-clockwise,
        holes clockwise. Derived from ``ring_offsets`` and ``ring_reversed``
        on first use (16 MB at 1M vertices that a validation alone does not
        need), then kept.
    constraints : (c, 2) int64
        Interior constraint segments, in input order (polyline after
        polyline, vertex after vertex), as point indices.
    constraint_source : (c, 2) int64
        Per constraint segment: the input polyline ``i`` and the index ``j``
        of its first vertex in that polyline (the segment joins vertices
        ``j`` and ``j + 1``).
    area : float
        The domain's area, outer rings minus holes, from exact products
        summed with compensation (:func:`math.fsum`): the exact area of the
        input polygons to within about an ulp, however far from the origin
        they lie.
    diameter : float
        Diagonal of the bounding box of the points; the length scale for
        tolerances.
    multi : bool
        Whether the input was a MultiPolygon (it selects the shape of
        ``loc`` paths, see :meth:`vertex_loc`).

    References
    ----------
    DESIGN.md "Domain input (2D)"; methods text §9.1.1.
    """

    points: np.ndarray
    ring_offsets: np.ndarray
    ring_polygon: np.ndarray
    ring_is_hole: np.ndarray
    ring_reversed: np.ndarray
    constraints: np.ndarray
    constraint_source: np.ndarray
    area: float
    diameter: float
    multi: bool = False

    def __post_init__(self) -> None:
        for name, dtype in DOMAIN_ARRAYS.items():
            arr = np.asarray(getattr(self, name), dtype=dtype)
            if arr.flags.writeable:  # perhaps the caller's: a copy of our own, frozen
                arr = arr.copy()
            if name in ("points", "constraints", "constraint_source"):
                arr = arr.reshape(-1, 2)
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        object.__setattr__(self, "area", float(self.area))
        object.__setattr__(self, "diameter", float(self.diameter))

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Domain):
            return NotImplemented
        return (
            self.area == other.area
            and self.diameter == other.diameter
            and self.multi == other.multi
            and all(np.array_equal(getattr(self, k), getattr(other, k)) for k in DOMAIN_ARRAYS)
        )

    __hash__ = None  # type: ignore[assignment]

    @cached_property
    def segments(self) -> np.ndarray:
        """(m, 2) int64, read-only: the boundary segments (see the class documentation)."""
        # Allocated by numpy, which asks the kernel for huge pages on large arrays
        # (numba's allocator does not): a fresh 16 MB at 1M vertices, faulted in
        # 4 KB pages, cost more than the loop that fills it.
        segs = np.empty((self.boundary_point_count, 2), dtype=np.int64)
        _oriented_segments(self.ring_offsets, self.ring_reversed, segs)
        segs.setflags(write=False)
        return segs

    @property
    def ring_count(self) -> int:
        """Number of rings R."""
        return len(self.ring_offsets) - 1

    @property
    def boundary_point_count(self) -> int:
        """Number of ring vertices (= number of boundary segments)."""
        return int(self.ring_offsets[-1])

    @property
    def segment_ring(self) -> np.ndarray:
        """(m,) int64: the ring of each boundary segment (and of each ring vertex)."""
        return np.repeat(np.arange(self.ring_count, dtype=np.int64), np.diff(self.ring_offsets))

    def corner_angles(self) -> np.ndarray:
        """(boundary_point_count,) float64: the angle inside the domain at each ring
        vertex, in degrees in [0, 360) (over 180 at a reflex corner); from the
        directions of its two segments, to rounding."""
        m = self.boundary_point_count
        nxt = np.empty(m, np.int64)
        prv = np.empty(m, np.int64)
        nxt[self.segments[:, 0]] = self.segments[:, 1]
        prv[self.segments[:, 1]] = self.segments[:, 0]
        P = self.points
        u, w = P[prv] - P[:m], P[nxt] - P[:m]
        turn = np.arctan2(u[:, 1], u[:, 0]) - np.arctan2(w[:, 1], w[:, 0])
        return np.degrees(np.mod(turn, 2 * np.pi))

    def ring_name(self, k: int) -> str:
        """Human name of ring ``k``: ``"ring 1"`` or ``"polygon 0, ring 1"``."""
        return _ring_name(self.multi, *self._ring_position(k))

    def ring_loc(self, k: int) -> tuple[str | int, ...]:
        """``loc`` path of ring ``k`` in the geometry (see :func:`parse_domain`)."""
        return _ring_loc(self.multi, *self._ring_position(k))

    def vertex_loc(self, i: int) -> tuple[str | int, ...]:
        """``loc`` path of point ``i``: into the geometry, or into ``segments``."""
        i = int(i)
        nb = self.boundary_point_count
        if i < nb:
            k = int(np.searchsorted(self.ring_offsets, i, side="right")) - 1
            return (*self.ring_loc(k), i - int(self.ring_offsets[k]))
        rows, cols = np.nonzero(self.constraints == i)
        line, first = (int(x) for x in self.constraint_source[rows[0]])
        return ("segments", line, first + int(cols[0]))

    def vertex_name(self, i: int) -> str:
        """Human name of point ``i``, e.g. ``"vertex 3 of ring 1"``."""
        loc = self.vertex_loc(i)
        if loc[0] == "segments":
            return f"vertex {loc[2]} of constraint {loc[1]}"
        k = int(np.searchsorted(self.ring_offsets, int(i), side="right")) - 1
        return f"vertex {loc[-1]} of {self.ring_name(k)}"

    def as_geojson(self) -> dict:
        """The rings as a GeoJSON geometry, normalized: closed, outer CCW, holes CW.

        Returns
        -------
        dict
            ``{"type": "Polygon" | "MultiPolygon", "coordinates": ...}`` with
            plain Python floats, the same type as the input.
        """
        polys: list[list[list[list[float]]]] = []
        for k in range(self.ring_count):
            lo, hi = int(self.ring_offsets[k]), int(self.ring_offsets[k + 1])
            ring = self.points[lo:hi]
            if self.ring_reversed[k]:
                ring = ring[::-1]
            coords = ring.tolist()
            coords.append(coords[0])
            if not self.ring_is_hole[k]:
                polys.append([])
            polys[-1].append(coords)
        if self.multi:
            return {"type": "MultiPolygon", "coordinates": polys}
        return {"type": "Polygon", "coordinates": polys[0]}

    def _ring_position(self, k: int) -> tuple[int, int]:
        p = int(self.ring_polygon[k])
        first = int(np.searchsorted(self.ring_polygon, p, side="left"))
        return p, int(k) - first


# ---------------------------------------------------------------------------
# Names and locations
# ---------------------------------------------------------------------------


def _ring_name(multi: bool, p: int, r: int) -> str:
    return f"polygon {p}, ring {r}" if multi else f"ring {r}"


def _ring_loc(multi: bool, p: int, r: int) -> tuple[str | int, ...]:
    return ("coordinates", p, r) if multi else ("coordinates", r)


def _pt(x: float, y: float) -> str:
    return f"({float(x)!r}, {float(y)!r})"


class _Names:
    """Names and ``loc`` paths of rings, vertices and segments for messages."""

    def __init__(self, multi: bool, ring_pos: list[tuple[int, int]], lengths: np.ndarray):
        self.multi = multi
        self.ring_pos = ring_pos
        self.lengths = lengths
        self.offsets = np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64)
        self.line_offsets = np.zeros(1, dtype=np.int64)

    def ring(self, k: int) -> str:
        return _ring_name(self.multi, *self.ring_pos[k])

    def ring_loc(self, k: int) -> tuple[str | int, ...]:
        return _ring_loc(self.multi, *self.ring_pos[k])

    def vertex_loc(self, k: int, v: int) -> tuple[str | int, ...]:
        return (*self.ring_loc(k), int(v))

    def segment(self, s: int) -> tuple[str, tuple[str | int, ...], int]:
        """(description, loc of its first vertex, owner id) of global segment ``s``.

        Boundary segments come first (one per ring vertex), then constraint
        segments (one per consecutive pair of polyline vertices). Owner ids
        are ring numbers for boundary segments, ``-1 - polyline`` otherwise.
        """
        s = int(s)
        nb = int(self.offsets[-1])
        if s < nb:
            k = int(np.searchsorted(self.offsets, s, side="right")) - 1
            v = s - int(self.offsets[k])
            w = (v + 1) % int(self.lengths[k])
            return f"segment [{self.ring(k)}: vertex {v} -> {w}]", self.vertex_loc(k, v), k
        t = s - nb
        i = int(np.searchsorted(self.line_offsets, t, side="right")) - 1
        j = t - int(self.line_offsets[i])
        return f"segment [constraint {i}: vertex {j} -> {j + 1}]", ("segments", i, j), -1 - i


# ---------------------------------------------------------------------------
# Parsing positions
# ---------------------------------------------------------------------------


def _is_seq(value: object) -> bool:
    if isinstance(value, np.ndarray):
        return value.ndim >= 1
    return isinstance(value, Sequence) and not isinstance(value, str | bytes)


def _positions(value: object, loc: tuple, what: str) -> tuple[np.ndarray, tuple]:
    """A list of ``[x, y]`` positions as a (k, 2) float64 array, or InputError;
    and its bounding box ``(min x, min y, max x, max y)``.

    ``loc`` locates the list; faults are located at the offending position
    (and coordinate, for non-finite numbers). A read-only C-contiguous
    float64 array is returned as it is; a writable one is copied (the
    domain must not change under the caller's hands) in the pass that
    checks it (:func:`_first_bad`).
    """
    if not _is_seq(value):
        raise InputError(f"{what} must be a list of [x, y] positions", loc=loc, code="bad_geometry")
    arr = None
    try:
        arr = np.asarray(value)
    except (ValueError, TypeError, OverflowError):
        arr = None
    if arr is not None and arr.ndim == 1 and arr.size == 0:
        return np.zeros((0, 2)), (np.inf, np.inf, -np.inf, -np.inf)
    if arr is not None and arr.dtype.kind in "iuf" and arr is not value:
        refuse_non_numbers(value, loc, what=what, code="bad_geometry")  # [True, 1.5] is float
    out = _NO_COPY
    if arr is None or arr.dtype.kind not in "iuf" or arr.ndim != 2 or arr.shape[1] != 2:
        arr = _positions_slow(value, loc, what)
    elif arr.dtype != np.float64 or not arr.flags.c_contiguous:
        arr = np.array(arr, dtype=np.float64, order="C")
    elif arr is value and arr.flags.writeable:
        out = np.empty_like(arr)  # a caller's writable array: copied
    v, c, kind, *box = _first_bad(_read_only(arr), MAX_COORDINATE, out)
    if kind == 1:
        raise InputError(
            f"{what}: vertex {v} has a non-finite coordinate ({float(arr[v, c])!r})",
            loc=(*loc, v, c),
            code="non_finite",
        )
    if kind == 2:
        raise InputError(
            f"{what}: vertex {v} has a coordinate of magnitude above {MAX_COORDINATE:g} "
            f"({float(arr[v, c])!r})",
            loc=(*loc, v, c),
            code="out_of_range",
        )
    return (arr if out is _NO_COPY else out), tuple(box)


#: The ``out`` of :func:`_first_bad` that asks for no copy.
_NO_COPY = np.empty((0, 2))


@njit(cache=True)
def _first_bad(arr, limit, out):
    """(vertex, coordinate, kind) of the first non-finite coordinate (kind 1), else of the
    first above ``limit`` in magnitude (kind 2), else (0, 0, 0), row-major order; then
    the bounding box (min x, min y, max x, max y) of the rows read. One pass, which
    also copies ``arr`` into ``out`` when ``out`` has as many rows (else no copy)."""
    copy = out.shape[0] == arr.shape[0]
    big_v = -1
    big_c = 0
    lx = ly = np.inf
    hx = hy = -np.inf
    for v in range(arr.shape[0]):
        x = arr[v, 0]
        y = arr[v, 1]
        if copy:
            out[v, 0] = x
            out[v, 1] = y
        if not np.isfinite(x):
            return v, 0, 1, lx, ly, hx, hy
        if not np.isfinite(y):
            return v, 1, 1, lx, ly, hx, hy
        if big_v < 0 and (abs(x) > limit or abs(y) > limit):
            big_v = v
            big_c = 0 if abs(x) > limit else 1
        lx = min(lx, x)
        hx = max(hx, x)
        ly = min(ly, y)
        hy = max(hy, y)
    if big_v >= 0:
        return big_v, big_c, 2, lx, ly, hx, hy
    return 0, 0, 0, lx, ly, hx, hy


def _positions_slow(value: Sequence, loc: tuple, what: str) -> np.ndarray:
    """Position by position: locate the first malformed one, else convert."""
    out = np.empty((len(value), 2))
    for v, pos in enumerate(value):
        if not _is_seq(pos) or len(pos) != 2:
            n = len(pos) if _is_seq(pos) else None
            got = f"{n} numbers" if n is not None else type(pos).__name__
            raise InputError(
                f"{what}: vertex {v} must be a position [x, y] of two numbers, got {got}",
                loc=(*loc, v),
                code="bad_geometry",
            )
        for c, x in enumerate(pos):
            if not is_number(x):
                raise InputError(
                    f"{what}: vertex {v}, coordinate {c} is not a number ({x!r})",
                    loc=(*loc, v, c),
                    code="bad_geometry",
                )
            try:
                out[v, c] = float(x)
            except (OverflowError, ValueError, TypeError):
                out[v, c] = np.inf
    return out


def _polygons(geometry: object) -> tuple[bool, list[list]]:
    """Whether it is a MultiPolygon, and its polygons as lists of rings."""
    if not isinstance(geometry, Mapping):
        raise InputError(
            "the domain must be a GeoJSON geometry object "
            '{"type": "Polygon" | "MultiPolygon", "coordinates": [...]}',
            loc=(),
            code="bad_geometry",
        )
    gtype = geometry.get("type")
    if gtype not in ("Polygon", "MultiPolygon"):
        raise InputError(
            f'the domain\'s "type" must be "Polygon" or "MultiPolygon", got {gtype!r}',
            loc=("type",),
            code="bad_geometry",
        )
    coords = geometry.get("coordinates")
    multi = gtype == "MultiPolygon"
    if not _is_seq(coords) or len(coords) == 0:
        raise InputError(
            f"a {gtype} needs a non-empty list of "
            + ("polygons (lists of rings)" if multi else "rings (lists of positions)"),
            loc=("coordinates",),
            code="bad_geometry",
        )
    if not multi:
        return False, [coords]
    for p, poly in enumerate(coords):
        if not _is_seq(poly) or len(poly) == 0:
            raise InputError(
                f"polygon {p} must be a non-empty list of rings",
                loc=("coordinates", p),
                code="bad_geometry",
            )
    return True, list(coords)


# ---------------------------------------------------------------------------
# Exact helpers
# ---------------------------------------------------------------------------


def _power_of_two_scale(*arrays: np.ndarray, big: float = 0.0) -> float:
    """2**-e with e the exponent of the largest magnitude (of the arrays' values
    and ``big``): scaled |coordinates| < 1.

    Multiplying by it is exact (no coordinate comes near underflow within
    the accepted range unless it is absurdly small next to the largest),
    changes no predicate sign, and keeps the predicates' products far from
    overflow and underflow.
    """
    for a in arrays:
        if a.size:
            big = max(big, -float(a.min()), float(a.max()))
    if big == 0.0:
        return 1.0
    return float(np.ldexp(1.0, -int(np.frexp(big)[1])))


# ---------------------------------------------------------------------------
# Point in polygon: ray parity per (query, ring)
# ---------------------------------------------------------------------------


def ray_parity(q, q_skip_ring, p0, p1, seg_ring, n_rings):
    """Rings that contain each query point, by exact ray crossing parity.

    Parameters
    ----------
    q : (k, 2) float64
        Query points, none of them on a segment of a ring it is tested
        against (callers guarantee it).
    q_skip_ring : (k,) int64
        A ring not to test the query against (its own ring), or -1.
    p0, p1 : (s, 2) float64
        Ring segments; ``seg_ring`` (s,) int64 their ring.

    Returns
    -------
    (r, 2) int64
        Rows ``(query, ring)`` for every ring that contains the query.

    Notes
    -----
    Each query shoots an axis-parallel ray, in whichever of the four
    directions meets the fewest candidate segments. For a ray along +u
    (u = x or y, v the other axis), a segment with ``lo.v <= q.v < hi.v``
    (half-open, exact comparisons; lo, hi its endpoints ordered by v)
    crosses it iff ``orient2d(lo, hi, q) > 0`` in the (u, v) frame, and
    iff ``< 0`` for a ray along -u. Candidates come from strips in v, the
    entries of a strip sorted by the column of the segment's far end, so
    a query only meets segments that reach past it.
    """
    options = []
    for u in (0, 1):
        sides = _ray_plan(q, p0, p1, u)
        for side, (first, count, sseg) in sides or ():
            options.append((u, side, first, count, sseg))
    if not options:
        return np.zeros((0, 2), dtype=np.int64)
    counts = np.stack([o[3] for o in options])
    choice = np.argmin(counts, axis=0)
    found = []
    for o, (u, side, first, count, sseg) in enumerate(options):
        queries = np.flatnonzero(choice == o)
        if queries.size == 0:
            continue
        frame = [u, 1 - u]
        qq = q[:, frame]
        a = p0[:, frame]
        b = p1[:, frame]
        up = a[:, 1] < b[:, 1]
        low = np.where(up[:, None], a, b)
        high = np.where(up[:, None], b, a)
        cnt = count[queries]
        cum = np.cumsum(cnt)
        start = 0
        while start < len(queries):
            base = int(cum[start - 1]) if start else 0
            stop = int(np.searchsorted(cum, base + _PAIR_CHUNK, side="right"))
            stop = min(max(stop, start + 1), len(queries))
            c = cnt[start:stop]
            tot = int(c.sum())
            if tot:
                qi = np.repeat(queries[start:stop], c)
                e = np.repeat(first[queries[start:stop]], c) + (
                    np.arange(tot) - np.repeat(np.cumsum(c) - c, c)
                )
                s = sseg[e]
                y = qq[qi, 1]
                ok = (low[s, 1] <= y) & (y < high[s, 1]) & (seg_ring[s] != q_skip_ring[qi])
                qi, s = qi[ok], s[ok]
                hit = orient2d(low[s], high[s], qq[qi]) * side > 0
                found.append(qi[hit] * n_rings + seg_ring[s[hit]])
            start = stop
    if not found:
        return np.zeros((0, 2), dtype=np.int64)
    keys, counts_ = np.unique(np.concatenate(found), return_counts=True)
    keys = keys[counts_ % 2 == 1]
    return np.stack([keys // n_rings, keys % n_rings], axis=1)


def _ray_plan(q, p0, p1, u):
    """Candidate lists for rays along +u and -u.

    Returns ``None`` when every segment is parallel to u, else
    ``[(+1, (first, count, entries)), (-1, (first, count, entries))]``: query
    ``i`` meets segments ``entries[first[i]:first[i] + count[i]]``.
    """
    v = 1 - u
    lov = np.minimum(p0[:, v], p1[:, v])
    hiv = np.maximum(p0[:, v], p1[:, v])
    # Only segments whose half-open v-range holds some query can be crossed
    # (segments parallel to the ray never are).
    qv = np.sort(q[:, v])
    live = np.flatnonzero(
        np.searchsorted(qv, hiv, side="left") > np.searchsorted(qv, lov, side="left")
    )
    if live.size == 0:
        return None
    lov, hiv = lov[live], hiv[live]
    lou = np.minimum(p0[live, u], p1[live, u])
    hiu = np.maximum(p0[live, u], p1[live, u])
    ov = float(lov.min())
    span_v = float(hiv.max()) - ov
    h = max(float((hiv - lov).mean()), span_v * 2.0**-30)
    budget = _ENTRIES_PER_SEGMENT * len(live) + (1 << 20)
    while True:
        r0 = _floor_index(lov, ov, h)
        cnt = _floor_index(hiv, ov, h) - r0 + 1
        if int(cnt.sum()) <= budget or h >= span_v:
            break
        h *= 2.0
    rows = int((r0 + cnt).max())
    # Columns in u, as fine as the packing of (row, column, segment) into 63 bits allows.
    bits = max(1, (len(live) - 1).bit_length())
    col_bits = max(0, min(20, 63 - bits - max(1, rows.bit_length())))
    ncol = 1 << col_bits
    ou = float(min(lou.min(), q[:, u].min()))
    span_u = max(float(hiu.max()), float(q[:, u].max())) - ou
    hu = max(span_u / ncol * (1 + 2.0**-20), 2.0**-1070)
    rep = np.repeat(np.arange(len(live)), cnt)
    row = r0[rep] + (np.arange(len(rep)) - np.repeat(np.cumsum(cnt) - cnt, cnt))
    qrow = _floor_index(q[:, v], ov, h)
    qcol = np.clip(_floor_index(q[:, u], ou, hu), 0, ncol - 1)
    sides = []
    for side, far in ((1, hiu), (-1, lou)):
        col = np.clip(_floor_index(far, ou, hu), 0, ncol - 1)
        packed = np.sort((((row * ncol) + col[rep]) << bits) | rep)
        key = packed >> bits
        sseg = live[packed & ((1 << bits) - 1)]
        if side > 0:  # far end at or right of the query's column
            lo_key, hi_key = qrow * ncol + qcol, qrow * ncol + ncol
        else:  # far (left) end at or left of the query's column
            lo_key, hi_key = qrow * ncol, qrow * ncol + qcol + 1
        first = np.searchsorted(key, lo_key, side="left")
        count = np.searchsorted(key, hi_key, side="left") - first
        sides.append((side, (first, count, sseg)))
    return sides


# ---------------------------------------------------------------------------
# The parser
# ---------------------------------------------------------------------------


def parse_domain(geometry: Mapping, segments: Sequence | None = None) -> Domain:
    """Validate a GeoJSON Polygon / MultiPolygon and constraint polylines.

    Parameters
    ----------
    geometry : dict
        ``{"type": "Polygon", "coordinates": [outer, hole, ...]}`` or
        ``{"type": "MultiPolygon", "coordinates": [[outer, hole, ...], ...]}``;
        a ring is a list (or (k, 2) array) of ``[x, y]`` positions, closed
        (last equal to first) or not, in either orientation. Other members
        of the object (``bbox``, foreign members) are ignored. A read-only
        float64 array is used without a copy (the returned domain's
        ``points`` may then be a view of it); anything else is copied.
    segments : list of polylines, optional
        Interior constraints: each polyline a list of at least two ``[x, y]``
        positions; consecutive positions make the constraint segments.

    Returns
    -------
    Domain
        The validated domain (see :class:`Domain` for the layout).

    Raises
    ------
    InputError
        With the ``code`` and ``loc`` listed in the module documentation;
        the message names the ring (or constraint) and vertex, and for
        intersections both segments and the point where they meet.
        Intersection errors list up to 10 faults in ``errors``.

    Notes
    -----
    Checks run in this order, the first failing one raising: structure and
    numbers of the rings, then of the constraint polylines (with their
    sizes and duplicates); ring sizes, duplicates, collinear rings and
    spikes; intersections of all segments; hole containment and polygon
    overlap; constraints inside the domain. Decisions use
    :func:`~meshcore.geometry.predicates.orient2d` and exact comparisons
    only (module documentation, "Robustness").

    References
    ----------
    DESIGN.md "Domain input (2D)", "Errors"; methods text §9.1.1.
    """
    multi, polygons = _polygons(geometry)

    # -- rings: structure, numbers, closing position ---------------------
    rings: list[np.ndarray] = []
    ring_pos: list[tuple[int, int]] = []
    boxes: list[tuple] = []  # dropping a closing position leaves a ring's box as it is
    for p, poly in enumerate(polygons):
        for r, ring in enumerate(poly):
            loc = _ring_loc(multi, p, r)
            arr, box = _positions(ring, loc, _ring_name(multi, p, r))
            boxes.append(box)
            if len(arr) >= 2 and (arr[0] == arr[-1]).all():
                arr = arr[:-1]
            rings.append(arr)
            ring_pos.append((p, r))
    lines = _constraint_lines(segments)
    lengths = np.array([len(a) for a in rings], dtype=np.int64)
    names = _Names(multi, ring_pos, lengths)
    for k in np.flatnonzero(lengths < 3):
        raise InputError(
            f"{names.ring(k)} has {_distinct_small(rings[k])} distinct point(s); "
            "a ring needs at least 3",
            loc=names.ring_loc(k),
            code="too_few_points",
        )
    n_rings = len(rings)
    offsets = names.offsets
    pts = _read_only(rings[0] if n_rings == 1 else np.concatenate(rings))
    del rings
    nb = len(pts)

    # The box (from the checks' pass): the scales below and the diameter.
    lo_x, lo_y = (min(b[i] for b in boxes) for i in (0, 1))
    hi_x, hi_y = (max(b[i] for b in boxes) for i in (2, 3))
    big = max(-lo_x, -lo_y, hi_x, hi_y)
    low = _check_ring_points(pts, offsets, lengths, names, _power_of_two_scale(big=big))

    # -- constraints -----------------------------------------------------
    names.line_offsets = np.concatenate([[0], np.cumsum([len(x) - 1 for x in lines])]).astype(
        np.int64
    )

    # Everything below runs on coordinates scaled by a power of two.
    scale = _power_of_two_scale(*lines, big=big)

    # Merge constraint vertices with equal ring vertices / each other.
    cpoints, cseg, csrc = _merge_constraints(pts, lines)
    points = _read_only(np.concatenate([pts, cpoints])) if len(cpoints) else pts

    # -- pairwise intersections ------------------------------------------
    rows, capped = _intersections(points, scale, offsets, cseg)
    if len(rows):
        _raise_intersections(points, scale, cseg, rows, capped, names)

    # -- orientation (exact, at each ring's lexicographically lowest vertex)
    a = np.where(low > offsets[:-1], low - 1, offsets[1:] - 1)
    c = np.where(low < offsets[1:] - 1, low + 1, offsets[:-1])
    ccw = orient2d(pts[a] * scale, pts[low] * scale, pts[c] * scale) > 0
    ring_polygon = np.array([p for p, _ in ring_pos], dtype=np.int64)
    ring_is_hole = np.array([r > 0 for _, r in ring_pos], dtype=bool)
    reversed_ = ccw == ring_is_hole
    # Undo the scaling exactly: area * 2**(2 e) for scale = 2**-e.
    area = math.ldexp(_area(pts, scale, offsets, reversed_), -2 * math.frexp(scale)[1] + 2)
    diameter = math.hypot(hi_x - lo_x, hi_y - lo_y)
    # Frozen here so that Domain does not copy them: the index arrays are ours
    # (compiled ones too, whose base is numba's memory record, not None); the
    # points are read-only since the rings were joined.
    for arr in (cseg, csrc):
        arr.setflags(write=False)
    domain = Domain(
        points=points,
        ring_offsets=offsets,
        ring_polygon=ring_polygon,
        ring_is_hole=ring_is_hole,
        ring_reversed=reversed_,
        constraints=cseg,
        constraint_source=csrc,
        area=area,
        diameter=diameter,
        multi=multi,
    )

    # -- containment -----------------------------------------------------
    if n_rings > 1 or len(cseg):
        P = pts * scale
        _check_containment(
            P,
            domain.segments,
            np.repeat(np.arange(n_rings), lengths),
            offsets,
            ring_polygon,
            ring_is_hole,
            names,
            points * scale if len(cpoints) else P,
            cseg,
            nb,
            points,
        )
        del P

    # -- size ------------------------------------------------------------
    if diameter < MIN_DIAMETER:
        raise InputError(
            f"the domain spans only {diameter:.3g}, below {MIN_DIAMETER:g}: its area and the "
            "methods' squared lengths would underflow float64; scale it up",
            loc=("coordinates",),
            code="out_of_range",
        )
    return domain


def _distinct_small(arr: np.ndarray) -> int:
    return len({(float(x), float(y)) for x, y in arr})


def _check_ring_points(pts, offsets, lengths, names: _Names, scale: float) -> np.ndarray:
    """Distinct points, consecutive duplicates, collinear rings, spikes (turns
    on ``pts * scale``, ``scale`` from :func:`_power_of_two_scale`); returns
    each ring's lexicographically smallest vertex (its turn is the ring's
    orientation)."""
    n_rings = len(lengths)
    starts = offsets[:-1]
    ccount, turning, dup, spike, low = _ring_scan(pts, scale, offsets)
    distinct = np.maximum(ccount, 1)
    # Every consecutive triple collinear (and no repeats): the whole ring is on a line.
    flat = ~turning
    # Without consecutive repeats, 2 distinct points must alternate a, b, a, b (a flat ring).
    if (flat & (ccount >= 3)).any():
        ring_of = np.repeat(np.arange(n_rings), lengths)
        prev = np.arange(len(pts)) - 1
        prev[starts] = offsets[1:] - 1
        keep = (pts != pts[prev]).any(axis=1)
        cp = pts[keep]
        cr = ring_of[keep]
        coff = np.concatenate([[0], np.cumsum(ccount)])
        local = np.arange(len(cp)) - coff[cr]
        prev2 = coff[cr] + (local - 2) % ccount[cr]
        differs = (cp[:, 0] != cp[prev2, 0]) | (cp[:, 1] != cp[prev2, 1])
        alternating = (np.bincount(cr[differs], minlength=n_rings) == 0) & (ccount >= 3)
        distinct[alternating] = 2
    for k in np.flatnonzero(distinct < 3):
        raise InputError(
            f"{names.ring(k)} has {int(distinct[k])} distinct point(s); a ring needs at least 3",
            loc=names.ring_loc(k),
            code="too_few_points",
        )
    if dup >= 0:
        k = int(np.searchsorted(offsets, dup, side="right")) - 1
        v = dup - int(starts[k])
        if v == 0:  # the ring was closed, and its closing position was doubled
            v = int(lengths[k])
        raise InputError(
            f"{names.ring(k)}: vertex {v} repeats vertex {v - 1} at {_pt(*pts[dup])} "
            "(duplicate consecutive points)",
            loc=names.vertex_loc(k, v),
            code="duplicate_point",
        )
    for k in np.flatnonzero(flat):
        raise InputError(
            f"{names.ring(k)} has zero area: all its vertices are collinear",
            loc=names.ring_loc(k),
            code="zero_area",
        )
    if spike >= 0:
        k = int(np.searchsorted(offsets, spike, side="right")) - 1
        v = spike - int(starts[k])
        n = int(lengths[k])
        raise InputError(
            f"{names.ring(k)} intersects itself: it doubles back at vertex {v} "
            f"{_pt(*pts[spike])}: segment [vertex {(v - 1) % n} -> {v}] and segment "
            f"[vertex {v} -> {(v + 1) % n}] overlap",
            loc=names.vertex_loc(k, v),
            code="self_intersection",
        )
    return low


@njit(cache=True)
def _ring_scan(pts, scale, offsets):
    """The ring checks' facts in one compiled pass (turns on ``pts * scale``).

    Returns
    -------
    kept : (R,) int64
        Per ring, the vertices not equal to their previous one (cyclically).
    turning : (R,) bool
        Per ring, whether some vertex's turn (previous, vertex, next), the sign
        of :func:`~meshcore.geometry.predicates.orient2d_scalar`, is not zero
        (turns are taken until the first one that is, and where a spike may be).
    dup : int
        The first vertex equal to its previous one, or -1.
    spike : int
        The first vertex of zero turn where the ring doubles back over its
        previous segment (the coordinate differences along an axis the
        previous segment moves in change sign: exact), or -1.
    low : (R,) int64
        Per ring, its first lexicographically smallest (x, y) vertex.
    """
    kept = np.zeros(len(offsets) - 1, dtype=np.int64)
    turning = np.zeros(len(offsets) - 1, dtype=np.bool_)
    low = offsets[:-1].copy()
    dup = -1
    spike = -1
    for k in range(len(offsets) - 1):
        lo, hi = offsets[k], offsets[k + 1]
        # (a, i, c) = (previous, vertex, next), carried along: each point is read once.
        ax, ay, ix, iy = pts[hi - 1, 0], pts[hi - 1, 1], pts[lo, 0], pts[lo, 1]
        mx, my, m, nk, turns = ix, iy, lo, 0, False
        i = lo
        while i < hi:
            # The common vertex (no repeat, no turning back, the ring's turn known) in a
            # loop of its own: with the predicate's code beside it, it took 1.3 times as long.
            while i < hi:
                c = i + 1 if i < hi - 1 else lo
                cx, cy = pts[c, 0], pts[c, 1]
                same = ax == ix and ay == iy
                u, v, w = (ax, ix, cx) if ax != ix else (ay, iy, cy)
                back = (v > u) - (v < u) != (w > v) - (w < v)
                if (back and spike < 0) or not turns or (same and dup < 0):
                    break
                if ix < mx or (ix == mx and iy < my):
                    mx, my, m = ix, iy, i
                nk += not same
                ax, ay, ix, iy = ix, iy, cx, cy
                i += 1
            if i == hi:
                break
            if ix < mx or (ix == mx and iy < my):
                mx, my, m = ix, iy, i
            if same:
                if dup < 0:
                    dup = i
            else:
                nk += 1
            if (back and spike < 0) or not turns:
                t = orient2d_scalar(
                    ax * scale, ay * scale, ix * scale, iy * scale, cx * scale, cy * scale
                )
                turns = turns or t != 0
                if t == 0 and back and spike < 0:
                    spike = i
            ax, ay, ix, iy = ix, iy, cx, cy
            i += 1
        kept[k], turning[k], low[k] = nk, turns, m
    return kept, turning, dup, spike, low


@njit(cache=True)
def _oriented_segments(offsets, reversed_, segs):
    """Write ring edge v -> v + 1 (cyclically), flipped in the reversed rings, to row v
    of ``segs`` ((m, 2) int64)."""
    for k in range(len(offsets) - 1):
        lo, hi = offsets[k], offsets[k + 1]
        for i in range(lo, hi):
            j = i + 1 if i < hi - 1 else lo
            if reversed_[k]:
                segs[i, 0] = j
                segs[i, 1] = i
            else:
                segs[i, 0] = i
                segs[i, 1] = j


def _read_only(arr: np.ndarray) -> np.ndarray:
    """``arr`` as a read-only view, never a copy: the compiled checks then see one array
    type whether the rings came from lists (copied, writable) or from the service's
    read-only arrays (numba compiles a read-only array as another type)."""
    view = arr.view()
    view.setflags(write=False)
    return view


def _constraint_lines(segments) -> list[np.ndarray]:
    if segments is None:
        return []
    if not _is_seq(segments):
        raise InputError(
            "segments must be a list of polylines (lists of [x, y] positions)",
            loc=("segments",),
            code="bad_geometry",
        )
    lines = []
    for i, line in enumerate(segments):
        arr, _ = _positions(line, ("segments", i), f"constraint {i}")
        if len(arr) < 2:
            raise InputError(
                f"constraint {i} has {len(arr)} point(s); a polyline needs at least 2",
                loc=("segments", i),
                code="too_few_points",
            )
        dup = np.flatnonzero((arr[1:] == arr[:-1]).all(axis=1))
        if dup.size:
            j = int(dup[0]) + 1
            raise InputError(
                f"constraint {i}: vertex {j} repeats vertex {j - 1} at {_pt(*arr[j])} "
                "(duplicate consecutive points)",
                loc=("segments", i, j),
                code="duplicate_point",
            )
        lines.append(arr)
    return lines


def _complex_keys(p: np.ndarray) -> np.ndarray:
    k = np.empty(len(p), dtype=np.complex128)
    k.real = p[:, 0]
    k.imag = p[:, 1]
    return k


def _merge_constraints(pts: np.ndarray, lines: list[np.ndarray]):
    """Point indices of constraint vertices, equal positions sharing one index.

    A constraint vertex equal to a ring vertex takes that vertex's index;
    the others are new points, numbered in order of first appearance.

    Returns
    -------
    new_points : (q, 2) float64
    seg : (c, 2) int64
    source : (c, 2) int64
        (polyline, first vertex) per segment.
    """
    empty2 = np.zeros((0, 2), dtype=np.int64)
    if not lines:
        return np.zeros((0, 2)), empty2, empty2
    nb = len(pts)
    cp = np.concatenate(lines)
    ck = _complex_keys(cp)
    uk, inv = np.unique(ck, return_inverse=True)
    inv = inv.reshape(-1)
    # Ring vertices equal to a constraint vertex (the first such, in ring order).
    bk = _complex_keys(pts)
    pos = np.minimum(np.searchsorted(uk, bk), len(uk) - 1)
    match = np.flatnonzero(uk[pos] == bk)
    target = np.full(len(uk), nb, dtype=np.int64)
    np.minimum.at(target, pos[match], match)
    target[target == nb] = -1
    # New points in order of first appearance among the constraint vertices.
    first_seen = np.full(len(uk), len(cp), dtype=np.int64)
    np.minimum.at(first_seen, inv, np.arange(len(cp)))
    new = np.flatnonzero(target < 0)
    new = new[np.argsort(first_seen[new], kind="stable")]
    target[new] = nb + np.arange(len(new))
    g = target[inv]
    new_points = cp[first_seen[new]]
    sizes = np.array([len(line) for line in lines], dtype=np.int64)
    starts = np.cumsum(sizes) - sizes
    line = np.repeat(np.arange(len(lines)), sizes - 1)
    first = np.arange(len(line)) + line  # global index of each segment's first vertex
    seg = np.stack([g[first], g[first + 1]], axis=1)
    source = np.stack([line, first - starts[line]], axis=1)
    return new_points, seg, source


def _segment_points(s: int, cseg: np.ndarray, names: _Names) -> tuple[int, int]:
    """Point indices of global segment ``s`` (ring edges first, then constraints)."""
    nb = int(names.offsets[-1])
    if s >= nb:
        return int(cseg[s - nb, 0]), int(cseg[s - nb, 1])
    k = int(np.searchsorted(names.offsets, s, side="right")) - 1
    return s, (s + 1 if s + 1 < int(names.offsets[k + 1]) else int(names.offsets[k]))


def _raise_intersections(points, scale, cseg, rows, capped, names: _Names) -> None:
    """Raise the InputError for intersecting pairs (the first ones in segment order)."""
    errors = []
    for si, sj, kd, w in rows[:_MAX_LISTED].tolist():
        di, loc_i, oi = names.segment(si)
        dj, loc_j, oj = names.segment(sj)
        if kd == _CROSS:
            ends = [points[p] * scale for s in (si, sj) for p in _segment_points(s, cseg, names)]
            x, y = _crossing_point(*ends)
            where, verb = _pt(x / scale, y / scale), "cross"
        else:
            where, verb = _pt(*points[w]), "touch" if kd == _TOUCH else "overlap"
        owner = {o: names.ring(o) if o >= 0 else f"constraint {-1 - o}" for o in (oi, oj)}
        if oi >= 0 and oj >= 0:
            code = "self_intersection" if oi == oj else "ring_intersection"
            loc = loc_i
        else:
            code = "constraint_intersection"
            loc = loc_j if oi >= 0 else loc_i  # point at the constraint
        if oi == oj:
            head = f"{owner[oi]} intersects itself"
        else:
            head = f"{owner[oi]} and {owner[oj]} intersect"
        msg = f"{head}: {di} and {dj} {verb} at {where}"
        if code == "constraint_intersection":
            msg += " (segments may meet only at common vertices)"
        errors.append({"loc": list(loc), "msg": msg, "type": code})
    message = errors[0]["msg"]
    more = len(rows) - 1
    if more:
        message += f"; and {'at least ' if capped else ''}{more} more intersecting pair"
        message += "s" if more > 1 else ""
    raise InputError(message, code=errors[0]["type"], errors=errors)


def _check_containment(
    P, segs, ring_of, offsets, ring_polygon, ring_is_hole, names, PA, cseg, nb, points
) -> None:
    """Holes in their outer ring, polygons apart, constraints inside the domain.

    Rings are pairwise disjoint here, so one vertex decides where a whole
    ring lies; a point is in the domain iff an odd number of rings contain
    it (outer rings at even depth, holes at odd depth, once the first two
    checks pass).
    """
    n_rings = len(offsets) - 1
    starts = offsets[:-1]
    n_new = len(PA) - nb
    n_ring_queries = n_rings if n_rings > 1 else 0
    queries, skips = [], []
    if n_ring_queries:
        queries.append(P[starts])
        skips.append(np.arange(n_rings))
    if n_new:
        queries.append(PA[nb:])
        skips.append(np.full(n_new, -1))
    if queries:
        inside = ray_parity(
            np.concatenate(queries),
            np.concatenate(skips),
            P[segs[:, 0]],
            P[segs[:, 1]],
            ring_of,
            n_rings,
        )
    else:
        inside = np.zeros((0, 2), dtype=np.int64)
    if n_ring_queries:
        rr = inside[inside[:, 0] < n_rings]  # (ring, ring containing it)
        keys = rr[:, 0] * n_rings + rr[:, 1]
        holes = np.flatnonzero(ring_is_hole)
        outer_of = np.searchsorted(ring_polygon, ring_polygon, side="left")
        ok = np.isin(holes * n_rings + outer_of[holes], keys)
        if not ok.all():
            k = int(holes[~ok][0])
            o = int(outer_of[k])
            raise InputError(
                f"{names.ring(k)} is a hole outside its outer ring ({names.ring(o)}): "
                f"its vertex 0 {_pt(*points[starts[k]])} is not inside",
                loc=names.vertex_loc(k, 0),
                code="hole_outside",
            )
        both_holes = ring_is_hole[rr[:, 0]] & ring_is_hole[rr[:, 1]]
        nested = rr[both_holes & (ring_polygon[rr[:, 0]] == ring_polygon[rr[:, 1]])]
        if len(nested):
            k, h = (int(x) for x in nested[0])
            raise InputError(
                f"{names.ring(k)} is a hole inside another hole of its polygon, "
                f"{names.ring(h)}: its vertex 0 {_pt(*points[starts[k]])} is inside",
                loc=names.vertex_loc(k, 0),
                code="hole_outside",
            )
        # An outer ring inside another polygon's outer ring must be in one of its holes.
        outer_in = rr[~ring_is_hole[rr[:, 0]] & ~ring_is_hole[rr[:, 1]]]
        in_hole = rr[ring_is_hole[rr[:, 1]]]
        hole_keys = in_hole[:, 0] * n_rings + outer_of[in_hole[:, 1]]
        overlap = ~np.isin(outer_in[:, 0] * n_rings + outer_in[:, 1], hole_keys)
        if overlap.any():
            a, b = (int(x) for x in outer_in[overlap][0])
            raise InputError(
                f"polygon {int(ring_polygon[a])} lies inside polygon {int(ring_polygon[b])} "
                f"(its vertex 0 {_pt(*points[starts[a]])} is inside {names.ring(b)} and in "
                "none of its holes): the polygons of a MultiPolygon must not overlap",
                loc=names.vertex_loc(a, 0),
                code="polygon_overlap",
            )
    if not len(cseg):
        return
    bad_seg = np.zeros(len(cseg), dtype=bool)
    if n_new:
        # Constraint vertices off the boundary: inside iff contained in an odd number of rings.
        q_new = inside[inside[:, 0] >= n_ring_queries, 0] - n_ring_queries
        depth = np.bincount(q_new, minlength=n_new)
        is_out = np.zeros(len(PA), dtype=bool)
        is_out[nb:] = depth % 2 == 0
        bad_seg |= is_out[cseg[:, 0]] | is_out[cseg[:, 1]]
    # Segments joining two ring vertices: does the segment leave its first end into
    # the domain? (Its interior meets no other segment, so that decides.)
    both = np.flatnonzero((cseg[:, 0] < nb) & (cseg[:, 1] < nb))
    if both.size:
        a = cseg[both, 0]
        b = cseg[both, 1]
        succ = np.empty(nb, dtype=np.int64)
        succ[segs[:, 0]] = segs[:, 1]
        pred = np.empty(nb, dtype=np.int64)
        pred[segs[:, 1]] = segs[:, 0]
        pp, vv, nn, bb = P[pred[a]], P[a], P[succ[a]], P[b]
        corner = orient2d(pp, vv, nn)
        left_of_in = orient2d(pp, vv, bb) > 0
        left_of_out = orient2d(vv, nn, bb) > 0
        into = np.where(corner > 0, left_of_in & left_of_out, left_of_in | left_of_out)
        into = np.where(corner == 0, left_of_in, into)
        bad_seg[both[~into]] = True
    bad = np.flatnonzero(bad_seg)
    if bad.size:
        s = int(bad[0])
        desc, loc, _ = names.segment(nb + s)
        a, b = cseg[s]
        raise InputError(
            f"{desc} from {_pt(*points[a])} to {_pt(*points[b])} lies outside the domain",
            loc=loc,
            code="constraint_outside",
        )


def as_domain(domain) -> Domain:
    """``domain`` itself if it is a :class:`Domain`, else the GeoJSON mapping parsed."""
    if isinstance(domain, Domain):
        return domain
    if isinstance(domain, Mapping):
        return parse_domain(domain)
    raise InputError(
        "domain must be a Domain or a GeoJSON Polygon / MultiPolygon mapping",
        loc=("domain",),
        code="bad_geometry",
    )


def parse_size_field(size_field, dim: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """A size field's sample points and sizes, checked (the control space of Remark 8.10).

    Parameters
    ----------
    size_field : mapping, object or pair
        ``{"points": [[x, y], ...], "values": [h, ...]}``, an object with
        ``points`` and ``values``, or the pair itself.
    dim : int
        2 for planar points, 3 for points in space (``[x, y, z]``).

    Returns
    -------
    points : (k, dim) float64
    values : (k,) float64
        Finite, distinct points and finite sizes above 0.

    Raises
    ------
    InputError
        Located at the bad point or value (``bad_parameter``, ``non_finite``,
        ``out_of_range``, ``duplicate_points``).
    """
    if isinstance(size_field, Mapping):
        pts, vals = size_field.get("points"), size_field.get("values")
    elif hasattr(size_field, "points") and hasattr(size_field, "values"):
        pts, vals = size_field.points, size_field.values
    else:
        try:
            pts, vals = size_field
        except (TypeError, ValueError):
            raise InputError(
                "size_field must be {points, values} or the pair (points, values), "
                f"got {type(size_field).__name__}",
                loc=("size_field",),
                code="bad_parameter",
            ) from None
    for name, given in (("points", pts), ("values", vals)):
        if given is None:  # not "entry [] is not a number (None)"
            raise InputError(
                f"size_field needs its {name}", loc=("size_field", name), code="bad_parameter"
            )
    refuse_non_numbers(pts, ("size_field", "points"))
    refuse_non_numbers(vals, ("size_field", "values"))
    try:
        pts = np.asarray(pts, dtype=np.float64)
        vals = np.asarray(vals, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):  # OverflowError: an int beyond float64
        raise InputError(
            "size_field needs numeric points and values", loc=("size_field",), code="bad_parameter"
        ) from None
    if pts.ndim != 2 or pts.shape[1] != dim or len(pts) == 0:
        position = "[x, y]" if dim == 2 else "[x, y, z]"
        raise InputError(
            f"size_field.points must be a non-empty list of {position}, got shape {pts.shape}",
            loc=("size_field", "points"),
            code="bad_parameter",
        )
    if vals.shape != (len(pts),):
        raise InputError(
            f"size_field has {len(pts)} points but {vals.size} values",
            loc=("size_field", "values"),
            code="bad_parameter",
        )
    bad = np.flatnonzero(~np.isfinite(pts).all(axis=1))
    if bad.size:
        raise InputError(
            f"size_field point {bad[0]} is not finite",
            loc=("size_field", "points", int(bad[0])),
            code="non_finite",
        )
    # The domains' bound: beyond it distances overflow (a point at 1e308 has none to any
    # other, and the interpolation found no nearest point for it).
    bound = MAX_COORDINATE if dim == 2 else MAX_COORDINATE_3D
    bad = np.flatnonzero((np.abs(pts) > bound).any(axis=1))
    if bad.size:
        raise InputError(
            f"size_field point {bad[0]} has a coordinate of magnitude above {bound:g}",
            loc=("size_field", "points", int(bad[0])),
            code="out_of_range",
        )
    bad = np.flatnonzero(~(np.isfinite(vals) & (vals > 0)))
    if bad.size:
        raise InputError(
            f"size_field value {bad[0]} must be a finite number above 0, got {vals[bad[0]]}",
            loc=("size_field", "values", int(bad[0])),
            code="bad_parameter",
        )
    order = np.lexsort(pts.T[::-1])  # by x, then y (then z)
    same = np.flatnonzero((pts[order][1:] == pts[order][:-1]).all(axis=1))
    if same.size:
        i, j = sorted((int(order[same[0]]), int(order[same[0] + 1])))
        raise InputError(
            f"size_field points {i} and {j} coincide",
            loc=("size_field", "points", j),
            code="duplicate_points",
        )
    return pts, vals
