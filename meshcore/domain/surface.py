"""The 3D domain input: closed triangulated surfaces, validated and oriented.

A 3D domain is given as points and triangles (DESIGN.md, "Surface input
(3D)"): one or more closed shells, such as a body, cavities nested in it,
and several bodies side by side or nested in cavities. :func:`parse_surface`
checks it and returns a frozen :class:`Surface`: the triangles oriented
outward (normals leaving the material), the shells, their nesting, the
regions (connected bodies) they bound, and the enclosed volume. It is the
3D counterpart of :func:`meshcore.domain.planar.parse_domain`: the
boundary discretization 𝓕 (faces) and 𝓢 (their vertices) of §9.3, from
which Delaunay-admissible surfaces (§9.3.5), empty tetrahedralizations
(§9.5) and tetrahedral meshes start.

What is accepted
----------------
* ``points``: at least 4 rows ``[x, y, z]`` of finite numbers. Points no
  triangle uses are allowed and ignored (methods mesh the triangles'
  vertices only).
* ``triangles``: rows ``[i, j, k]`` of point indices. Their orientation is
  free but must be consistent within each shell (two triangles sharing an
  edge run through it in opposite directions); each shell is then turned
  so that its normals (right hand rule on ``i, j, k``) point out of the
  material: away from a body, into a cavity.
* Shells: the connected components of triangles across edges. They must be
  pairwise disjoint (no common point). A shell inside another is a cavity
  of it; a shell inside a cavity is a new body; and so on (nesting depth
  from exact ray parity, below).

What is rejected
----------------
Each rejection is an :class:`~meshcore.errors.InputError` whose ``code`` is
one of the following; ``loc`` is ``("points", v)`` or ``("points", v, c)``
for point ``v`` (coordinate ``c``), and ``("triangles", t)`` or
``("triangles", t, c)`` for triangle ``t`` (corner ``c``), indices of the
input. Faults that involve several triangles list one entry per triangle
(or per pair) in ``errors``, at most 10.

``bad_geometry``
    ``points`` not a list of ``[x, y, z]`` numbers, ``triangles`` not a list
    of three integer indices.
``too_few_points``, ``too_few_triangles``
    Fewer than 4 points; fewer than 4 triangles (no closed surface has fewer).
``non_finite``, ``out_of_range``
    NaN or infinite coordinates; magnitudes above ``1e150``.
``index_out_of_range``
    A triangle index below 0 or not below the number of points.
``degenerate_triangle``
    A triangle repeating an index or with exactly collinear corners.
``duplicate_triangle``
    Two triangles on the same three points (either orientation).
``open_edge``, ``nonmanifold_edge``
    An edge held by one triangle (a hole in the surface), or by more than
    two; the message names the edge's points and the triangles.
``inconsistent_orientation``
    Two triangles running through their common edge in the same direction
    (a shell that cannot be oriented as given, or a Moebius-like strip).
``nonmanifold_vertex``
    A vertex whose link (the edges opposite it in its triangles) is not a
    single cycle: two cones meeting at a point, two shells touching at it.
``self_intersection``, ``shell_intersection``
    Two triangles of one shell, or of two shells, meeting anywhere but in
    their common vertices or edge: crossing, touching, overlapping
    (coplanar), folded onto each other along a common edge. The message
    names both triangles and a point where they meet.

Robustness
----------
Every decision is a sign of
:func:`~meshcore.geometry.predicates3d.orient3d_scalar` /
:func:`~meshcore.geometry.predicates.orient2d_scalar` (the latter on the
projection of coplanar points onto a coordinate plane where their triangle
does not degenerate) or an exact comparison of coordinates; no tolerance
decides anything. The predicates see the coordinates scaled by a power of
two (exact), so the outcome does not change under translations and
power-of-two scalings that are exact in floating point, and the products
they form stay far from overflow. The crossing point in a message is a
construction (rounded).

Candidate triangle pairs come from a uniform grid over the triangles'
bounding boxes (cell size the median box extent, doubled while the
entries exceed a budget of 8 per triangle); a pair is tested only in the
cell holding the low corner of the intersection of the two boxes, so once.
A pair is rejected at once when one triangle lies strictly on one side of
the other's plane; otherwise every edge of each is tested against the
other triangle (for non-coplanar triangles their intersection is a
segment whose ends lie on such edges), and coplanar configurations by
exact 2D tests in the projection. The cost is linear in the number of
(triangle, cell) entries and same-cell pairs: about a second per million
triangles of an ordinary surface mesh.

Nesting: a vertex of each shell shoots a ray along +x, perturbed
symbolically to ``(y + ε, z + ε²)`` (Simulation of Simplicity) so that it
never meets an edge or vertex of another shell's projection; the parity of
the triangles it crosses says whether that shell contains it. The cost is
the number of shells times the number of triangles (bounding boxes
compared first), small unless there are thousands of shells.

Orientation: a shell at even depth (a body) gets a positive signed volume,
one at odd depth (a cavity) a negative one. The sign of a shell's volume
is decided by the float sum of its triangles' determinants when it
exceeds their rounding error bounds (Shewchuk's ``o3derrboundA`` per
term), else exactly with rationals (only for shells whose volume is
within rounding of zero: a very flat or very far shell).

References
----------
DESIGN.md "Surface input (3D)", "Errors", "Geometry robustness"; methods
text §9.3.1 (the face set 𝓕 and point set 𝓢), §9.3.5 (closed surface Σ).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from fractions import Fraction

import numpy as np
import scipy.sparse as sp
from numba import njit
from scipy.sparse.csgraph import connected_components

from meshcore.domain.numbers import is_number, refuse_non_numbers
from meshcore.errors import InputError
from meshcore.geometry.predicates import orient2d, orient2d_scalar
from meshcore.geometry.predicates3d import orient3d_scalar
from meshcore.geometry.tolerances import MAX_COORDINATE_3D, MIN_DIAMETER_3D

__all__ = ["Surface", "added_triangles_fit", "as_surface", "parse_surface", "shell_volume"]

# Candidate search: (triangle, cell) entries allowed per triangle before the grid coarsens.
_ENTRIES_PER_TRIANGLE = 8
# At most this many faults are listed in an error's ``errors``.
_MAX_LISTED = 10
# The intersection search stops after finding this many bad pairs.
_MAX_FOUND = 1 << 12
# Shewchuk's orient3d filter constant (the float determinant's error bound factor).
_O3D_ERRBOUND_A = (7.0 + 56.0 * 2.0**-53) * 2.0**-53


@dataclass(frozen=True, eq=False)
class Surface:
    """A validated closed surface: oriented triangles, shells, nesting, regions.

    Build it with :func:`parse_surface`. Triangle ``t`` is input triangle
    ``t``, its corners possibly reordered (columns 1 and 2 swapped where
    ``triangle_reversed[t]``) so that its normal ``(b - a) x (c - a)``
    points out of the material.

    Attributes
    ----------
    points : (n, 3) float64
        The input points, unchanged (unused ones included).
    triangles : (m, 3) int64
        The triangles, oriented outward.
    triangle_reversed : (m,) bool
        Whether the input triangle ran the other way.
    triangle_shell : (m,) int64
        The shell of each triangle. Shells are numbered by their first
        triangle in input order.
    shell_parent : (S,) int64
        The innermost shell containing each shell, -1 for none.
    shell_depth : (S,) int64
        The number of shells containing each shell: even for the outer
        boundary of a body, odd for a cavity.
    shell_region : (S,) int64
        The region (a connected body) each shell bounds: a body shell and
        the cavities directly inside it share one region. Regions are
        numbered by their outer shell.
    shell_volume : (S,) float64
        Signed volume enclosed by each shell: positive for bodies, negative
        for cavities (compensated sums of per-triangle determinants).
    volume : float
        Volume of the material: the sum of ``shell_volume``.
    diameter : float
        Diagonal of the bounding box of the triangles' vertices.

    References
    ----------
    DESIGN.md "Surface input (3D)"; methods text §9.3.1, §9.3.5.
    """

    points: np.ndarray
    triangles: np.ndarray
    triangle_reversed: np.ndarray
    triangle_shell: np.ndarray
    shell_parent: np.ndarray
    shell_depth: np.ndarray
    shell_region: np.ndarray
    shell_volume: np.ndarray
    volume: float
    diameter: float

    def __post_init__(self) -> None:
        dtypes = {
            "points": np.float64,
            "triangles": np.int64,
            "triangle_reversed": np.bool_,
            "triangle_shell": np.int64,
            "shell_parent": np.int64,
            "shell_depth": np.int64,
            "shell_region": np.int64,
            "shell_volume": np.float64,
        }
        for name, dtype in dtypes.items():
            arr = np.array(getattr(self, name), dtype=dtype)
            if name == "points":
                arr = arr.reshape(-1, 3)
            elif name == "triangles":
                arr = arr.reshape(-1, 3)
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        object.__setattr__(self, "volume", float(self.volume))
        object.__setattr__(self, "diameter", float(self.diameter))

    @property
    def shell_count(self) -> int:
        """Number of shells S."""
        return len(self.shell_parent)

    @property
    def region_count(self) -> int:
        """Number of regions (connected bodies)."""
        return int(self.shell_region.max()) + 1

    @property
    def triangle_region(self) -> np.ndarray:
        """(m,) int64: the region each triangle bounds."""
        return self.shell_region[self.triangle_shell]

    @property
    def region_volume(self) -> np.ndarray:
        """(R,) float64: the volume of each region (its shells' signed volumes summed)."""
        return np.bincount(
            self.shell_region, weights=self.shell_volume, minlength=self.region_count
        )

    @property
    def vertices(self) -> np.ndarray:
        """(k,) int64: the points the triangles use, sorted."""
        return np.unique(self.triangles)

    def edges(self) -> np.ndarray:
        """(e, 2) int64: the surface's edges, each once, ``[lo, hi]`` rows sorted."""
        t = self.triangles
        e = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
        e.sort(axis=1)
        return np.unique(e, axis=0)


# ---------------------------------------------------------------------------
# Parsing arrays
# ---------------------------------------------------------------------------


def _is_seq(value: object) -> bool:
    if isinstance(value, np.ndarray):
        return value.ndim >= 1
    return isinstance(value, Sequence) and not isinstance(value, str | bytes)


def _rows(value: object, name: str, what: str) -> np.ndarray:
    """A list of 3-rows as an array (any numeric dtype), or InputError at the bad row."""
    if not _is_seq(value):
        raise InputError(f"{name} must be a list of {what}", loc=(name,), code="bad_geometry")
    try:
        arr = np.asarray(value)
    except (ValueError, TypeError, OverflowError):
        arr = None
    if arr is not None and arr.ndim == 1 and arr.size == 0:
        return np.zeros((0, 3))
    if arr is not None and arr.dtype.kind in "iuf" and arr.ndim == 2 and arr.shape[1] == 3:
        if arr is not value:  # numpy reads [True, 1.5] as floats
            refuse_non_numbers(value, (name,), what=name, code="bad_geometry")
        return arr
    for v, row in enumerate(value):
        if not _is_seq(row) or len(row) != 3:
            got = f"{len(row)} values" if _is_seq(row) else type(row).__name__
            raise InputError(
                f"{name}: row {v} must be {what[:-1]}, got {got}",
                loc=(name, v),
                code="bad_geometry",
            )
        for c, x in enumerate(row):
            if not is_number(x):
                raise InputError(
                    f"{name}: row {v}, entry {c} is not a number ({x!r})",
                    loc=(name, v, c),
                    code="bad_geometry",
                )
    try:
        return np.asarray(value, dtype=np.float64)
    except OverflowError:
        return np.array([[float(x) if abs(x) < 2**1023 else np.inf for x in r] for r in value])


def _points(value: object) -> np.ndarray:
    arr = np.array(_rows(value, "points", "positions [x, y, z]"), dtype=np.float64)
    bad = ~np.isfinite(arr)
    if bad.any():
        v, c = (int(x) for x in np.argwhere(bad)[0])
        raise InputError(
            f"point {v} has a non-finite coordinate ({float(arr[v, c])!r})",
            loc=("points", v, c),
            code="non_finite",
        )
    big = np.abs(arr) > MAX_COORDINATE_3D
    if big.any():
        v, c = (int(x) for x in np.argwhere(big)[0])
        raise InputError(
            f"point {v} has a coordinate of magnitude above {MAX_COORDINATE_3D:g} "
            f"({float(arr[v, c])!r})",
            loc=("points", v, c),
            code="out_of_range",
        )
    if len(arr) < 4:
        raise InputError(
            f"a closed surface needs at least 4 points, got {len(arr)}",
            loc=("points",),
            code="too_few_points",
        )
    diameter = float(np.linalg.norm(arr.max(axis=0) - arr.min(axis=0)))
    if diameter < MIN_DIAMETER_3D:
        raise InputError(
            f"the surface spans only {diameter:.3g}, below {MIN_DIAMETER_3D:g}: its volumes and "
            "the methods' products of lengths would underflow float64; scale it up",
            loc=("points",),
            code="out_of_range",
        )
    return arr


def _triangles(value: object, n: int) -> np.ndarray:
    raw = _rows(value, "triangles", "triangles [i, j, k]")
    if raw.dtype.kind == "f":
        frac = ~np.isfinite(raw) | (raw != np.round(raw))
        if frac.any():
            t, c = (int(x) for x in np.argwhere(frac)[0])
            raise InputError(
                f"triangle {t}: index {c} is not an integer ({float(raw[t, c])!r})",
                loc=("triangles", t, c),
                code="bad_geometry",
            )
        out = np.where(np.abs(raw) < 2.0**62, raw, -1.0)
        tri = out.astype(np.int64)
    else:
        tri = np.array(raw, dtype=np.int64) if raw.dtype.kind != "u" else raw.astype(np.int64)
        if raw.dtype.kind == "u" and (raw > np.iinfo(np.int64).max).any():
            tri = np.where(raw > np.iinfo(np.int64).max, -1, tri)
    bad = (tri < 0) | (tri >= n)
    if bad.any():
        hits = np.argwhere(bad)
        errors = [
            {
                "loc": ["triangles", int(t), int(c)],
                "msg": f"triangle {int(t)}: index {int(c)} is {int(tri[t, c])}, "
                f"not a point index in [0, {n})",
                "type": "index_out_of_range",
            }
            for t, c in hits[:_MAX_LISTED]
        ]
        raise InputError(errors[0]["msg"], code="index_out_of_range", errors=errors)
    if len(tri) < 4:
        raise InputError(
            f"a closed surface needs at least 4 triangles, got {len(tri)}",
            loc=("triangles",),
            code="too_few_triangles",
        )
    return tri


def _pt(p) -> str:
    return "(" + ", ".join(repr(float(x)) for x in p) + ")"


def _power_of_two_scale(points: np.ndarray) -> float:
    """2**-e with e the exponent of the largest magnitude: scaled |coordinates| < 1."""
    big = float(np.abs(points).max()) if points.size else 0.0
    if big == 0.0:
        return 1.0
    return float(np.ldexp(1.0, -int(np.frexp(big)[1])))


def _listed(rows: list[tuple[tuple, str]], code: str, more: int = 0) -> InputError:
    errors = [{"loc": list(loc), "msg": msg, "type": code} for loc, msg in rows[:_MAX_LISTED]]
    message = errors[0]["msg"]
    if more > 0:
        message += f"; and {more} more"
    return InputError(message, code=code, errors=errors)


# ---------------------------------------------------------------------------
# Combinatorial checks
# ---------------------------------------------------------------------------


def _check_degenerate(PA: np.ndarray, tri: np.ndarray) -> None:
    """Repeated indices and exactly collinear corners (all three projections flat)."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    repeated = (a == b) | (b == c) | (c == a)
    flat = repeated.copy()
    rest = np.flatnonzero(~repeated)
    if rest.size:
        pa, pb, pc = PA[a[rest]], PA[b[rest]], PA[c[rest]]
        zero = np.ones(rest.size, dtype=bool)
        for u, v in ((0, 1), (1, 2), (2, 0)):
            zero &= orient2d(pa[:, [u, v]], pb[:, [u, v]], pc[:, [u, v]]) == 0
        flat[rest] = zero
    bad = np.flatnonzero(flat)
    if bad.size:
        rows = []
        for t in bad[:_MAX_LISTED].tolist():
            i, j, k = tri[t].tolist()
            why = "repeats a point" if repeated[t] else "has collinear corners"
            rows.append((("triangles", t), f"triangle {t} [{i}, {j}, {k}] is degenerate: it {why}"))
        raise _listed(rows, "degenerate_triangle", len(bad) - len(rows))


def _keys3(rows: np.ndarray, n: int) -> np.ndarray:
    """An int64 key per sorted row of 3 indices below n (unique per row set)."""
    s = np.sort(rows, axis=1)
    if n <= 1 << 21:
        return (s[:, 0] << 42) | (s[:, 1] << 21) | s[:, 2]
    _, inv = np.unique(s, axis=0, return_inverse=True)
    return inv.reshape(-1).astype(np.int64)


def _check_duplicates(tri: np.ndarray, n: int) -> None:
    key = _keys3(tri, n)
    order = np.argsort(key, kind="stable")
    ks = key[order]
    dup = np.flatnonzero(ks[1:] == ks[:-1])
    if dup.size:
        rows = []
        for d in dup[:_MAX_LISTED].tolist():
            first, second = sorted((int(order[d]), int(order[d + 1])))
            rows.append(
                (
                    ("triangles", second),
                    f"triangle {second} {tri[second].tolist()} duplicates triangle {first} "
                    f"{tri[first].tolist()} (the same three points)",
                )
            )
        raise _listed(rows, "duplicate_triangle", len(dup) - len(rows))


def _half_edges(tri: np.ndarray, n: int):
    """Half-edge h = 3 t + k runs from tri[t, k] to tri[t, (k + 1) % 3].

    Returns the twin of every half-edge (the other half-edge on the same
    edge), after checking that every edge has exactly two half-edges and
    that they run in opposite directions.
    """
    m = len(tri)
    src = tri.reshape(-1)
    dst = tri[:, [1, 2, 0]].reshape(-1)
    lo = np.minimum(src, dst)
    hi = np.maximum(src, dst)
    key = lo * n + hi
    order = np.argsort(key, kind="stable")
    ks = key[order]
    starts = np.flatnonzero(np.concatenate([[True], ks[1:] != ks[:-1]]))
    counts = np.diff(np.concatenate([starts, [3 * m]]))
    bad = np.flatnonzero(counts != 2)
    if bad.size:
        first_bad = counts[bad[0]]
        code = "open_edge" if first_bad == 1 else "nonmanifold_edge"
        sel = bad[counts[bad] == first_bad]
        rows = []
        for g in sel[:_MAX_LISTED].tolist():
            hs = order[starts[g] : starts[g] + counts[g]]
            ts = sorted({int(h) // 3 for h in hs})
            i, j = int(lo[hs[0]]), int(hi[hs[0]])
            held = f"{len(hs)} triangle" + ("s" if len(hs) > 1 else "")
            names = ", ".join(str(t) for t in ts)
            what = "an open edge: the surface is not closed" if first_bad == 1 else "non-manifold"
            rows.append(
                (
                    ("triangles", ts[0]),
                    f"edge ({i}, {j}) is held by {held} ({names}), not 2: {what}",
                )
            )
        raise _listed(rows, code, len(sel) - len(rows))
    h0 = order[starts]
    h1 = order[starts + 1]
    same = np.flatnonzero(src[h0] == src[h1])
    if same.size:
        rows = []
        for g in same[:_MAX_LISTED].tolist():
            t0, t1 = sorted((int(h0[g]) // 3, int(h1[g]) // 3))
            i, j = int(src[h0[g]]), int(dst[h0[g]])
            rows.append(
                (
                    ("triangles", t1),
                    f"triangles {t0} and {t1} both run through edge ({i} -> {j}) in the same "
                    "direction: inconsistent orientation",
                )
            )
        raise _listed(rows, "inconsistent_orientation", len(same) - len(rows))
    twin = np.empty(3 * m, dtype=np.int64)
    twin[h0] = h1
    twin[h1] = h0
    return twin


def _check_vertices(tri: np.ndarray, twin: np.ndarray) -> None:
    """Each used vertex's fan of triangles is one cycle (its link is one loop).

    Corner 3 t + k (triangle t at vertex tri[t, k]) is followed, around its
    vertex, by the corner of the triangle across the outgoing half-edge
    3 t + k; that map is a permutation whose cycles are the vertex's fans.
    """
    m = len(tri)
    h = np.arange(3 * m)
    t2 = twin // 3
    k2 = twin % 3
    nxt = 3 * t2 + (k2 + 1) % 3
    graph = sp.csr_matrix((np.ones(3 * m, dtype=np.int8), (h, nxt)), shape=(3 * m, 3 * m))
    _, label = connected_components(graph, directed=True, connection="weak")
    vert = tri.reshape(-1)
    pairs = np.unique(vert.astype(np.int64) * (3 * m) + label)
    v_of = pairs // (3 * m)
    bad_v = np.unique(v_of[1:][v_of[1:] == v_of[:-1]])
    if bad_v.size:
        rows = []
        for v in bad_v[:_MAX_LISTED].tolist():
            fans = len(np.unique(label[vert == v]))
            rows.append(
                (
                    ("points", v),
                    f"point {v} is a non-manifold vertex: its triangles form {fans} separate "
                    "fans (its link is not one cycle)",
                )
            )
        raise _listed(rows, "nonmanifold_vertex", len(bad_v) - len(rows))


def _shells(tri: np.ndarray, twin: np.ndarray) -> tuple[np.ndarray, int]:
    """Triangle components across edges, numbered by first triangle."""
    m = len(tri)
    a = np.arange(3 * m) // 3
    b = twin // 3
    graph = sp.csr_matrix((np.ones(3 * m, dtype=np.int8), (a, b)), shape=(m, m))
    count, label = connected_components(graph, directed=False)
    first = np.full(count, m, dtype=np.int64)
    np.minimum.at(first, label, np.arange(m))
    rank = np.empty(count, dtype=np.int64)
    rank[np.argsort(first)] = np.arange(count)
    return rank[label], int(count)


# ---------------------------------------------------------------------------
# Exact triangle-triangle intersection (compiled)
# ---------------------------------------------------------------------------


@njit(cache=True, inline="always")
def _o3(P, a, b, c, d):
    if d == a or d == b or d == c or a == b or b == c or c == a:
        return 0  # a repeated point: exactly zero, no need for the exact stage
    for k in range(3):
        if P[a, k] == P[d, k] and P[b, k] == P[d, k] and P[c, k] == P[d, k]:
            return 0  # all four in one axis-parallel plane (flat CAD faces): exactly zero
    return orient3d_scalar(
        P[a, 0], P[a, 1], P[a, 2], P[b, 0], P[b, 1], P[b, 2],
        P[c, 0], P[c, 1], P[c, 2], P[d, 0], P[d, 1], P[d, 2],
    )  # fmt: skip


@njit(cache=True, inline="always")
def _o2(P, ax, a, b, c):
    """orient2d of a, b, c projected along axis ``ax`` (onto the other two, cyclically)."""
    u = (ax + 1) % 3
    v = (ax + 2) % 3
    return orient2d_scalar(P[a, u], P[a, v], P[b, u], P[b, v], P[c, u], P[c, v])


@njit(cache=True)
def _flat_axis(P, a, b, c):
    """An axis along which triangle abc projects to a non-degenerate triangle."""
    for ax in range(3):
        if _o2(P, ax, a, b, c) != 0:
            return ax
    return -1


@njit(cache=True)
def _seg_seg_2d(P, ax, p, q, e0, e1, w):
    """Coplanar segments pq and e0e1 meeting other than at a common vertex index.

    Writes a meeting point into ``w`` (a construction) and returns True if so.
    """
    o1 = _o2(P, ax, p, q, e0)
    o2 = _o2(P, ax, p, q, e1)
    if o1 * o2 > 0:
        return False
    o3 = _o2(P, ax, e0, e1, p)
    o4 = _o2(P, ax, e0, e1, q)
    if o3 * o4 > 0:
        return False
    shared = p == e0 or p == e1 or q == e0 or q == e1
    if o1 == 0 and o2 == 0:
        # Collinear: compare extents along an axis where p and q differ.
        k = 0
        while P[p, k] == P[q, k]:
            k += 1
        lo = max(min(P[p, k], P[q, k]), min(P[e0, k], P[e1, k]))
        hi = min(max(P[p, k], P[q, k]), max(P[e0, k], P[e1, k]))
        if lo > hi or (lo == hi and shared):
            return False
        # A point of the overlap: the endpoint of either segment inside the other.
        for r in (e0, e1, p, q):
            if lo <= P[r, k] <= hi:
                for i in range(3):
                    w[i] = P[r, i]
                return True
        return True
    if shared:
        return False  # two non-collinear segments from one vertex meet only there
    # One point: a proper crossing or an endpoint on the other segment.
    if o1 == 0:
        r = e0
    elif o2 == 0:
        r = e1
    elif o3 == 0:
        r = p
    elif o4 == 0:
        r = q
    else:
        r = -1
    if r >= 0:
        for i in range(3):
            w[i] = P[r, i]
    else:
        _line_point(P, p, q, e0, e1, ax, w)
    return True


@njit(cache=True)
def _line_point(P, p, q, e0, e1, ax, w):
    """Where line pq meets line e0e1 in the projection along ``ax`` (rounded), lifted."""
    u = (ax + 1) % 3
    v = (ax + 2) % 3
    rx = P[q, u] - P[p, u]
    ry = P[q, v] - P[p, v]
    sx = P[e1, u] - P[e0, u]
    sy = P[e1, v] - P[e0, v]
    den = rx * sy - ry * sx
    t = 0.5
    if den != 0.0:
        t = ((P[e0, u] - P[p, u]) * sy - (P[e0, v] - P[p, v]) * sx) / den
    for i in range(3):
        w[i] = P[p, i] + t * (P[q, i] - P[p, i])


@njit(cache=True)
def _in_open_triangle_2d(P, ax, a, b, c, p):
    s = _o2(P, ax, a, b, c)
    return _o2(P, ax, a, b, p) == s and _o2(P, ax, b, c, p) == s and _o2(P, ax, c, a, p) == s


@njit(cache=True)
def _seg_tri(P, p, q, a, b, c, w):
    """Segment pq meets triangle abc other than at their common vertex indices.

    Writes a meeting point into ``w`` (a construction) and returns True if so.
    """
    op = _o3(P, a, b, c, p)
    oq = _o3(P, a, b, c, q)
    if op * oq > 0:
        return False
    if op == 0 and oq == 0:
        ax = _flat_axis(P, a, b, c)
        for e0, e1 in ((a, b), (b, c), (c, a)):
            if _seg_seg_2d(P, ax, p, q, e0, e1, w):
                return True
        for r in (p, q):
            if r != a and r != b and r != c and _in_open_triangle_2d(P, ax, a, b, c, r):
                for i in range(3):
                    w[i] = P[r, i]
                return True
        return False
    if op == 0 and (p == a or p == b or p == c):
        return False
    if oq == 0 and (q == a or q == b or q == c):
        return False
    s1 = _o3(P, p, q, a, b)
    s2 = _o3(P, p, q, b, c)
    s3 = _o3(P, p, q, c, a)
    if (s1 > 0 or s2 > 0 or s3 > 0) and (s1 < 0 or s2 < 0 or s3 < 0):
        return False
    # The crossing point with the plane (rounded).
    if op == 0:
        t = 0.0
    elif oq == 0:
        t = 1.0
    else:
        nx = (P[b, 1] - P[a, 1]) * (P[c, 2] - P[a, 2]) - (P[b, 2] - P[a, 2]) * (P[c, 1] - P[a, 1])
        ny = (P[b, 2] - P[a, 2]) * (P[c, 0] - P[a, 0]) - (P[b, 0] - P[a, 0]) * (P[c, 2] - P[a, 2])
        nz = (P[b, 0] - P[a, 0]) * (P[c, 1] - P[a, 1]) - (P[b, 1] - P[a, 1]) * (P[c, 0] - P[a, 0])
        dp = nx * (P[p, 0] - P[a, 0]) + ny * (P[p, 1] - P[a, 1]) + nz * (P[p, 2] - P[a, 2])
        dq = nx * (P[q, 0] - P[a, 0]) + ny * (P[q, 1] - P[a, 1]) + nz * (P[q, 2] - P[a, 2])
        t = dp / (dp - dq) if dp != dq else 0.5
        t = min(max(t, 0.0), 1.0)
    for i in range(3):
        w[i] = P[p, i] + t * (P[q, i] - P[p, i])
    return True


@njit(cache=True, inline="always")
def _one_side(s0, s1, s2, p0, p1, p2, a, b, c):
    """Signs s of p0, p1, p2 against plane abc: all on one side, zeros only at a, b or c."""
    if (s0 > 0 or s1 > 0 or s2 > 0) and (s0 < 0 or s1 < 0 or s2 < 0):
        return False
    for s, p in ((s0, p0), (s1, p1), (s2, p2)):
        if s == 0 and p != a and p != b and p != c:
            return False
    return not (s0 == 0 and s1 == 0 and s2 == 0)


@njit(cache=True)
def _tri_tri(P, T, i, j, w):
    """Triangles i and j meet other than in their common vertices or edge.

    Returns 0 (they do not) or 1, with a meeting point in ``w``.
    """
    a0, a1, a2 = T[i, 0], T[i, 1], T[i, 2]
    b0, b1, b2 = T[j, 0], T[j, 1], T[j, 2]
    ia = (a0, a1, a2)
    ib = (b0, b1, b2)
    shared = 0
    for x in ia:
        if x == b0 or x == b1 or x == b2:
            shared += 1
    if shared == 2:
        # A common edge uv: they meet beyond it only if folded onto each other.
        ka = 0
        while ia[ka] == b0 or ia[ka] == b1 or ia[ka] == b2:
            ka += 1
        kb = 0
        while ib[kb] == a0 or ib[kb] == a1 or ib[kb] == a2:
            kb += 1
        x = ia[ka]
        d = ib[kb]
        u = ia[(ka + 1) % 3]
        v = ia[(ka + 2) % 3]
        if _o3(P, u, v, x, d) != 0:
            return 0
        ax = _flat_axis(P, u, v, x)
        if _o2(P, ax, u, v, x) * _o2(P, ax, u, v, d) > 0:
            for k in range(3):
                w[k] = (P[u, k] + P[v, k] + P[x, k] + P[d, k]) * 0.25
            return 1
        return 0
    # One on one side of the other's plane, touching it at most in the common
    # vertex: they meet at most there.
    s0 = _o3(P, a0, a1, a2, b0)
    s1 = _o3(P, a0, a1, a2, b1)
    s2 = _o3(P, a0, a1, a2, b2)
    if _one_side(s0, s1, s2, b0, b1, b2, a0, a1, a2):
        return 0
    if s0 == 0 and s1 == 0 and s2 == 0:
        # Coplanar: edges against edges, then vertices strictly inside the other.
        ax = _flat_axis(P, a0, a1, a2)
        for p, q in ((a0, a1), (a1, a2), (a2, a0)):
            for e0, e1 in ((b0, b1), (b1, b2), (b2, b0)):
                if _seg_seg_2d(P, ax, p, q, e0, e1, w):
                    return 1
        for r in ia:
            if r != b0 and r != b1 and r != b2 and _in_open_triangle_2d(P, ax, b0, b1, b2, r):
                for k in range(3):
                    w[k] = P[r, k]
                return 1
        for r in ib:
            if r != a0 and r != a1 and r != a2 and _in_open_triangle_2d(P, ax, a0, a1, a2, r):
                for k in range(3):
                    w[k] = P[r, k]
                return 1
        return 0
    r0 = _o3(P, b0, b1, b2, a0)
    r1 = _o3(P, b0, b1, b2, a1)
    r2 = _o3(P, b0, b1, b2, a2)
    if _one_side(r0, r1, r2, a0, a1, a2, b0, b1, b2):
        return 0
    for p, q in ((a0, a1), (a1, a2), (a2, a0)):
        if _seg_tri(P, p, q, b0, b1, b2, w):
            return 1
    for p, q in ((b0, b1), (b1, b2), (b2, b0)):
        if _seg_tri(P, p, q, a0, a1, a2, w):
            return 1
    return 0


@njit(cache=True)
def _grid_cells(lo, hi, origin, h, dims, fill, key, tri):
    """Count (``fill`` False) or write the (cell, triangle) entries of the grid.

    Each triangle is entered in every cell its bounding box meets; cell
    indices are ``floor((x - origin) / h)``, the same monotone expression
    for every triangle, so two boxes sharing a point share a cell.
    """
    total = 0
    for t in range(len(lo)):
        c0 = np.empty(3, np.int64)
        c1 = np.empty(3, np.int64)
        for k in range(3):
            c0[k] = np.int64(np.floor((lo[t, k] - origin[k]) / h))
            c1[k] = np.int64(np.floor((hi[t, k] - origin[k]) / h))
        for x in range(c0[0], c1[0] + 1):
            for y in range(c0[1], c1[1] + 1):
                for z in range(c0[2], c1[2] + 1):
                    if fill:
                        key[total] = (x * dims[1] + y) * dims[2] + z
                        tri[total] = t
                    total += 1
    return total


@njit(cache=True)
def _scan_cells(key, tri, P, T, lo, hi, origin, h, dims, hashed, room, cap):
    """Test every pair of triangles sharing a grid cell; collect the bad ones.

    A compiled loop over the pairs of each cell. A pair is skipped when
    its bounding boxes are disjoint (exact comparisons), and in every cell
    but the one holding the low corner of their boxes' intersection, so it
    is tested once. Returns rows ``(i, j)`` (i < j), their meeting points,
    the row count, and whether ``cap`` was reached (the scan then stops).
    """
    out = np.empty((cap, 2), dtype=np.int64)
    wit = np.empty((cap, 3))
    w = np.empty(3)
    nout = 0
    n = len(key)
    start = 0
    while start < n:
        stop = start + 1
        while stop < n and key[stop] == key[start]:
            stop += 1
        for p in range(start, stop - 1):
            if p > start and tri[p] == tri[p - 1]:
                continue
            for q in range(p + 1, stop):
                if tri[q] == tri[q - 1]:
                    continue
                i = min(tri[p], tri[q])
                j = max(tri[p], tri[q])
                disjoint = False
                for k in range(3):
                    if lo[i, k] > hi[j, k] or lo[j, k] > hi[i, k]:
                        disjoint = True
                if disjoint:
                    continue
                cell = np.int64(0)
                for k in range(3):
                    ck = np.int64(np.floor((max(lo[i, k], lo[j, k]) - origin[k]) / h))
                    cell = cell * dims[k] + ck
                if hashed:
                    mixed = np.uint64(cell) * np.uint64(0x9E3779B97F4A7C15)
                    cell = np.int64(mixed >> np.uint64(64 - room))
                if cell != key[start]:
                    continue
                if _tri_tri(P, T, i, j, w):
                    out[nout, 0] = i
                    out[nout, 1] = j
                    for k in range(3):
                        wit[nout, k] = w[k]
                    nout += 1
                    if nout == cap:
                        return out, wit, nout, True
        start = stop
    return out, wit, nout, False


def _intersections(PA: np.ndarray, tri: np.ndarray, first: int = 0):
    """Every pair of triangles meeting other than in common vertices or a common edge.

    Only pairs with a triangle numbered ``first`` or later are tested (the
    grid cells without such a triangle are dropped). Returns rows ``(i, j)``
    sorted, their meeting points (scaled coordinates) and whether the search
    stopped at ``_MAX_FOUND``.
    """
    m = len(tri)
    corners = PA[tri]  # (m, 3, 3)
    lo = np.ascontiguousarray(corners.min(axis=1))
    hi = np.ascontiguousarray(corners.max(axis=1))
    origin = lo.min(axis=0)
    top = hi.max(axis=0)
    span = float((top - origin).max())
    extent = (hi - lo).max(axis=1)
    h = max(float(np.median(extent)), span * 2.0**-20, 1e-300)
    budget = _ENTRIES_PER_TRIANGLE * m + (1 << 16)
    dummy = np.zeros(0, dtype=np.int64)
    while True:
        dims = (np.floor((top - origin) / h).astype(np.int64) + 1).astype(np.int64)
        total = _grid_cells(lo, hi, origin, h, dims, False, dummy, dummy)
        if total <= budget or h >= span:
            break
        h *= 2.0
    key = np.empty(total, dtype=np.int64)
    cell_tri = np.empty(total, dtype=np.int64)
    _grid_cells(lo, hi, origin, h, dims, True, key, cell_tri)
    bits = max(1, (m - 1).bit_length())
    room = 63 - bits
    ncells = int(dims[0]) * int(dims[1]) * int(dims[2])
    hashed = ncells > (1 << room)
    if hashed:
        mixed = key.astype(np.uint64) * np.uint64(0x9E3779B97F4A7C15)
        key = (mixed >> np.uint64(64 - room)).astype(np.int64)
    packed = np.sort((key << bits) | cell_tri)
    key = packed >> bits
    cell_tri = packed & ((1 << bits) - 1)
    if first > 0:
        # a pair is tested in the cell of the low corner of its boxes' meet, which holds both
        keep = np.isin(key, key[cell_tri >= first])
        key, cell_tri = key[keep], cell_tri[keep]
    out, wit, count, capped = _scan_cells(
        key, cell_tri, PA, tri, lo, hi, origin, h, dims, hashed, room, _MAX_FOUND
    )
    rows, wit = out[:count], wit[:count]
    order = np.lexsort((rows[:, 1], rows[:, 0]))
    return rows[order], wit[order], bool(capped)


def _raise_intersections(tri, shell, rows, wit, scale, capped) -> None:
    listed = []
    code = None
    for (i, j), w in zip(rows[:_MAX_LISTED].tolist(), wit[:_MAX_LISTED], strict=True):
        same = shell[i] == shell[j]
        kind = "self_intersection" if same else "shell_intersection"
        code = code or kind
        where = _pt(w / scale)
        msg = (
            f"triangles {i} {tri[i].tolist()} and {j} {tri[j].tolist()} intersect at {where}"
            + ("" if same else f" (shells {int(shell[i])} and {int(shell[j])})")
            + "; triangles may meet only in common vertices or a common edge"
        )
        listed.append({"loc": ["triangles", j], "msg": msg, "type": kind})
    message = listed[0]["msg"]
    more = len(rows) - 1
    if more:
        message += f"; and {'at least ' if capped else ''}{more} more intersecting pair"
        message += "s" if more > 1 else ""
    raise InputError(message, code=code, errors=listed)


# ---------------------------------------------------------------------------
# Nesting by exact ray parity
# ---------------------------------------------------------------------------


@njit(cache=True, inline="always")
def _perturbed_side(P, a, b, q):
    """Sign of orient2d(a, b, q') in the (y, z) plane, q' = q + (ε, ε²) symbolically."""
    s = orient2d_scalar(P[a, 1], P[a, 2], P[b, 1], P[b, 2], P[q, 1], P[q, 2])
    if s != 0:
        return s
    dv = P[a, 2] - P[b, 2]  # d/d(q_y) of the determinant
    if dv != 0.0:
        return 1 if dv > 0 else -1
    du = P[b, 1] - P[a, 1]  # d/d(q_z)
    if du != 0.0:
        return 1 if du > 0 else -1
    return 0


@njit(cache=True)
def _ray_counts(P, T, tshell, queries, qshell, n_shells):
    """(k, S) crossing parities of the +x rays from ``queries`` with each shell.

    A triangle is crossed when the perturbed query projects strictly inside
    its (y, z) projection and the triangle's plane lies at larger x
    (``orient3d(a, b, c, q)`` with the sign of the projected orientation).
    A sequential compiled loop over queries and triangles.
    """
    k = len(queries)
    out = np.zeros((k, n_shells), dtype=np.int8)
    ylo = np.minimum(np.minimum(P[T[:, 0], 1], P[T[:, 1], 1]), P[T[:, 2], 1])
    yhi = np.maximum(np.maximum(P[T[:, 0], 1], P[T[:, 1], 1]), P[T[:, 2], 1])
    zlo = np.minimum(np.minimum(P[T[:, 0], 2], P[T[:, 1], 2]), P[T[:, 2], 2])
    zhi = np.maximum(np.maximum(P[T[:, 0], 2], P[T[:, 1], 2]), P[T[:, 2], 2])
    xhi = np.maximum(np.maximum(P[T[:, 0], 0], P[T[:, 1], 0]), P[T[:, 2], 0])
    for r in range(k):
        q = queries[r]
        qy, qz, qx = P[q, 1], P[q, 2], P[q, 0]
        for t in range(len(T)):
            if tshell[t] == qshell[r]:
                continue
            if qy < ylo[t] or qy > yhi[t] or qz < zlo[t] or qz > zhi[t] or qx > xhi[t]:
                continue
            a, b, c = T[t, 0], T[t, 1], T[t, 2]
            s = orient2d_scalar(P[a, 1], P[a, 2], P[b, 1], P[b, 2], P[c, 1], P[c, 2])
            if s == 0:
                continue  # projects to a segment: the perturbed ray misses it
            if _perturbed_side(P, a, b, q) != s:
                continue
            if _perturbed_side(P, b, c, q) != s:
                continue
            if _perturbed_side(P, c, a, q) != s:
                continue
            if _o3(P, a, b, c, q) * s > 0:
                out[r, tshell[t]] ^= 1
    return out


# ---------------------------------------------------------------------------
# Volumes and orientation
# ---------------------------------------------------------------------------


def _dets(PA: np.ndarray, tri: np.ndarray, ref: np.ndarray):
    """Per triangle: det[a - r, b - r, c - r] (6 x signed volume) and its error bound."""
    a = PA[tri[:, 0]] - ref
    b = PA[tri[:, 1]] - ref
    c = PA[tri[:, 2]] - ref
    bxcy = b[:, 0] * c[:, 1]
    cxby = c[:, 0] * b[:, 1]
    cxay = c[:, 0] * a[:, 1]
    axcy = a[:, 0] * c[:, 1]
    axby = a[:, 0] * b[:, 1]
    bxay = b[:, 0] * a[:, 1]
    det = a[:, 2] * (bxcy - cxby) + b[:, 2] * (cxay - axcy) + c[:, 2] * (axby - bxay)
    perm = (
        (np.abs(bxcy) + np.abs(cxby)) * np.abs(a[:, 2])
        + (np.abs(cxay) + np.abs(axcy)) * np.abs(b[:, 2])
        + (np.abs(axby) + np.abs(bxay)) * np.abs(c[:, 2])
    )
    return det, _O3D_ERRBOUND_A * perm


def _exact_volume_sign(PA: np.ndarray, tri: np.ndarray) -> int:
    """Sign of a shell's volume with rationals (only for volumes within rounding of 0)."""
    total = Fraction(0)
    F = [[Fraction(float(x)) for x in row] for row in PA[np.unique(tri)]]
    index = {int(v): i for i, v in enumerate(np.unique(tri).tolist())}
    for i, j, k in tri.tolist():
        a, b, c = F[index[i]], F[index[j]], F[index[k]]
        total += (
            a[0] * (b[1] * c[2] - b[2] * c[1])
            - a[1] * (b[0] * c[2] - b[2] * c[0])
            + a[2] * (b[0] * c[1] - b[1] * c[0])
        )
    return (total > 0) - (total < 0)


def _shell_volumes(P, PA, tri, shell, n_shells, ref_vertex):
    """Signed volume of each shell (compensated sum) and its exact sign."""
    det_s, err = _dets(PA, tri, PA[ref_vertex[shell]])
    det_u, _ = _dets(P, tri, P[ref_vertex[shell]])
    order = np.argsort(shell, kind="stable")
    bounds = np.searchsorted(shell[order], np.arange(n_shells + 1))
    volume = np.empty(n_shells)
    sign = np.empty(n_shells, dtype=np.int64)
    for s in range(n_shells):  # a loop over shells, each sum vectorized
        rows = order[bounds[s] : bounds[s + 1]]
        volume[s] = math.fsum(det_u[rows].tolist()) / 6.0
        approx = math.fsum(det_s[rows].tolist())
        bound = float(err[rows].sum()) * (1.0 + 1e-10) + 1e-300
        if abs(approx) > bound:
            sign[s] = 1 if approx > 0 else -1
        else:
            sign[s] = _exact_volume_sign(PA, tri[rows])
    return volume, sign


# ---------------------------------------------------------------------------
# Entry point
# ---------------------------------------------------------------------------


def parse_surface(points: object, triangles: object) -> Surface:
    """Validate a closed triangulated surface and orient it outward.

    Parameters
    ----------
    points : (n, 3) array_like of float
        Positions ``[x, y, z]``, at least 4.
    triangles : (m, 3) array_like of int
        Point indices of each triangle, at least 4 triangles, any
        orientation consistent within each shell.

    Returns
    -------
    Surface
        The triangles oriented out of the material, their shells (edge
        components), the nesting of the shells and the regions (bodies)
        they bound, and the enclosed volume (see :class:`Surface`).

    Raises
    ------
    InputError
        With the codes listed in the module documentation, ``loc`` pointing
        at ``("points", v[, c])`` or ``("triangles", t[, c])``.

    Notes
    -----
    Every decision is an exact sign (orient3d / orient2d on coordinates
    scaled by a power of two) or an exact comparison, so the result is the
    same after an exact translation or power-of-two scaling; under other
    translations and scalings it only changes if the input is within
    rounding of a degenerate or intersecting configuration.

    References
    ----------
    DESIGN.md "Surface input (3D)"; methods text §9.3.1, §9.3.5.
    """
    P = _points(points)
    n = len(P)
    tri = _triangles(triangles, n)
    used = np.unique(tri)
    scale = _power_of_two_scale(P[used])
    PA = P * scale
    _check_degenerate(PA, tri)
    _check_duplicates(tri, n)
    twin = _half_edges(tri, n)
    _check_vertices(tri, twin)
    shell, n_shells = _shells(tri, twin)
    rows, wit, capped = _intersections(PA, tri)
    if len(rows):
        _raise_intersections(tri, shell, rows, wit, scale, capped)
    # Nesting: the first vertex of each shell's first triangle against the other shells.
    first_tri = np.full(n_shells, len(tri), dtype=np.int64)
    np.minimum.at(first_tri, shell, np.arange(len(tri)))
    queries = tri[first_tri, 0]
    if n_shells > 1:
        parity = _ray_counts(PA, tri, shell, queries, np.arange(n_shells), n_shells).astype(bool)
    else:
        parity = np.zeros((1, 1), dtype=bool)
    depth = parity.sum(axis=1).astype(np.int64)
    parent = np.full(n_shells, -1, dtype=np.int64)
    for s in np.flatnonzero(depth > 0).tolist():  # a loop over shells
        containers = np.flatnonzero(parity[s])
        parent[s] = containers[np.argmax(depth[containers])]
    region = np.full(n_shells, -1, dtype=np.int64)
    bodies = np.flatnonzero(depth % 2 == 0)
    region[bodies] = np.arange(len(bodies))
    cavities = np.flatnonzero(depth % 2 == 1)
    region[cavities] = region[parent[cavities]]
    # Orientation: bodies positive, cavities negative.
    volume, sign = _shell_volumes(P, PA, tri, shell, n_shells, queries)
    want = np.where(depth % 2 == 0, 1, -1)
    flip_shell = sign != want
    reversed_ = flip_shell[shell]
    oriented = tri.copy()
    oriented[reversed_, 1] = tri[reversed_, 2]
    oriented[reversed_, 2] = tri[reversed_, 1]
    volume = np.where(flip_shell, -volume, volume)
    corners = P[used]
    diameter = float(np.linalg.norm(corners.max(axis=0) - corners.min(axis=0)))
    return Surface(
        points=P,
        triangles=oriented,
        triangle_reversed=reversed_,
        triangle_shell=shell,
        shell_parent=parent,
        shell_depth=depth,
        shell_region=region,
        shell_volume=volume,
        volume=math.fsum(volume.tolist()),
        diameter=diameter,
    )


def added_triangles_fit(points: np.ndarray, triangles: np.ndarray, first: int) -> bool:
    """Whether ``triangles[first:]`` join ``triangles[:first]`` without a crossing.

    For surfaces built from a part of a validated one (whose triangles,
    ``triangles[:first]``, are known to meet only in common vertices or
    edges) and added triangles, such as the separator surfaces of the
    recursive partition (§8.7.2): true when no added triangle is degenerate
    (exactly collinear corners or a repeated point), none repeats another
    triangle, and no pair with an added triangle meets other than in common
    vertices or a common edge. The same exact tests as :func:`parse_surface`,
    on coordinates scaled by a power of two, only on those pairs.

    References
    ----------
    DESIGN.md "Surface input (3D)"; methods text §9.3.1, §8.7.2.
    """
    P = np.asarray(points, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.int64)
    PA = P * _power_of_two_scale(P[np.unique(tri)])
    try:
        _check_degenerate(PA, tri[first:])
        _check_duplicates(tri, len(P))
    except InputError:
        return False
    rows, _, _ = _intersections(PA, tri, first)
    return not (rows[:, 1] >= first).any()


def shell_volume(points: np.ndarray, triangles: np.ndarray) -> tuple[float, int]:
    """(signed volume, exact sign) enclosed by one closed shell, as :func:`parse_surface` sums it.

    The volume is the compensated sum of the triangles' determinants about
    the shell's first vertex (``triangles[0, 0]``); the sign is exact (by
    rationals when the sum is within its rounding bound of zero).

    References
    ----------
    DESIGN.md "Surface input (3D)"; methods text §9.3.5.
    """
    P = np.asarray(points, dtype=np.float64)
    tri = np.asarray(triangles, dtype=np.int64)
    PA = P * _power_of_two_scale(P[np.unique(tri)])
    shell = np.zeros(len(tri), dtype=np.int64)
    volume, sign = _shell_volumes(P, PA, tri, shell, 1, tri[:1, 0])
    return float(volume[0]), int(sign[0])


def as_surface(surface) -> Surface:
    """``surface`` itself if it is a :class:`Surface`, else the mapping
    ``{"points": ..., "triangles": ...}`` or the pair ``(points, triangles)``
    parsed by :func:`parse_surface`.

    Raises
    ------
    InputError
        Anything else, or a surface :func:`parse_surface` refuses; the
        location is prefixed with ``surface``.
    """
    if isinstance(surface, Surface):
        return surface
    if isinstance(surface, tuple) and len(surface) == 2:
        surface = {"points": surface[0], "triangles": surface[1]}
    if not isinstance(surface, Mapping):
        raise InputError(
            'surface must be a Surface or {"points": ..., "triangles": ...}',
            loc=("surface",),
            code="bad_geometry",
        )
    try:
        return parse_surface(surface.get("points"), surface.get("triangles"))
    except InputError as exc:
        raise exc.prefixed("surface") from None
