"""Boundary recovery in 3D: a growing Delaunay tetrahedralization that must hold a closed surface.

:class:`SurfaceRecovery` keeps the incremental 3D kernel together with the
surface's *subsegments* (pieces of input edges between two facets) and
*subfaces* (pieces of facets, re-triangulated in their plane after every
split); :func:`recover` splits every missing piece until the tetrahedralization
holds them all (edges first, then faces, §9.3.4), with every new point on the
input surface (§9.3.5); :func:`~meshcore.delaunay.regions3d.regions` labels the
tetrahedra by the shell region they lie in. Both ``tetrahedralize`` (Delaunay refinement,
``meshcore.tets``) and the Delaunay-admissible surface
(:mod:`meshcore.delaunay.admissible3d`) are built on it, which is why it lives
in the kernel package.

Choices the text leaves open are documented where they are made: facets are
maximal sets of exactly coplanar input triangles (as TetGen merges them)
unless ``merge=False``; the caps of the rounds are :class:`Knobs`.

References
----------
Methods text §9.2 (Delaunay-admissible segments in R^3), §9.3 (faces,
§9.3.4 edges first, then faces; §9.3.5 new points on the surface);
J. R. Shewchuk, "Tetrahedral Mesh Generation by Delaunay Refinement"
(SoCG 1998).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numba import njit
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from meshcore.delaunay.facets3d import KeptTriangulations, _facet_points, _facet_subfaces
from meshcore.delaunay.hashgrid import _find, _find_all, _shift, _table, ball_pairs
from meshcore.delaunay.kernel2d import delaunay as delaunay2d
from meshcore.delaunay.kernel3d import _NTET, IncrementalDelaunay3d
from meshcore.delaunay.prefetch import prefetch
from meshcore.domain.surface import Surface
from meshcore.errors import AlgorithmError, InputError
from meshcore.geometry.predicates import orient2d
from meshcore.geometry.predicates3d import dot3d, orient3d
from meshcore.mesh.topology import group_slots, isin_ints, unique_ints

__all__ = [
    "KNOBS",
    "TET_EDGES",
    "TET_FACES",
    "Knobs",
    "SurfaceRecovery",
    "ball_pairs",
    "packed_edge_keys",
    "face_keys",
    "face_rows",
    "member",
    "recover",
    "tet_circumcenters",
    "tri_circumcenters",
]

#: Faces of a positively oriented tetrahedron, opposite vertex i, normals outward.
TET_FACES = np.array([[1, 3, 2], [0, 2, 3], [0, 3, 1], [0, 1, 2]], np.int64)


TET_EDGES = np.array([[0, 1], [0, 2], [0, 3], [1, 2], [1, 3], [2, 3]], np.int64)


@dataclass(frozen=True)
class Knobs:
    """Caps and factors of the refinement (not tolerances of any sign)."""

    #: Recovery rounds before giving up (each splits every missing piece once).
    recovery_rounds: int = 200
    #: Refinement rounds (encroachment fixes and one pass over bad tetrahedra each).
    refinement_rounds: int = 60
    #: Degrees: a tetrahedron with two faces on the surface and a least dihedral
    #: angle below this fills a fold of two facets coplanar up to rounding.
    flat_fold: float = 1e-6
    #: Circumradius bound of the size criterion, in units of ``size`` (a
    #: regular tetrahedron of edge h has circumradius 0.61 h).
    size_radius: float = 0.7
    #: With a radius-edge bound, each facet is first refined to this multiple of
    #: its feature size (``tetrahedralize``): subsegments longer, subfaces of a
    #: circumradius above ``size_radius`` times it, are split before the tetrahedra.
    feature_size: float = 2.0
    #: ... only the facets whose feature size is below this fraction of their
    #: shortest edge (thin parts: on a torus the tube's width is comparable to
    #: its edges, and refining to it only added points).
    thin: float = 0.25
    #: Oversized subfaces (``size_radius``) of at most this fraction of all are split
    #: in the round's interior insertion rather than in a round of their own.
    tail: float = 0.1
    #: A vertex encroaches a subface when its distance to the circumcentre is
    #: below this fraction of the circumradius (float: keeps co-circular
    #: facet points, at the radius up to rounding, from counting).
    subface_ball: float = 1.0 - 1e-9
    #: Refinement never splits (for encroachment) a subsegment shorter than this
    #: fraction of its input edge, or a subface whose circumradius is below it
    #: times its facet's shortest edge (or of ``size``, if smaller): the guard
    #: against endless cascades next to small input angles. The bad
    #: tetrahedra whose circumcentre encroaches only such pieces are given up.
    protect: float = 1.0 / 16.0
    #: Split every subsegment and subface a vertex encroaches before each round
    #: (Shewchuk's eager rule), rather than only those missing or encroached by
    #: a candidate circumcentre (lazy).
    eager: bool = False
    #: Candidate points closer than this fraction of their circumradius to a
    #: vertex or to another candidate are dropped (co-circular subfaces, co-spherical
    #: tetrahedra give the same centre up to rounding).
    merge: float = 1e-9
    #: Of two subface centres of one batch closer than this fraction of the
    #: smaller circumradius, only the one of larger radius is inserted.
    separation: float = 0.5
    #: Refinement stops once the mesh has this many points (the bad tetrahedra
    #: left are counted in ``given_up``): Delaunay refinement with a radius-edge
    #: bound of 2 can cascade next to small input angles.
    max_points: int = 300_000
    #: Degrees: with ``keep_boundary`` (no refinement), the tetrahedra whose least
    #: dihedral angle is below this are offered 3-2 flips (``meshcore.tets.keep``).
    kept_flip_below: float = 15.0
    #: Degrees: two input features (segments, facets) meeting at an angle below
    #: this make a *small input angle* (``meshcore.tets.angles``): an input vertex
    #: where two segments on no common facet, or a segment and a facet, meet below
    #: it gets a protecting ball; a tetrahedron whose shortest edge joins two such
    #: features where they make an angle below it is not refined.
    small_angle: float = 60.0
    #: ... an input vertex on a segment whose interior dihedral angle is below
    #: this (degrees) gets a protecting ball too (Shewchuk's analysis needs 90).
    sharp_dihedral: float = 85.0
    #: ... two segments of one facet: the tetrahedron is left only below this
    #: angle between them (degrees; a facet corner of angle t forces a
    #: radius-edge ratio of at least 1 / (2 sin t), 2 at 14.5 degrees).
    facet_angle: float = 15.0
    #: Degrees: an input edge whose interior dihedral angle is below this gets a
    #: protecting cylinder (``meshcore.tets.angles``): no interior point inside it, no
    #: subface split for encroachment at a circumcentre inside it, and a tetrahedron
    #: whose circumcentre lies inside it is left (skinny because of the input angle).
    sharp_edge: float = 70.0
    #: A protecting ball's radius is the largest power of two at most this
    #: fraction of its vertex's local feature size (so balls never meet).
    ball_fraction: float = 1.0 / 3.0


KNOBS = Knobs()


def tri_circumcenters(P: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Circumcentres (in the triangle's plane) and circumradii of triangles."""
    a = P[F[:, 0]]
    u = P[F[:, 1]] - a
    v = P[F[:, 2]] - a
    w = np.cross(u, v)
    ww = np.einsum("ij,ij->i", w, w)
    num = np.einsum("ij,ij->i", u, u)[:, None] * np.cross(v, w) + np.einsum("ij,ij->i", v, v)[
        :, None
    ] * np.cross(w, u)
    with np.errstate(divide="ignore", invalid="ignore"):
        off = num / (2.0 * ww)[:, None]
    return a + off, np.sqrt(np.einsum("ij,ij->i", off, off))


def tet_circumcenters(P: np.ndarray, T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Circumcentres and circumradii of tetrahedra ``T`` (float constructions, not signs:
    offsets from the first corner, so a far translation costs no accuracy; not finite for a
    flat tetrahedron; §9.3's circumspheres)."""
    a = P[T[:, 0]]
    u = P[T[:, 1]] - a
    v = P[T[:, 2]] - a
    w = P[T[:, 3]] - a
    vw = np.cross(v, w)
    wu = np.cross(w, u)
    uv = np.cross(u, v)
    den = 2.0 * np.einsum("ij,ij->i", u, vw)
    num = (
        np.einsum("ij,ij->i", u, u)[:, None] * vw
        + np.einsum("ij,ij->i", v, v)[:, None] * wu
        + np.einsum("ij,ij->i", w, w)[:, None] * uv
    )
    with np.errstate(divide="ignore", invalid="ignore"):
        off = num / den[:, None]
    return a + off, np.sqrt(np.einsum("ij,ij->i", off, off))


def packed_edge_keys(E: np.ndarray) -> np.ndarray:
    """(k,) int64 ``min << 32 | max`` of each edge row of ``E`` (k, 2): a key needing no
    point count, for the 3D tables (:func:`meshcore.mesh.topology.edge_keys` takes the
    ends apart and ``n``; its keys differ)."""
    lo = np.minimum(E[:, 0], E[:, 1])
    hi = np.maximum(E[:, 0], E[:, 1])
    return (lo << 32) | hi


def face_keys(F: np.ndarray) -> np.ndarray:
    """(k,) int64: a key per triangle ``F`` (k, 3), the same for any order of its corners."""
    F = np.ascontiguousarray(F, dtype=np.int64)
    if F.size and F.max() >= 1 << 21:
        raise AlgorithmError("more than 2**21 points: face keys overflow", code="too_many_points")
    return _face_keys(F)


@njit(cache=True)
def _face_key(a, b, c):
    """The key of triangle (a, b, c): its sorted corners, 21 bits each."""
    if a > b:
        a, b = b, a
    if b > c:
        b, c = c, b
        if a > b:
            a, b = b, a
    return (a << 42) | (b << 21) | c


@njit(cache=True, inline="always")
def _subface_at(T, t, j, faces, on, tk, tv, shift):
    """The subface that face ``j`` of tetrahedron ``t`` is, or -1 (a corner off the
    surface or no such subface in the table ``tk``/``tv``)."""
    a = T[t, faces[j, 0]]
    b = T[t, faces[j, 1]]
    c = T[t, faces[j, 2]]
    if on[a] and on[b] and on[c]:
        return _find(tk, tv, _face_key(a, b, c), shift)
    return -1


@njit(cache=True)
def _face_keys(F):
    out = np.empty(F.shape[0], np.int64)
    for i in range(F.shape[0]):
        out[i] = _face_key(F[i, 0], F[i, 1], F[i, 2])
    return out


# Hash tables of int64 keys (faces and edges of the tetrahedralization looked up
# among the subfaces and subsegments): open addressing, Fibonacci hashing, at most
# half full; each slot holds a key and the index of its first occurrence.
@njit(cache=True)
def _tet_face_rows(T, tk, tv, faces):
    """(m, 4): the table index of each face of each tetrahedron (``faces`` order), or -1."""
    shift = _shift(tk.shape[0])
    out = np.empty((T.shape[0], 4), np.int64)
    for t in range(T.shape[0]):
        for j in range(4):
            key = _face_key(T[t, faces[j, 0]], T[t, faces[j, 1]], T[t, faces[j, 2]])
            out[t, j] = _find(tk, tv, key, shift)
    return out


@njit(cache=True)
def _present(T, on, seg_tk, seg_tv, n_seg, sub_tk, sub_tv, n_sub, edges, faces):
    """Which table entries (first occurrences) are edges / faces of the tetrahedra ``T``.

    Only the edges and faces whose corners are all ``on`` (the surface points:
    subsegments and subfaces have no other) are looked up.
    """
    seg_shift = _shift(seg_tk.shape[0])
    sub_shift = _shift(sub_tk.shape[0])
    seg_hit = np.zeros(n_seg, np.bool_)
    sub_hit = np.zeros(n_sub, np.bool_)
    for t in range(T.shape[0]):
        if (on[T[t, 0]] + on[T[t, 1]] + on[T[t, 2]] + on[T[t, 3]]) < 2:
            continue
        for j in range(6):
            a = T[t, edges[j, 0]]
            b = T[t, edges[j, 1]]
            if not (on[a] and on[b]):
                continue
            if a > b:
                a, b = b, a
            k = _find(seg_tk, seg_tv, (a << 32) | b, seg_shift)
            if k >= 0:
                seg_hit[k] = True
        for j in range(4):
            k = _subface_at(T, t, j, faces, on, sub_tk, sub_tv, sub_shift)
            if k >= 0:
                sub_hit[k] = True
    return seg_hit, sub_hit


@njit(cache=True)
def _held_in_kernel(V, A, vt, inv, ntet, pieces, wit):
    """Which ``pieces`` (rows of 2 or 3 vertex ids) are edges / faces of a real
    tetrahedron of the kernel (``V``, ``A``, ``vt``: vertex slots, adjacency and a
    tetrahedron of each vertex, in the kernel's numbering ``inv``); ``wit`` (a slot
    per piece, -1 none) is tried first and set to the slot found (-1: missing).

    Otherwise the star of the piece's first corner is walked across the faces
    that hold it. Returns (hit, ok): ``ok`` False when a corner's ``vt`` entry
    does not hold it (then nothing is decided).
    """
    k, w = pieces.shape
    hit = np.zeros(k, np.bool_)
    mark = np.zeros(0, np.int64)  # made at the first walk (most pieces have a witness)
    stack = np.empty(0, np.int64)
    stamp = 0
    for i in range(k):
        if i + 16 < k:  # the witness and corners 16 pieces ahead (misses at 10^6 tets)
            if wit[i + 16] >= 0:
                prefetch(V, 4 * wit[i + 16])
            for j in (0, 1, w - 1):
                prefetch(inv, pieces[i + 16, j])
        a = inv[pieces[i, 0]]
        b = inv[pieces[i, 1]]
        c = inv[pieces[i, w - 1]]
        s = wit[i]
        if 0 <= s < ntet and _holds3(V, s, a, b, c):
            hit[i] = True
            continue
        wit[i] = -1
        s = vt[a]
        if not (0 <= s < ntet) or not (
            V[4 * s] == a or V[4 * s + 1] == a or V[4 * s + 2] == a or V[4 * s + 3] == a
        ):
            return hit, False
        if mark.shape[0] == 0:
            mark = np.zeros(ntet, np.int64)
            stack = np.empty(ntet, np.int64)
        stamp += 1
        mark[s] = stamp
        stack[0] = s
        top = 1
        while top > 0:
            top -= 1
            s = stack[top]
            if _holds3(V, s, a, b, c):
                hit[i] = True
                wit[i] = s
                break
            for j in range(4):
                if V[4 * s + j] != a:  # the face opposite j holds a
                    u = A[4 * s + j] >> 2
                    if mark[u] != stamp:
                        mark[u] = stamp
                        stack[top] = u
                        top += 1
    return hit, True


@njit(cache=True, inline="always")
def _holds3(V, s, a, b, c):
    """True when slot s is a real tetrahedron (no vertex at infinity, not dead) holding
    vertices a, b and c."""
    x0, x1, x2, x3 = V[4 * s], V[4 * s + 1], V[4 * s + 2], V[4 * s + 3]
    if x0 < 0 or x1 < 0 or x2 < 0 or x3 < 0:
        return False
    return (
        (x0 == a or x1 == a or x2 == a or x3 == a)
        and (x0 == b or x1 == b or x2 == b or x3 == b)
        and (x0 == c or x1 == c or x2 == c or x3 == c)
    )


@njit(cache=True)
def _sources(P, sub, sub_facet, facets, by_group, start):
    """:meth:`SurfaceRecovery.sources`: per subface, the triangle of its facet (``by_group``
    from ``start[facet]``, in that order) with the greatest least side of the subface's
    centroid (:meth:`SurfaceRecovery._sides`' floats, the first of equals)."""
    out = np.empty(len(sub), np.int64)
    for i in range(len(sub)):
        g = sub_facet[i]
        lo, hi = start[g], start[g + 1]
        out[i] = by_group[lo]
        if hi - lo == 1:
            continue
        u, v, w = sub[i, 0], sub[i, 1], sub[i, 2]
        x = (P[u, 0] + P[v, 0] + P[w, 0]) / 3.0
        y = (P[u, 1] + P[v, 1] + P[w, 1]) / 3.0
        z = (P[u, 2] + P[v, 2] + P[w, 2]) / 3.0
        best = -np.inf
        for jj in range(lo, hi):
            j = by_group[jj]
            a, b, c = facets[j, 0], facets[j, 1], facets[j, 2]
            ax, ay, az = P[a, 0], P[a, 1], P[a, 2]
            bx, by, bz = P[b, 0], P[b, 1], P[b, 2]
            cx, cy, cz = P[c, 0], P[c, 1], P[c, 2]
            nx, ny, nz = _cross(bx - ax, by - ay, bz - az, cx - ax, cy - ay, cz - az)
            s = min(
                min(
                    _side(ax, ay, az, bx, by, bz, x, y, z, nx, ny, nz),
                    _side(bx, by, bz, cx, cy, cz, x, y, z, nx, ny, nz),
                ),
                _side(cx, cy, cz, ax, ay, az, x, y, z, nx, ny, nz),
            )
            if s > best:
                best = s
                out[i] = j
    return out


@njit(cache=True, inline="always")
def _cross(u0, u1, u2, v0, v1, v2):
    """numpy.cross of two 3-vectors, the same roundings."""
    return u1 * v2 - u2 * v1, u2 * v0 - u0 * v2, u0 * v1 - u1 * v0


@njit(cache=True, inline="always")
def _side(px, py, pz, qx, qy, qz, x, y, z, nx, ny, nz):
    """``cross(q - p, x - p) . n`` as :meth:`SurfaceRecovery._sides` rounds it (numpy's
    ``einsum`` of a row of three adds the last product to the first, then the middle one)."""
    c0, c1, c2 = _cross(qx - px, qy - py, qz - pz, x - px, y - py, z - pz)
    return (c0 * nx + c2 * nz) + c1 * ny


def face_rows(T: np.ndarray, F: np.ndarray) -> np.ndarray:
    """(m, 4) int64: the row of ``F`` (k, 3) that each face of each tetrahedron ``T`` is
    (faces in ``TET_FACES`` order, corners in any order), or -1.

    One compiled pass, the triangles in a hash table (no sort).
    """
    tk, tv = _table(face_keys(F))
    T = np.ascontiguousarray(T, dtype=np.int64)
    if T.size and T.max() >= 1 << 21:
        raise AlgorithmError("more than 2**21 points: face keys overflow", code="too_many_points")
    return _tet_face_rows(T, tk, tv, TET_FACES)


def member(keys: np.ndarray, table_sorted: np.ndarray) -> np.ndarray:
    if table_sorted.size == 0:
        return np.zeros(len(keys), dtype=bool)
    pos = np.minimum(np.searchsorted(table_sorted, keys), len(table_sorted) - 1)
    return table_sorted[pos] == keys


class SurfaceRecovery:
    """The growing tetrahedralization and the subsegments and subfaces it must hold.

    A *facet* is a maximal set of input triangles joined across edges whose
    four points are exactly coplanar (``orient3d == 0``), as TetGen merges
    coplanar facets; with ``merge=False`` every input triangle is a facet.
    The *segments* are the input edges between two facets; the edges inside
    a facet are no constraints (the diagonals a planar face was triangulated
    with make no small input angles).
    """

    def __init__(self, surface: Surface, knobs: Knobs, merge: bool = True) -> None:
        self.knobs = knobs
        used = surface.vertices
        remap = np.full(len(surface.points), -1, dtype=np.int64)
        remap[used] = np.arange(len(used))
        self.source = used
        self.n_surface = len(used)
        self.P = np.array(surface.points[used], dtype=np.float64)
        self.n = len(used)
        facets = remap[surface.triangles]
        self.facets = facets  # the input triangles
        self.facet_region = surface.triangle_region
        F = len(facets)
        e = np.concatenate([facets[:, [0, 1]], facets[:, [1, 2]], facets[:, [2, 0]]])
        e.sort(axis=1)
        edges, inv = np.unique(e, axis=0, return_inverse=True)
        inv = inv.reshape(-1)
        order = np.argsort(inv, kind="stable")
        edge_tris = (order % F).reshape(-1, 2)  # row k of e belongs to triangle k % F
        # Coplanar neighbours (exact sign) form one facet.
        if merge:
            t1, t2 = edge_tris[:, 0], edge_tris[:, 1]
            tri2 = facets[t2]
            far = tri2[np.arange(len(edges)), np.argmax(
                (tri2 != edges[:, :1]) & (tri2 != edges[:, 1:]), axis=1)]  # fmt: skip
            a0, a1, a2 = (self.P[facets[t1, k]] for k in range(3))
            flat = orient3d(a0, a1, a2, self.P[far]) == 0
        else:
            flat = np.zeros(len(edges), dtype=bool)
        graph = sp.csr_matrix(
            (np.ones(int(flat.sum())), (edge_tris[flat, 0], edge_tris[flat, 1])), shape=(F, F)
        )
        n_groups, group = connected_components(graph, directed=False)
        self.group = group  # facet of each input triangle
        self.group_region = np.zeros(n_groups, dtype=np.int64)
        self.group_region[group] = self.facet_region
        seg_edges = np.flatnonzero(~flat)
        self.edges = edges
        self.edge_groups = group[edge_tris]  # (E, 2): the facets on each side
        self.seg = edges[seg_edges].copy()
        self.seg_edge = seg_edges.copy()
        self.pt_edge = np.full(self.n, -1, dtype=np.int64)
        self.pt_facet = np.full(self.n, -1, dtype=np.int64)  # facet (group) of inner points
        # Per facet: its triangles, its vertices and its boundary loops (directed
        # input edges, the facet on their left seen from outside).
        by_group, bounds = group_slots(group, n_groups)
        self.group_tris = [by_group[bounds[g] : bounds[g + 1]] for g in range(n_groups)]
        self._by_group, self._group_start = by_group, bounds
        self._directed = np.stack([facets[:, [0, 1]], facets[:, [1, 2]], facets[:, [2, 0]]], 1)
        self._edge_id = inv.reshape(3, F).T
        self._flat = flat
        self._loops: dict[int, list] = {}
        self._corner_cache: dict[int, tuple] = {}
        self._static: tuple | None = None
        #: Per subface: circumcentre, circumradius, whether computed (:meth:`sub_circles`).
        self._circles: tuple = (np.zeros((0, 3)), np.zeros(0), np.zeros(0, dtype=bool))
        self._circles_P = np.zeros((0, 3))
        self._near: tuple = (None, np.zeros((0, 3)))  # see :meth:`_nearest`
        # Facet frames for the 2D triangulations: origin, two orthonormal axes
        # (counter-clockwise in the frame is outward), from the facet's first triangle.
        first = facets[[t[0] for t in self.group_tris]]
        a = self.P[first[:, 0]]
        u = self.P[first[:, 1]] - a
        v = self.P[first[:, 2]] - a
        e1 = u / np.linalg.norm(u, axis=1)[:, None]
        w = v - np.einsum("ij,ij->i", v, e1)[:, None] * e1
        e2 = w / np.linalg.norm(w, axis=1)[:, None]
        self.frame = (a, e1, e2)
        lengths = np.linalg.norm(self.P[edges[:, 0]] - self.P[edges[:, 1]], axis=1)
        self.edge_length = lengths
        short = np.full(n_groups, np.inf)
        np.minimum.at(short, self.edge_groups[seg_edges, 0], lengths[seg_edges])
        np.minimum.at(short, self.edge_groups[seg_edges, 1], lengths[seg_edges])
        self.facet_short = short
        self.size_cap = math.inf
        #: Per facet: the size its pieces are refined to (``feature_sizes``), inf if none.
        self.facet_size = np.full(n_groups, np.inf)
        # Subfaces, outward, and their facet: with no point added, the input
        # triangles (what retriangulate gives a facet without added points).
        self.sub = facets.copy()
        self.sub_facet = group.copy()
        #: Per input vertex: the radius of its protecting ball (0: none); see
        #: :meth:`split_segments` and :meth:`onto_balls`. Set by ``tetrahedralize``.
        self.ball = np.zeros(self.n_surface)
        self._ball_tree = None
        #: Protecting cylinders along sharp input edges (``meshcore.tets.angles``): the
        #: edge (``edges`` row) and radius of each; see :meth:`in_cylinders`.
        self.cyl_edge = np.zeros(0, dtype=np.int64)
        self.cyl_radius = np.zeros(0)
        self.unsettled: dict[int, np.ndarray] = {}  # subsegments missing from a facet's 2D mesh
        self._kept = KeptTriangulations()  # the large facets' 2D triangulations
        self.dt = IncrementalDelaunay3d(self.P)
        self._tets_at = -1
        self._tets: tuple[np.ndarray, np.ndarray] = (
            np.zeros(0, np.int64),
            np.zeros((0, 4), np.int64),
        )
        self.surface_added = 0
        self.interior_added = 0
        #: Per row of ``seg`` and of ``sub``: the witness slot of :meth:`missing` (-1 none).
        self._witness = [np.zeros(0, np.int64), np.zeros(0, np.int64)]

    def loops(self, g: int) -> list:
        """Boundary loops of facet ``g``: (directed input edges, edge ids), chained."""
        if g in self._loops:
            return self._loops[g]
        rows = self.group_tris[g]
        de = self._directed[rows].reshape(-1, 2)
        ei = self._edge_id[rows].reshape(-1)
        keep = ~self._flat[ei]
        de, ei = de[keep], ei[keep]
        nxt: dict[int, list[int]] = {}
        for k, (u, _) in enumerate(de.tolist()):
            nxt.setdefault(u, []).append(k)
        used_e = np.zeros(len(de), dtype=bool)
        loops = []
        for k0 in range(len(de)):  # chaining a facet's boundary edges
            if used_e[k0]:
                continue
            loop, k = [], k0
            while not used_e[k]:
                used_e[k] = True
                loop.append(k)
                cands = [c for c in nxt[int(de[k, 1])] if not used_e[c]]
                if not cands:
                    break
                k = cands[0]
            loops.append((de[loop], ei[loop]))
        self._loops[g] = loops
        return loops

    def _corners(self, g: int) -> tuple[np.ndarray, np.ndarray]:
        """Input vertices of facet ``g``, and those on none of its boundary loops."""
        if g not in self._corner_cache:
            corners = unique_ints(self.facets[self.group_tris[g]])
            starts = [de[:, 0] for de, _ in self.loops(g)]
            on_loop = np.concatenate(starts) if starts else np.zeros(0, dtype=np.int64)
            self._corner_cache[g] = (corners, corners[~isin_ints(corners, on_loop)])
        return self._corner_cache[g]

    # -- points ----------------------------------------------------------------

    def add(self, X: np.ndarray, edge: np.ndarray, facet: np.ndarray) -> np.ndarray:
        """Insert points (batch); their vertex ids (-1 where one coincided with a vertex)."""
        if len(X) == 0:
            return np.zeros(0, dtype=np.int64)
        ids = self.dt.insert_many(X)
        n0 = self.n
        new = ids >= n0
        keep = np.zeros(len(X), dtype=bool)
        _, first = unique_ints(ids, return_index=True)
        keep[first] = True
        keep &= new
        order = np.argsort(ids[keep], kind="stable")
        rows = np.flatnonzero(keep)[order]
        self.P = np.concatenate([self.P, X[rows]])
        self.pt_edge = np.concatenate([self.pt_edge, edge[rows]])
        self.pt_facet = np.concatenate([self.pt_facet, facet[rows]])
        self.n = len(self.P)
        on_surface = (edge[rows] >= 0) | (facet[rows] >= 0)
        self.surface_added += int(on_surface.sum())
        self.interior_added += int((~on_surface).sum())
        return np.where(new & keep, ids, -1)

    def tets(self) -> tuple[np.ndarray, np.ndarray]:
        """(slots, (m, 4) vertices) of the real tetrahedra, read-only.

        Kept until the next insertion (the kernel changes only by inserting
        points, so its point count dates the structure).
        """
        n = self.dt.n_points
        if self._tets_at != n:
            self._tets = ()  # the old arrays freed before the new are made
            slots = self.dt.alive()
            T = self.dt.tets(slots)
            slots.flags.writeable = False
            T.flags.writeable = False
            self._tets = (slots, T)
            self._tets_at = n
        return self._tets

    def release_kernel(self) -> None:
        """Drop the tetrahedralization and the caches built on it (the caller has taken
        the tetrahedra it needs: no insertion, :meth:`tets` or :meth:`missing` after)."""
        self.dt = None
        self._tets_at = -1
        self._tets = (np.zeros(0, np.int64), np.zeros((0, 4), np.int64))
        self._witness = []
        self._kept.clear()

    def on_surface(self) -> np.ndarray:
        """(n,) bool: which points lie on the surface (input vertices, points added on
        input edges and in facets)."""
        on = np.ones(self.n, dtype=bool)
        on[self.n_surface :] = (self.pt_edge[self.n_surface :] >= 0) | (
            self.pt_facet[self.n_surface :] >= 0
        )
        return on

    # -- subsegments -------------------------------------------------------------

    def split_segments(self, rows: np.ndarray, defer: list | None = None) -> int:
        """Split subsegments ``rows``; the number split.

        Ruppert's concentric shells: a subsegment with exactly one endpoint
        at an input vertex is split at the power of two of distance from it
        nearest to half its length (so the points put on the edges leaving
        one vertex lie on common spheres around it and do not encroach each
        other's subsegments, whatever the angle between the edges); the
        others at their midpoints. At a vertex with a protecting ball
        (``ball``, a power of two) no split goes inside the ball: the shells
        stop at its sphere, and a subsegment from the vertex to the sphere is
        never split (it stays an edge: every point inside the ball is on its
        sphere, and no point of that sphere lies in its closed diametral
        ball). With ``defer`` (a list), the facets to retriangulate are
        appended to it instead.
        """
        rows = unique_ints(rows)
        if rows.size == 0:
            return 0
        s = self.seg[rows]
        ia = s[:, 0] < self.n_surface
        one = ia ^ (s[:, 1] < self.n_surface)
        pa, pb = self.P[s[:, 0]], self.P[s[:, 1]]
        L = np.linalg.norm(pb - pa, axis=1)
        floor = self.radial_floor(s)
        ok = L >= 1.5 * floor
        rows, s, ia, one, pa, pb, L, floor = (x[ok] for x in (rows, s, ia, one, pa, pb, L, floor))
        if rows.size == 0:
            return 0
        t = np.full(len(rows), 0.5)
        if one.any():
            d = np.maximum(np.exp2(np.round(np.log2(0.5 * L[one]))), floor[one])
            frac = d / L[one]
            t[one] = np.where(ia[one], frac, 1.0 - frac)
        mid = pa + t[:, None] * (pb - pa)
        e = self.seg_edge[rows]
        ids = self.add(mid, e, np.full(len(rows), -1))
        ok = ids >= 0
        rows, s, e, ids = rows[ok], s[ok], e[ok], ids[ok]
        self.seg[rows, 1] = ids
        self.seg = np.concatenate([self.seg, np.stack([ids, s[:, 1]], 1)])
        self.seg_edge = np.concatenate([self.seg_edge, e])
        touched = unique_ints(self.edge_groups[e])
        if defer is None:
            self.retriangulate(touched)
        else:
            defer.append(touched)  # the caller retriangulates them
        return int(ok.sum())

    # -- subfaces ----------------------------------------------------------------

    def _facet_static(self, g: int) -> tuple:
        """Facet ``g``'s boundary (first vertex, edge, loop, whether the edge runs from
        its first vertex), its corners on no loop, its input triangles projected in
        its frame and the inside tolerance."""
        corners, lonely = self._corners(g)
        parts = [(de[:, 0], ei, np.full(len(ei), li)) for li, (de, ei) in enumerate(self.loops(g))]
        if parts:
            u, e, li = (np.concatenate(x) for x in zip(*parts, strict=True))
        else:
            u = e = li = np.zeros(0, dtype=np.int64)
        origin, e1, e2 = self.frame
        q = self.P[self.facets[self.group_tris[g]]] - origin[g]
        tu = np.stack([q @ e1[g], q @ e2[g]], -1)  # (k, 3, 2)
        # Non-strict up to rounding: a centroid may lie on an edge inside the
        # facet (a diagonal its input triangles share).
        tol = -1e-9 * float(np.ptp(tu.reshape(-1, 2), axis=0).max()) ** 2
        fwd = u == self.edges[e, 0]
        return u, e, li, fwd, lonely, len(corners), tu, tol

    def _facet_tables(self) -> tuple:
        """:meth:`_facet_static` of every facet as CSR tables indexed by facet id
        (boundary ``bptr, bu, be, bl, bfwd``, lonely corners ``lptr, lonely``, corner
        counts, input triangles ``in_ptr, in_tri``, projected ``tu``, ``tol``); built
        once, a one-triangle facet (its boundary the triangle's three edges in order,
        no lonely corner) without a loop in Python."""
        if self._static is not None:
            return self._static
        G = len(self.group_tris)
        in_ptr = self._group_start
        sizes = np.diff(in_ptr)
        single = np.flatnonzero(sizes == 1)
        multi = np.flatnonzero(sizes > 1).tolist()
        st = [self._facet_static(g) for g in multi]
        bcount = np.full(G, 3, dtype=np.int64)
        bcount[sizes == 0] = 0
        bcount[multi] = [len(x[0]) for x in st]
        lcount = np.zeros(G, dtype=np.int64)
        lcount[multi] = [len(x[4]) for x in st]
        ncorner = bcount.copy()
        ncorner[multi] = [x[5] for x in st]
        bptr = np.concatenate([[0], np.cumsum(bcount)])
        lptr = np.concatenate([[0], np.cumsum(lcount)])
        bu, be, bl = (np.zeros(bptr[-1], dtype=np.int64) for _ in range(3))
        lonely = np.zeros(lptr[-1], dtype=np.int64)
        in_tri = self.facets[self._by_group]
        tu = np.zeros((len(in_tri), 3, 2))
        tol = np.zeros(G)
        t = in_ptr[single]  # the facet's one triangle (row of in_tri)
        at = bptr[single][:, None] + np.arange(3)
        bu[at] = in_tri[t]
        be[at] = self._edge_id[self._by_group[t]]
        origin, e1, e2 = self.frame
        q = self.P[in_tri[t]] - origin[single][:, None, :]
        tu[t] = np.stack([q @ e1[single][:, :, None], q @ e2[single][:, :, None]], -1)[:, :, 0]
        span = (tu[t].max(axis=1) - tu[t].min(axis=1)).max(axis=1)
        tol[single] = -1e-9 * span**2
        for g, x in zip(multi, st, strict=True):  # facets of several input triangles
            bu[bptr[g] : bptr[g + 1]], be[bptr[g] : bptr[g + 1]] = x[0], x[1]
            bl[bptr[g] : bptr[g + 1]] = x[2]
            lonely[lptr[g] : lptr[g + 1]] = x[4]
            tu[in_ptr[g] : in_ptr[g + 1]], tol[g] = x[6], x[7]
        bfwd = bu == self.edges[be, 0]
        self._static = (bptr, bu, be, bl, bfwd, lptr, lonely, ncorner, in_ptr, in_tri, tu, tol)
        return self._static

    def retriangulate(self, facets: np.ndarray) -> None:
        """Recompute the subfaces of ``facets``: 2D Delaunay of each facet's points.

        The points: the facet's input vertices, the points added on its
        boundary edges and inside it; the triangles outside the facet are
        dropped (:func:`~meshcore.delaunay.facets3d._facet_subfaces`). A
        subsegment of the facet's boundary that is not an edge of the result
        (its diametral circle holds a facet point) is *unsettled*:
        :meth:`missing` reports it, and recovery splits it. One compiled call
        triangulates every facet whose point set changed
        (:func:`~meshcore.delaunay.facets3d.triangulate_facets`), a large one's
        kept triangulation gets only its new points
        (:class:`~meshcore.delaunay.facets3d.KeptTriangulations`); the points
        are projected in each facet's frame in a loop over those facets.
        """
        if facets.size == 0:
            return
        facets = np.asarray(facets, dtype=np.int64)
        on_edge = np.flatnonzero(self.pt_edge >= 0)
        # The points on each input edge, ordered from its first vertex.
        pe = self.pt_edge[on_edge]
        a = self.P[self.edges[pe, 0]]
        along = np.einsum("ij,ij->i", self.P[on_edge] - a, self.P[self.edges[pe, 1]] - a)
        by_edge = on_edge[np.lexsort((along, pe))]
        edge_bounds = np.searchsorted(self.pt_edge[by_edge], np.arange(len(self.edges) + 1))
        by_facet, facet_bounds = group_slots(self.pt_facet, len(self.group_tris))
        by_facet, facet_bounds = by_facet[facet_bounds[0] :], facet_bounds - facet_bounds[0]
        seg_order, seg_bounds = group_slots(self.seg_edge, len(self.edges))
        bptr, bu, be, bl, bfwd, lptr, lonely, ncorner, in_ptr, in_tri, tu, tol = (
            self._facet_tables()
        )
        ptr, ids, loop, pos, sptr, segs = _facet_points(
            facets, bptr, bu, be, bl, bfwd, lptr, lonely, by_edge, edge_bounds, by_facet,
            facet_bounds, seg_order, seg_bounds,
        )  # fmt: skip
        origin, e1, e2 = self.frame
        # No point added: the input triangles (what the 3D mesh most likely holds
        # when the facet's corners are co-circular, as a square's).
        plain = np.diff(ptr) == ncorner[facets]
        uv = np.zeros((len(ids), 2))
        for k in np.flatnonzero(~plain).tolist():  # the projections, facet by facet
            f = int(facets[k])
            d = self.P[ids[ptr[k] : ptr[k + 1]]] - origin[f]
            uv[ptr[k] : ptr[k + 1], 0] = d @ e1[f]
            uv[ptr[k] : ptr[k + 1], 1] = d @ e2[f]
        ro = uv.view()
        ro.flags.writeable = False
        tri, tptr, status = self._kept.triangulate(facets, ptr, ids, ro, plain, self.n)
        for k in np.flatnonzero(status).tolist():  # the kernel's own error, to name it
            f = int(facets[k])
            try:
                delaunay2d(uv[ptr[k] : ptr[k + 1]])
                msg = "the 2D kernel failed"
            except InputError as exc:  # rounding made two projections coincide
                msg = exc.message
            raise AlgorithmError(
                f"the points added on facet {f} (input triangles "
                f"{self.group_tris[f][:5].tolist()}) could not be triangulated in its "
                f"plane ({msg})",
                code="recovery_failed",
            )
        sub, owner, uptr, unsettled = _facet_subfaces(
            facets, plain, ptr, ids, loop, pos, tptr, tri, uv, in_ptr, in_tri, tu, tol, sptr,
            segs, packed_edge_keys(self.seg),
        )  # fmt: skip
        for k, f in enumerate(facets.tolist()):
            self.unsettled[f] = unsettled[uptr[k] : uptr[k + 1]]
        keep = ~isin_ints(self.sub_facet, facets)
        self._carry_rows(keep, sub)
        self.sub = np.concatenate([self.sub[keep], sub])
        self.sub_facet = np.concatenate([self.sub_facet[keep], owner])

    def _carry_rows(self, keep: np.ndarray, sub: np.ndarray) -> None:
        """The circles of :meth:`sub_circles` and the witnesses of :meth:`missing` for the
        subfaces ``sub[keep]`` followed by ``sub`` (the new ones of a retriangulation):
        those kept, and those of the new rows that were rows before, corners in the same
        order (a facet triangulated again mostly gives its triangles again; the circle's
        rounding depends on the order, so only the same row reuses it)."""
        old = np.flatnonzero(~keep)
        src = np.full(len(sub), -1, dtype=np.int64)  # the old row of each new one
        if old.size and sub.size and len(self.P) < 1 << 21:

            def row_keys(F):
                return (F[:, 0] << 42) | (F[:, 1] << 21) | F[:, 2]

            at = _find_all(*_table(row_keys(self.sub[old])), row_keys(sub))
            src[at >= 0] = old[at[at >= 0]]
        hit = src >= 0
        if self._witness and len(self._witness[1]) == len(keep):
            wit = self._witness[1]
            self._witness[1] = np.concatenate([wit[keep], np.where(hit, wit[src], -1)])
        o, r, known = self._circles
        if len(known) != len(keep):
            return
        no, nr = np.zeros((len(sub), 3)), np.zeros(len(sub))
        nk = np.zeros(len(sub), dtype=bool)
        hit[hit] = known[src[hit]]
        no[hit], nr[hit], nk[hit] = o[src[hit]], r[src[hit]], True
        self._circles = (
            np.concatenate([o[keep], no]),
            np.concatenate([r[keep], nr]),
            np.concatenate([known[keep], nk]),
        )

    def sub_circles(self, rows: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The circumcentres and circumradii of subfaces ``rows`` (all of them when
        None: the cache itself, not to be written), as :func:`tri_circumcenters` gives
        them; each subface's computed once and kept while it and the points are
        (points are only appended during refinement; :meth:`_carry_circles`)."""
        o, r, known = self._circles
        m = len(self._circles_P)
        if len(known) != len(self.sub) or not np.array_equal(self.P[:m], self._circles_P):
            o, r = np.zeros((len(self.sub), 3)), np.zeros(len(self.sub))
            known = np.zeros(len(self.sub), dtype=bool)
            m = 0
        if len(self.P) > m:
            self._circles_P = self.P.copy()
        need = np.flatnonzero(~known) if rows is None else rows[~known[rows]]
        if need.size:
            need = unique_ints(need)
            o[need], r[need] = tri_circumcenters(self.P, self.sub[need])
            known[need] = True
        self._circles = (o, r, known)
        if rows is None:
            return o, r
        return o[rows], r[rows]

    def split_subfaces(self, rows: np.ndarray, touched: list | None = None) -> tuple[int, int]:
        """Split subfaces ``rows`` at their circumcentres (Shewchuk's rule).

        A circumcentre in the diametral ball of a subsegment splits the
        subsegments it encroaches instead; one outside its facet and in no such
        ball splits the boundary subsegment crossed on the way from the
        subface to it (:meth:`crossed_segments`: a vertex of the subface
        encroaches that subsegment, Shewchuk's lemma). A point
        inside the protecting ball of a corner of its facet is moved onto the
        ball's sphere (:meth:`onto_balls`). ``touched``: the facets a caller's
        :meth:`split_segments` deferred (``defer``), retriangulated here with
        these splits, so that ``rows`` still name the subfaces they named.
        Returns (subfaces split, subsegments split).
        """
        rows = unique_ints(rows)
        touched = [] if touched is None else touched
        if rows.size == 0:
            self._retriangulate_after(touched, np.zeros(0, dtype=np.int64))
            return 0, 0
        c, R = self.sub_circles(rows)
        flat = ~np.isfinite(c).all(axis=1)
        if flat.any():
            T = self.P[self.sub[rows[flat]]]
            half = 0.5 * np.linalg.norm(T - np.roll(T, 1, axis=1), axis=2).max(axis=1)
            if (half == 0).any():
                # Splits that converged onto one point (its corners coincide in float).
                k = rows[flat][np.flatnonzero(half == 0)[0]]
                raise AlgorithmError(
                    f"boundary recovery did not converge: subface {self.sub[k].tolist()} "
                    f"of facet {int(self.sub_facet[k])} has collapsed to a point "
                    f"after {self.n - self.n_surface} points were added",
                    code="recovery_failed",
                )
            # Collinear in float (points on one input edge): the centroid, on that
            # edge, encroaches the subsegment that is split below.
            c[flat] = T.mean(axis=1)
            R[flat] = half
        c = self.onto_balls(c, self.sub_facet[rows])
        # Co-circular subfaces share a circumcentre up to rounding: keep one.
        near = self.crowded(c, R)
        rows, c, R = rows[~near], c[~near], R[~near]
        f = self.sub_facet[rows]
        enc_c, enc_s = self.encroached_segments(c)
        hit = np.zeros(len(rows), dtype=bool)
        hit[enc_c] = True
        inside = self.in_facet(c, f)
        lost = ~inside & ~hit
        if lost.any():
            # Outside its facet and encroaching no subsegment: a vertex of the
            # subface encroaches the subsegment that separates it from its
            # circumcentre (Shewchuk's lemma), so that subsegment is split, as
            # Triangle does. Only where none is crossed (rounding): the centroid.
            crossed = self.crossed_segments(
                self.P[self.sub[rows[lost]]].mean(axis=1), c[lost], f[lost]
            )
            enc_s = np.concatenate([enc_s, crossed[crossed >= 0]])
            hit[np.flatnonzero(lost)[crossed >= 0]] = True
            lost &= ~hit
            c[lost] = self.P[self.sub[rows[lost]]].mean(axis=1)
            inside[lost] = True
        c[lost] = self.onto_balls(c[lost], f[lost])
        use = inside & ~hit
        n_seg = self.split_segments(enc_s, touched)
        ids = self.add(c[use], np.full(int(use.sum()), -1), f[use])
        self._retriangulate_after(touched, unique_ints(f[use][ids >= 0]))
        return int((ids >= 0).sum()), n_seg

    def _retriangulate_after(self, touched: list, mine: np.ndarray) -> None:
        """One retriangulation for deferred subsegment splits (``touched``, facet arrays)
        and facets ``mine`` that got points inside, the subfaces in the order separate
        calls would give (the facets of the subsegments only, first seen first, then
        ``mine``)."""
        first = np.concatenate([np.zeros(0, dtype=np.int64), *touched])
        _, at = unique_ints(first, return_index=True)
        first = first[np.sort(at)]
        self.retriangulate(np.concatenate([first[~isin_ints(first, mine)], mine]))

    def crossed_segments(self, A: np.ndarray, B: np.ndarray, f: np.ndarray) -> np.ndarray:
        """For each segment A→B in facet ``f``'s plane, the subsegment of the facet's
        boundary it crosses nearest A, or -1 (exact ``orient2d`` in the facet's frame)."""
        out = np.full(len(A), -1, dtype=np.int64)
        on = self.edge_groups[self.seg_edge]
        origin, e1, e2 = self.frame
        for g in unique_ints(f).tolist():  # a loop over the facets concerned
            rows = np.flatnonzero(f == g)
            segs = np.flatnonzero((on[:, 0] == g) | (on[:, 1] == g))
            if segs.size == 0:
                continue

            def uv(X, g=g):
                d = X - origin[g]
                return np.stack([d @ e1[g], d @ e2[g]], -1)

            a, b = uv(A[rows])[:, None], uv(B[rows])[:, None]
            p, q = uv(self.P[self.seg[segs, 0]])[None], uv(self.P[self.seg[segs, 1]])[None]
            cross = (orient2d(a, b, p) * orient2d(a, b, q) <= 0) & (
                orient2d(p, q, a) * orient2d(p, q, b) < 0
            )
            # nearest A: the crossing's parameter along A→B (float, for the order only)
            d = b - a
            den = d[..., 0] * (q - p)[..., 1] - d[..., 1] * (q - p)[..., 0]
            with np.errstate(divide="ignore", invalid="ignore"):
                t = ((p - a)[..., 0] * (q - p)[..., 1] - (p - a)[..., 1] * (q - p)[..., 0]) / den
            t = np.where(cross, np.abs(t), np.inf)
            k = np.argmin(t, axis=1)
            found = np.isfinite(t[np.arange(len(rows)), k])
            out[rows[found]] = segs[k[found]]
        return out

    def _nearest(self, X: np.ndarray) -> np.ndarray:
        """The distance from each point ``X`` to the nearest point of ``P``.

        From a KD-tree of the first points, kept while they are unchanged (points
        are appended between calls), and one of the points appended since, as a
        tree of every point would give: built again once those are a quarter of
        the first (each refinement round appends its points; the tree of every
        point was built again each round).
        """
        n = len(self.P)
        tree, ref = self._near
        m = len(ref)
        if tree is None or 4 * (n - m) > m or not np.array_equal(self.P[:m], ref):
            tree, ref = cKDTree(self.P), self.P.copy()
            self._near = (tree, ref)
            m = n
        d, _ = tree.query(X)
        if n > m:
            d = np.minimum(d, cKDTree(self.P[m:]).query(X)[0])
        return d

    def crowded(self, X: np.ndarray, R: np.ndarray) -> np.ndarray:
        """Candidates to drop from one batch of insertions.

        Within ``merge`` times their radius of a vertex (co-circular subfaces
        give the same centre up to rounding), or within ``separation`` times
        the smaller radius of a candidate of larger radius (neighbouring
        subfaces of nearly the same circle: inserted together they would make
        an edge far shorter than the local size; the survivor's insertion
        settles the other's subface, or the next round splits it).
        """
        out = self._nearest(X) <= self.knobs.merge * R
        if len(X) > 1:
            r = self.knobs.separation * R
            # The pairs within the radius of either (widened past rounding): every pair
            # within the smaller one's, each once (i < j), as a query at the largest
            # radius gave them, with far fewer to test where the radii differ.
            i, j = ball_pairs(X, X, np.maximum(r * (1.0 + 1e-9), 1e-300))
            i, j = i[i < j], j[i < j]
            if len(i):
                # j is the one of smaller radius (ties: the later index).
                swap = (R[i] < R[j]) | ((R[i] == R[j]) & (i > j))
                i, j = np.where(swap, j, i), np.where(swap, i, j)
                dd = np.linalg.norm(X[i] - X[j], axis=1)
                out[j[dd <= np.minimum(r[i], r[j])]] = True
        return out

    def in_cylinders(self, X: np.ndarray) -> np.ndarray:
        """The sharp input edge (``edges`` row) whose protecting cylinder holds each point
        strictly inside, or -1 (the nearest such edge's; float distances).

        The cylinder of an edge: the points whose projection on the edge's line falls
        inside the edge and whose distance to that line is below ``cyl_radius``.
        """
        out = np.full(len(X), -1, dtype=np.int64)
        if len(X) == 0 or self.cyl_edge.size == 0:
            return out
        E = self.edges[self.cyl_edge]
        a, bb = self.P[E[:, 0]], self.P[E[:, 1]]
        half = 0.5 * np.linalg.norm(bb - a, axis=1)
        xi, ci = ball_pairs(X, 0.5 * (a + bb), half + self.cyl_radius)
        if xi.size == 0:
            return out
        d = bb[ci] - a[ci]
        t = np.einsum("ij,ij->i", X[xi] - a[ci], d) / np.einsum("ij,ij->i", d, d)
        off = np.linalg.norm(X[xi] - (a[ci] + t[:, None] * d), axis=1)
        inside = (t > 0) & (t < 1) & (off < self.cyl_radius[ci] * (1.0 - 1e-9))
        xi, ci, off = xi[inside], ci[inside], off[inside]
        order = np.argsort(-off, kind="stable")  # the nearest edge written last wins
        out[xi[order]] = self.cyl_edge[ci[order]]
        return out

    def in_balls(self, X: np.ndarray) -> np.ndarray:
        """The input vertex whose protecting ball holds each point strictly inside, or -1.

        The balls are disjoint (``ball_fraction`` of the local feature size),
        so the nearest ball centre decides. Float distances: a point moved
        onto a sphere by :meth:`onto_balls` counts as outside.
        """
        out = np.full(len(X), -1, dtype=np.int64)
        if len(X) == 0 or not self.ball.any():
            return out
        if self._ball_tree is None:
            self._ball_ids = np.flatnonzero(self.ball > 0)
            self._ball_tree = cKDTree(self.P[self._ball_ids])
        d, k = self._ball_tree.query(X)
        v = self._ball_ids[k]
        inside = d < self.ball[v] * (1.0 - 1e-9)
        out[inside] = v[inside]
        return out

    def onto_balls(self, X: np.ndarray, f: np.ndarray) -> np.ndarray:
        """Points of facets ``f`` inside the protecting ball of a facet corner, moved onto it.

        Along the ray from the corner (in the facet's plane, which holds the
        corner): the points a facet gets inside a protecting ball all lie on
        its sphere, so splits next to a sharp vertex stop there (Cheng and
        Poon's and Cohen-Steiner, de Verdière and Yvinec's protecting balls).
        """
        v = self.in_balls(X)
        rows = np.flatnonzero(v >= 0)
        if rows.size == 0:
            return X
        X = X.copy()
        corner = np.array(
            [
                int(vv) in set(self._corners(int(g))[0].tolist())
                for vv, g in zip(v[rows], f[rows], strict=True)
            ],
            dtype=bool,
        )
        rows = rows[corner]
        d = X[rows] - self.P[v[rows]]
        n = np.linalg.norm(d, axis=1)
        ok = n > 0
        rows, d, n = rows[ok], d[ok], n[ok]
        X[rows] = self.P[v[rows]] + (self.ball[v[rows]] / n)[:, None] * d
        return X

    def protected_segments(self, rows: np.ndarray) -> np.ndarray:
        s = self.seg[rows]
        L = np.linalg.norm(self.P[s[:, 0]] - self.P[s[:, 1]], axis=1)
        ref = np.minimum(self.edge_length[self.seg_edge[rows]], self.size_cap)
        ref = np.minimum(ref, self.segment_size(rows))
        return (L < self.knobs.protect * ref) | (L < 1.5 * self.radial_floor(s))

    def radial_floor(self, s: np.ndarray) -> np.ndarray:
        """The protecting ball radius at the one input vertex of each subsegment ``s`` (else 0)."""
        ia = s[:, 0] < self.n_surface
        ib = s[:, 1] < self.n_surface
        v = np.where(ia, s[:, 0], s[:, 1]) % self.n_surface
        return np.where(ia ^ ib, self.ball[v], 0.0)

    def protected_subfaces(self, rows: np.ndarray) -> np.ndarray:
        """Which subfaces ``rows`` are not split for encroachment: too small (``protect``)
        or with their circumcentre inside a protecting cylinder (:meth:`in_cylinders`)."""
        c, R = self.sub_circles(rows)
        g = self.sub_facet[rows]
        ref = np.minimum(np.minimum(self.facet_short[g], self.facet_size[g]), self.size_cap)
        out = R < self.knobs.protect * ref
        if self.cyl_edge.size:
            c = np.where(np.isfinite(c).all(axis=1)[:, None], c, 1e300)
            out |= self.in_cylinders(c) >= 0
        return out

    def segment_size(self, rows: np.ndarray) -> np.ndarray:
        """The size of subsegments ``rows``: the smaller ``facet_size`` of their two facets."""
        return self.facet_size[self.edge_groups[self.seg_edge[rows]]].min(axis=1)

    def _facet_triangles(self, g: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """For facets ``g`` (one per row): the pairs (row, input triangle of its facet),
        row by row, each facet's triangles in ``group_tris`` order."""
        start = self._group_start
        sizes = np.diff(start)[g]
        k = np.repeat(np.arange(len(g)), sizes)
        shift = np.repeat(start[g] - (np.cumsum(sizes) - sizes), sizes)
        j = self._by_group[np.arange(len(k)) + shift]
        return k, j

    def _sides(self, x: np.ndarray, j: np.ndarray) -> np.ndarray:
        """(k, 3): the side of each point ``x`` of the three edges of input triangle ``j``
        (positive inside; float)."""
        tri = self.facets[j]
        a, b, c = self.P[tri[:, 0]], self.P[tri[:, 1]], self.P[tri[:, 2]]
        n = np.cross(b - a, c - a)
        return np.stack(
            [
                np.einsum("ij,ij->i", np.cross(b - a, x - a), n),
                np.einsum("ij,ij->i", np.cross(c - b, x - b), n),
                np.einsum("ij,ij->i", np.cross(a - c, x - c), n),
            ],
            1,
        )

    def in_facet(self, X: np.ndarray, f: np.ndarray) -> np.ndarray:
        """Whether points (in their facet's plane) lie inside facet ``f`` (float)."""
        k, j = self._facet_triangles(f)
        inside = (self._sides(X[k], j) > 0).all(axis=1)
        return np.bincount(k[inside], minlength=len(X)) > 0

    def sources(self) -> np.ndarray:
        """The input triangle each subface lies in (the one that best holds its centroid;
        a facet of one input triangle: that one)."""
        return _sources(
            self.P, np.ascontiguousarray(self.sub, dtype=np.int64),
            np.ascontiguousarray(self.sub_facet, dtype=np.int64), self.facets,
            self._by_group, self._group_start,
        )  # fmt: skip

    # -- encroachment --------------------------------------------------------------

    def encroached_segments(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pairs (point row, subsegment) with the point in the closed diametral ball.

        Closed: a candidate point on the sphere (the circumcentre of a right
        triangle, on its hypotenuse) splits the subsegment rather than land
        next to its midpoint.

        Candidates from KD-trees of subsegment midpoints (one per power of two
        of the radius); the sign is exact
        (:func:`~meshcore.geometry.predicates3d.dot3d`).
        """
        a = self.P[self.seg[:, 0]]
        b = self.P[self.seg[:, 1]]
        mid = 0.5 * (a + b)
        half = 0.5 * np.linalg.norm(b - a, axis=1)
        xi, si = ball_pairs(X, mid, half * (1 + 1e-9))
        inside = dot3d(a[si], b[si], X[xi]) <= 0
        return xi[inside], si[inside]

    def encroached_by_vertices(self) -> tuple[np.ndarray, np.ndarray]:
        """Subsegments and subfaces with a vertex inside their diametral / equatorial ball."""
        tree = cKDTree(self.P)
        a = self.P[self.seg[:, 0]]
        b = self.P[self.seg[:, 1]]
        mid = 0.5 * (a + b)
        half = 0.5 * np.linalg.norm(b - a, axis=1)
        seg_bad = np.zeros(len(self.seg), dtype=bool)
        hits = tree.query_ball_point(mid, r=half * (1 + 1e-9))
        counts = np.fromiter((len(h) for h in hits), dtype=np.int64, count=len(hits))
        if counts.sum():
            si = np.repeat(np.arange(len(self.seg)), counts)
            pi = np.concatenate([np.asarray(h, dtype=np.int64) for h in hits if h])
            other = (pi != self.seg[si, 0]) & (pi != self.seg[si, 1])
            si, pi = si[other], pi[other]
            inside = dot3d(a[si], b[si], self.P[pi]) < 0
            seg_bad[si[inside]] = True
        o, r = self.sub_circles()
        sub_bad = np.zeros(len(self.sub), dtype=bool)
        hits = tree.query_ball_point(o, r=r * self.knobs.subface_ball)
        counts = np.fromiter((len(h) for h in hits), dtype=np.int64, count=len(hits))
        if counts.sum():
            fi = np.repeat(np.arange(len(self.sub)), counts)
            pi = np.concatenate([np.asarray(h, dtype=np.int64) for h in hits if h])
            s = self.sub[fi]
            other = (pi != s[:, 0]) & (pi != s[:, 1]) & (pi != s[:, 2])
            sub_bad[fi[other]] = True
        return np.flatnonzero(seg_bad), np.flatnonzero(sub_bad)

    def encroached_subfaces(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pairs (point row, subface) with the point inside the equatorial ball (float)."""
        o, r = self.sub_circles()
        return ball_pairs(X, o, r * self.knobs.subface_ball)

    # -- presence ------------------------------------------------------------------

    def missing(self) -> tuple[np.ndarray, np.ndarray]:
        """Subsegments that are not edges, subfaces that are not faces of the tetrahedralization.

        Each piece is looked for in the tetrahedron that held it at the last
        call (its *witness*, kept by row), else in the star of its first
        corner (:func:`_held_in_kernel`): one tetrahedron for most pieces, not a pass
        over the whole mesh.
        """
        seg_hit, sub_hit = self._held(0, self.seg), self._held(1, self.sub)
        keys = packed_edge_keys(self.seg)
        if seg_hit is None or sub_hit is None:
            seg_hit, sub_hit = self._present(keys, face_keys(self.sub))
        seg_missing = ~seg_hit
        if self.unsettled:
            seg_missing |= isin_ints(keys, np.concatenate(list(self.unsettled.values())))
        return np.flatnonzero(seg_missing), np.flatnonzero(~sub_hit)

    def _held(self, kind: int, pieces: np.ndarray) -> np.ndarray | None:
        """:func:`_held_in_kernel` on subsegments (``kind`` 0) or subfaces (1), their witnesses kept
        by row (rows added since: none); None when the kernel's vertex tetrahedra cannot
        start the walk."""
        old = self._witness[kind]
        wit = np.full(len(pieces), -1, dtype=np.int64)
        wit[: min(len(old), len(wit))] = old[: len(wit)]
        dt = self.dt
        hit, ok = _held_in_kernel(
            dt._V, dt._A, dt._vt, dt._inv, int(dt._state[_NTET]),
            np.ascontiguousarray(pieces, dtype=np.int64), wit,
        )  # fmt: skip
        if not ok:
            return None
        self._witness[kind] = wit
        return hit

    def _present(self, keys: np.ndarray, sub_keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Presence of the subsegments and subfaces by a pass over every tetrahedron."""
        seg_tk, seg_tv = _table(keys)
        sub_tk, sub_tv = _table(sub_keys)
        seg_hit, sub_hit = _present(
            np.ascontiguousarray(self.tets()[1], dtype=np.int64), self.on_surface(), seg_tk,
            seg_tv, len(keys), sub_tk, sub_tv, len(sub_keys), TET_EDGES, TET_FACES,
        )  # fmt: skip
        return seg_hit[_find_all(seg_tk, seg_tv, keys)], sub_hit[
            _find_all(sub_tk, sub_tv, sub_keys)
        ]


def recover(b: SurfaceRecovery, progress) -> int:
    """Split missing subsegments, then missing subfaces, until all are present."""
    for r in range(b.knobs.recovery_rounds):
        seg_missing, sub_missing = b.missing()
        if seg_missing.size:
            b.split_segments(seg_missing)
        elif sub_missing.size:
            b.split_subfaces(sub_missing)
        else:
            return r
        if progress is not None:
            progress(0.1, f"boundary recovery: round {r + 1}")
    raise AlgorithmError(
        f"boundary recovery did not finish in {b.knobs.recovery_rounds} rounds "
        f"({len(seg_missing)} subsegments and {len(sub_missing)} subfaces missing)",
        code="recovery_failed",
    )
