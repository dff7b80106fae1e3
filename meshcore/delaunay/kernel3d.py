"""The 3D Delaunay kernel: one Delaunay tetrahedralization of 3D points for every method.

DESIGN.md, "Our own Delaunay kernels": surface recovery, Delaunay-admissible
faces (§9.2, §9.3) and tetrahedralization stand on this kernel. Every
geometric decision is a sign from :mod:`meshcore.geometry.predicates`
(``orient3d`` and ``insphere``, exact after a float filter), so the result is
a true Delaunay tetrahedralization of the input, whatever its degeneracies.

Algorithm (a compiled sequential loop, numba ``@njit(cache=True)``):

1. Validate; rescale by a power of two (exact, changes no predicate sign) so
   that the coordinates sit in ``[-1, 1]``.
2. Order the points for insertion (:mod:`meshcore.delaunay.order3d`):
   biased randomized insertion order (BRIO, rounds of doubling size, the
   "random" draw a hash of the point index so that a run is reproducible),
   each round sorted along a 3D Hilbert curve (Skilling's transform),
   alternately forwards and backwards.
3. Incremental Bowyer-Watson insertion with *ghost tetrahedra*: each convex
   hull facet is closed by a tetrahedron on a vertex at infinity, so there is
   no enclosing tetrahedron to remove afterwards and the result is exactly
   the Delaunay tetrahedralization of the convex hull. A point is located by
   a visibility walk starting at a tetrahedron of the nearest already
   inserted point along the curve; the cavity (every tetrahedron whose
   circumsphere holds the point) is grown by depth-first search and replaced
   by the cone of its boundary faces to the point. New tetrahedra are glued
   to each other across the cavity's boundary edges
   (:mod:`meshcore.delaunay.cone3d`).

Data structure: tetrahedron ``t`` has vertex slots ``4t .. 4t+3`` in ``V``
(the vertex at infinity is -1, a freed slot -2) and ``A[4t+i] = 4u+j`` when
the face opposite slot ``i`` of ``t`` is the face opposite slot ``j`` of
``u``. A real tetrahedron is positively oriented: ``orient3d(v0, v1, v2, v3)
> 0`` in meshcore's (Shewchuk's) convention, i.e. ``v3`` lies below the
plane of ``v0, v1, v2`` seen counter-clockwise, so the face opposite ``v3``
listed as ``(v0, v1, v2)`` has its right-hand normal pointing out of the
tetrahedron. A ghost has the same orientation with the vertex at infinity
standing for a point far outside its hull facet: replacing the infinite
vertex by ``p`` gives ``orient3d > 0`` exactly when ``p`` lies strictly
beyond that facet.

Choices where the methods text leaves freedom:

* **Ties.** Co-spherical points are resolved by symbolic perturbation
  (:func:`meshcore.geometry.predicates3d.insphere_perturbed`): each point's
  lifting ``x**2 + y**2 + z**2`` is raised by ``eps**(r + 1)``, ``r`` its
  rank in lexicographic ``(x, y, z)`` order, exactly the 2D kernel's rule.
  The perturbed points are in general position, so their Delaunay
  tetrahedralization is unique, and it is a Delaunay tetrahedralization of
  the points: the tetrahedra depend only on the point *set*, not on the input
  order, and are unchanged by exact translations and power-of-two scalings.
* **Hull.** A ghost is in conflict with ``p`` when ``p`` lies strictly beyond
  its hull facet, or on the facet's plane and in conflict with the real
  tetrahedron behind the facet (the in-circle test of the facet, under the
  same perturbation). Coplanar hull points therefore become hull vertices,
  hull facets in one plane are that face's 2D Delaunay triangulation and no
  tetrahedron is flat.
* **Duplicates** are refused (``duplicate_points``, naming both indices),
  as in 2D: a caller that wants to merge them knows better which to keep.
  The incremental API instead reports the existing vertex.

Incremental API, for boundary recovery and Delaunay refinement
(:class:`IncrementalDelaunay3d`, keeping the structure between calls):
``insert`` (an :class:`Insertion`: the vertex, the slots removed and
created), ``insert_many`` (a batch in BRIO/Hilbert order, one compiled
loop), ``insert_guarded``, ``locate`` (a :class:`Location`), ``tets``,
``adjacent``, ``alive`` and ``tetrahedralization``. Vertices are numbered
as given: the initial points first, then each inserted point in turn.
Slots are stable until the tetrahedron is removed; removed slots are reused
by later insertions.

References
----------
Methods text §9.2-§9.3 (Delaunay faces and their empty spheres); DESIGN.md
"Geometry robustness" and "Our own Delaunay kernels". A. Bowyer (1981) and
D. F. Watson (1981); O. Devillers, S. Pion and M. Teillaud, "Walking in a
triangulation" (2002); N. Amenta, S. Choi and G. Rote, "Incremental
constructions con BRIO" (2003); J. Skilling, "Programming the Hilbert curve"
(2004); H. Edelsbrunner and E. Mücke, "Simulation of Simplicity" (1990);
O. Devillers and M. Teillaud, "Perturbations for Delaunay and weighted
Delaunay 3D triangulations" (2011).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numba import njit

from meshcore.delaunay.cone3d import TABLE_MIN, glue_cone
from meshcore.delaunay.kernel2d import _walk_hints
from meshcore.delaunay.order3d import insertion_order
from meshcore.delaunay.prefetch import prefetch
from meshcore.errors import InputError
from meshcore.geometry.ordering import radix_argsort
from meshcore.geometry.predicates import WORK_SIZE, orient2d_filtered
from meshcore.geometry.predicates3d import insphere_filtered, insphere_tie, orient3d_filtered
from meshcore.mesh.topology import unique_ints

__all__ = [
    "SKIP_CHANGED",
    "SKIP_DUPLICATE",
    "SKIP_OUTSIDE",
    "SKIP_STALE",
    "Insertion",
    "IncrementalDelaunay3d",
    "Location",
    "Tetrahedralization",
    "delaunay3d",
]

_O3D_ERRBOUND_A = (7.0 + 56.0 * 2.0**-53) * 2.0**-53
_ISP_ERRBOUND_A = (16.0 + 224.0 * 2.0**-53) * 2.0**-53
# Semi-static filters: Shewchuk's bound times an upper bound of the
# permanent from the largest coordinate differences (6 mx my mz for orient3d,
# 24 mx my mz (mx**2 + my**2 + mz**2) for insphere), with 2**-40 of slack for
# the few roundings of that bound (each under 2**-52 relative).
_O3D_SEMI = 6.0 * _O3D_ERRBOUND_A * (1.0 + 2.0**-40)
_ISP_SEMI = 24.0 * _ISP_ERRBOUND_A * (1.0 + 2.0**-40)
_CHUNK = 1 << 16
_MAX_POINTS = 1 << 26  # 4 * tetrahedra slots must fit int32
_MAX_SLOTS = 1 << 29  # tetrahedron slots: the adjacency's 4 * slot + 3 must fit int32
# Smallest magnitude a nonzero coordinate may have after rescaling the largest
# to [0.5, 1), and largest for points inserted later: keeps every product of
# the exact predicates a normal number.
_MIN_SCALED = 2.0**-100
_MAX_SCALED = 2.0**40

# Status codes of the compiled insertion.
_OK, _DUPLICATE, _COPLANAR, _GROW_BUFFERS, _GROW_TETS = 0, 1, 2, 3, 4
# state slots
_NTET, _NFREE, _LAST, _STAMP, _STATUS, _INFO, _NCAV, _NNEW = range(8)

#: Outward faces of a positively oriented tetrahedron: ``_FACES[i]`` lists the
#: face opposite vertex slot ``i`` with its right-hand normal pointing out.
_FACES = np.array([[1, 3, 2], [0, 2, 3], [0, 3, 1], [0, 1, 2]], np.int64)


@dataclass(frozen=True, eq=False)
class Tetrahedralization:
    """A Delaunay tetrahedralization of 3D points.

    Attributes
    ----------
    points : (n, 3) float64
        The points (read-only).
    tetra : (m, 4) int64
        Point indices of each tetrahedron, positively oriented:
        ``orient3d(p[t0], p[t1], p[t2], p[t3]) > 0`` in meshcore's (Shewchuk's)
        convention, ``t3`` below the counter-clockwise ``t0, t1, t2``
        (read-only).
    neighbors : (m, 4) int64
        ``neighbors[t, i]`` is the tetrahedron across the face opposite
        vertex ``tetra[t, i]``, or -1 when that face is on the convex hull;
        the convention of ``scipy.spatial.Delaunay`` (read-only).
    """

    points: np.ndarray
    tetra: np.ndarray
    neighbors: np.ndarray

    @cached_property
    def hull_facets(self) -> np.ndarray:
        """(k, 3) int64: the convex hull's triangles, oriented outward.

        Each is the face of a tetrahedron without neighbour, listed so that
        its right-hand normal points out of the hull.
        """
        t, i = np.nonzero(self.neighbors < 0)
        out = self.tetra[t[:, None], _FACES[i]]
        out.flags.writeable = False
        return out


@dataclass(frozen=True)
class Insertion:
    """What :meth:`IncrementalDelaunay3d.insert` did.

    Attributes
    ----------
    vertex : int
        Index of the point (an existing vertex when ``duplicate``).
    duplicate : bool
        The point coincides with vertex ``vertex``; nothing changed.
    removed : (j,) int64
        Slots of the tetrahedra (real and ghost) the insertion removed.
    created : (k,) int64
        Slots of the tetrahedra created, real and ghost (test with
        :meth:`IncrementalDelaunay3d.tets`: ghosts hold vertex -1). Removed
        slots are reused, so ``created`` and ``removed`` may share values.
    """

    vertex: int
    duplicate: bool
    removed: np.ndarray
    created: np.ndarray


@dataclass(frozen=True)
class Location:
    """Where a point lies in the tetrahedralization (:meth:`IncrementalDelaunay3d.locate`).

    Attributes
    ----------
    tet : int
        Slot of a real tetrahedron whose closure holds the point, or -1 when
        the point lies outside the convex hull.
    kind : str
        ``"inside"`` (strictly inside ``tet``), ``"face"``, ``"edge"``,
        ``"vertex"`` (on that part of its boundary) or ``"outside"``.
    vertex : int
        The vertex the point coincides with (``kind == "vertex"``), else -1.
    """

    tet: int
    kind: str
    vertex: int


# ---------------------------------------------------------------------------
# Predicates as the kernel uses them (float filter inline, exact call rare)
# ---------------------------------------------------------------------------


@njit(cache=True, inline="always")
def _orient_filter(pts, a, b, c, d):
    """orient3d of the vertices a, b, c, d by the semi-static filter: +1, -1, or 0 undecided.

    No call: numba then prunes the inlined arrays' reference counts (a call
    that may raise, the exact stage, left five atomic increments and
    decrements around every inlined test); :func:`_orient` completes it.
    """
    ax = pts[a, 0]
    ay = pts[a, 1]
    az = pts[a, 2]
    dx = pts[d, 0]
    dy = pts[d, 1]
    dz = pts[d, 2]
    adx = ax - dx
    ady = ay - dy
    adz = az - dz
    bdx = pts[b, 0] - dx
    bdy = pts[b, 1] - dy
    bdz = pts[b, 2] - dz
    cdx = pts[c, 0] - dx
    cdy = pts[c, 1] - dy
    cdz = pts[c, 2] - dz
    bdxcdy = bdx * cdy
    cdxbdy = cdx * bdy
    cdxady = cdx * ady
    adxcdy = adx * cdy
    adxbdy = adx * bdy
    bdxady = bdx * ady
    det = adz * (bdxcdy - cdxbdy) + bdz * (cdxady - adxcdy) + cdz * (adxbdy - bdxady)
    # Semi-static filter: the permanent is at most 6 mx my mz (mx the largest
    # |x difference|, ...); _O3D_SEMI covers its rounding too.
    mx = max(abs(adx), max(abs(bdx), abs(cdx)))
    my = max(abs(ady), max(abs(bdy), abs(cdy)))
    mz = max(abs(adz), max(abs(bdz), abs(cdz)))
    errbound = _O3D_SEMI * (mx * my * mz)
    if det > errbound:
        return 1
    if -det > errbound:
        return -1
    return 0


@njit(cache=True)
def _orient(pts, a, b, c, d, work):
    """orient3d of vertices a, b, c, d: semi-static filter, then the predicate."""
    s = _orient_filter(pts, a, b, c, d)
    if s != 0:
        return s
    return orient3d_filtered(
        pts[a, 0], pts[a, 1], pts[a, 2], pts[b, 0], pts[b, 1], pts[b, 2],
        pts[c, 0], pts[c, 1], pts[c, 2], pts[d, 0], pts[d, 1], pts[d, 2], work,
    )  # fmt: skip


@njit(cache=True, inline="always")
def _insphere_filter(pts, a, b, c, d, e):
    """Insphere sign of e against positive (a, b, c, d) by the semi-static filter; 0 undecided.

    No call (see :func:`_orient_filter`); :func:`_insphere` completes it.
    """
    ex = pts[e, 0]
    ey = pts[e, 1]
    ez = pts[e, 2]
    aex = pts[a, 0] - ex
    aey = pts[a, 1] - ey
    aez = pts[a, 2] - ez
    bex = pts[b, 0] - ex
    bey = pts[b, 1] - ey
    bez = pts[b, 2] - ez
    cex = pts[c, 0] - ex
    cey = pts[c, 1] - ey
    cez = pts[c, 2] - ez
    dex = pts[d, 0] - ex
    dey = pts[d, 1] - ey
    dez = pts[d, 2] - ez
    aexbey = aex * bey
    bexaey = bex * aey
    bexcey = bex * cey
    cexbey = cex * bey
    cexdey = cex * dey
    dexcey = dex * cey
    dexaey = dex * aey
    aexdey = aex * dey
    aexcey = aex * cey
    cexaey = cex * aey
    bexdey = bex * dey
    dexbey = dex * bey
    ab = aexbey - bexaey
    bc = bexcey - cexbey
    cd = cexdey - dexcey
    da = dexaey - aexdey
    ac = aexcey - cexaey
    bd = bexdey - dexbey
    abc = aez * bc - bez * ac + cez * ab
    bcd = bez * cd - cez * bd + dez * bc
    cda = cez * da + dez * ac + aez * cd
    dab = dez * ab + aez * bd + bez * da
    alift = aex * aex + aey * aey + aez * aez
    blift = bex * bex + bey * bey + bez * bez
    clift = cex * cex + cey * cey + cez * cez
    dlift = dex * dex + dey * dey + dez * dez
    det = (dlift * abc - clift * dab) + (blift * cda - alift * bcd)
    # Semi-static filter: the permanent is at most 24 mx my mz (mx**2 + my**2
    # + mz**2), mx the largest |x difference|, ...; _ISP_SEMI covers its
    # rounding too. Undecided cases (rare on random points) go to the exact
    # predicate, whose first stage is the permanent-bounded double-double.
    mx = max(max(abs(aex), abs(bex)), max(abs(cex), abs(dex)))
    my = max(max(abs(aey), abs(bey)), max(abs(cey), abs(dey)))
    mz = max(max(abs(aez), abs(bez)), max(abs(cez), abs(dez)))
    errbound = _ISP_SEMI * ((mx * my) * mz) * ((mx * mx + my * my) + mz * mz)
    if det > errbound:
        return 1
    if -det > errbound:
        return -1
    return 0


@njit(cache=True)
def _insphere_tail(ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz, ex, ey, ez, work):
    """Perturbed insphere sign where the semi-static filter failed; never 0.

    predicates3d.insphere_filtered (Shewchuk's bound from the permanent, then
    the exact predicate), exact ties to insphere_tie (the symbolic
    perturbation of insphere_perturbed). Coordinates and one scratch array
    only: a cheap call from the hot loops.
    """
    s = insphere_filtered(ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz, ex, ey, ez, work)
    if s != 0:
        return s
    rows = np.empty((5, 3))
    rows[0, 0], rows[0, 1], rows[0, 2] = ax, ay, az
    rows[1, 0], rows[1, 1], rows[1, 2] = bx, by, bz
    rows[2, 0], rows[2, 1], rows[2, 2] = cx, cy, cz
    rows[3, 0], rows[3, 1], rows[3, 2] = dx, dy, dz
    rows[4, 0], rows[4, 1], rows[4, 2] = ex, ey, ez
    return insphere_tie(rows, work)


@njit(cache=True, inline="always")
def _insphere_rest(pts, a, b, c, d, e, work):
    """:func:`_insphere_tail` of the vertices a, b, c, d, e."""
    return _insphere_tail(
        pts[a, 0], pts[a, 1], pts[a, 2], pts[b, 0], pts[b, 1], pts[b, 2],
        pts[c, 0], pts[c, 1], pts[c, 2], pts[d, 0], pts[d, 1], pts[d, 2],
        pts[e, 0], pts[e, 1], pts[e, 2], work,
    )  # fmt: skip


@njit(cache=True, inline="always")
def _replaced(V, b, j, p):
    """The vertices of the tetrahedron at slots b..b+3 with slot j replaced by p."""
    w0 = p if j == 0 else V[b]
    w1 = p if j == 1 else V[b + 1]
    w2 = p if j == 2 else V[b + 2]
    w3 = p if j == 3 else V[b + 3]
    return w0, w1, w2, w3


@njit(cache=True)
def _orient_replaced(pts, V, b, j, p, work):
    """orient3d of the tetrahedron at slots b..b+3 with slot j replaced by p."""
    w0, w1, w2, w3 = _replaced(V, b, j, p)
    return _orient(pts, w0, w1, w2, w3, work)


@njit(cache=True, inline="always")
def _ghost_slot(V, b):
    """Slot of the vertex at infinity in the tetrahedron at b, or -1 if real."""
    for j in range(4):
        if V[b + j] < 0:
            return j
    return -1


@njit(cache=True, inline="always")
def _conflict_filter(pts, V, t, p):
    """Is tetrahedron t in conflict with point p: 1 yes, 0 no, -1 undecided by the filters.

    No call (see :func:`_orient_filter`); exact: :func:`_insphere_rest`, :func:`_ghost_conflict`.
    """
    b = 4 * t
    v0 = V[b]
    v1 = V[b + 1]
    v2 = V[b + 2]
    v3 = V[b + 3]
    if (v0 | v1 | v2 | v3) >= 0:  # real: no vertex at infinity (-1)
        s = _insphere_filter(pts, v0, v1, v2, v3, p)
    else:
        w0, w1, w2, w3 = _replaced(V, b, _ghost_slot(V, b), p)
        s = _orient_filter(pts, w0, w1, w2, w3)
    if s == 0:
        return -1
    return 1 if s > 0 else 0


@njit(cache=True)
def _ghost_conflict(pts, V, A, t, p, work):
    """Exact conflict of ghost t with p: beyond its facet, or on it and in the sphere behind."""
    b = 4 * t
    j = _ghost_slot(V, b)
    o = _orient_replaced(pts, V, b, j, p, work)
    if o != 0:
        return o > 0
    r = 4 * (A[b + j] >> 2)
    s = _insphere_filter(pts, V[r], V[r + 1], V[r + 2], V[r + 3], p)
    return (s if s != 0 else _insphere_rest(pts, V[r], V[r + 1], V[r + 2], V[r + 3], p, work)) > 0


# ---------------------------------------------------------------------------
# Compiled insertion
# ---------------------------------------------------------------------------


@njit(cache=True)
def _walk(pts, V, A, t, p, work):
    """Visibility walk from tetrahedron t towards p.

    Returns the real tetrahedron whose closure holds p, or the ghost whose
    hull facet p lies strictly beyond. t must be alive; a ghost start steps
    to its real neighbour first.
    """
    b = 4 * t
    j = _ghost_slot(V, b)
    if j >= 0:
        t = A[b + j] >> 2
    prev = -1
    off = p & 3
    while True:
        b = 4 * t
        if _ghost_slot(V, b) >= 0:
            return t
        moved = False
        for ii in range(4):
            i = (ii + off) & 3
            u = A[b + i] >> 2
            if u == prev:
                continue
            w0, w1, w2, w3 = _replaced(V, b, i, p)
            o = _orient_filter(pts, w0, w1, w2, w3)
            if o == 0:
                o = _orient(pts, w0, w1, w2, w3, work)
            if o < 0:
                prev = t
                t = u
                moved = True
                break
        if not moved:
            return t
        off = (off + 1) & 3


@njit(cache=True, inline="always")
def _insert(pts, p, start, V, A, mark, vt, free, state, cav, bnd, newv, newslot, hkey, hval, work):
    """Insert vertex p (its coordinates in pts[p]) walking from tetrahedron start.

    Sets state[_STATUS]: _OK (state[_NCAV] removed slots in cav, state[_NNEW]
    created slots in newslot), _DUPLICATE (state[_INFO] the vertex it
    coincides with), _GROW_BUFFERS or _GROW_TETS (nothing changed: enlarge
    and call again). Inlined into the compiled loops (a call reference-counts
    its arrays at every insertion: 6 % of the time at 300k random points).
    """
    t = _walk(pts, V, A, start, p, work)
    b = 4 * t
    if _ghost_slot(V, b) < 0:
        for k in range(4):
            v = V[b + k]
            if pts[v, 0] == pts[p, 0] and pts[v, 1] == pts[p, 1] and pts[v, 2] == pts[p, 2]:
                state[_STATUS] = _DUPLICATE
                state[_INFO] = v
                return
    stamp = state[_STAMP] + 1
    state[_STAMP] = stamp
    inside = 2 * stamp
    outside = inside + 1
    # --- cavity: depth-first search over conflicting tetrahedra -----------
    ncav_max = cav.shape[0]
    nbnd_max = bnd.shape[0]
    cav[0] = t
    mark[t] = inside
    nc = 1
    nb = 0
    i = 0
    while i < nc:
        c = cav[i]
        i += 1
        # The four neighbours and their marks are read first, as independent
        # loads: their cache misses overlap instead of following one another.
        bc = 4 * c
        u0 = A[bc] >> 2
        u1 = A[bc + 1] >> 2
        u2 = A[bc + 2] >> 2
        u3 = A[bc + 3] >> 2
        m0 = mark[u0]
        m1 = mark[u1]
        m2 = mark[u2]
        m3 = mark[u3]
        # Their vertex and adjacency rows too, ahead of use: the rows are read
        # by the conflict tests and when a cavity tetrahedron is searched, the
        # outer ones' adjacency written when the cone is glued to them.
        prefetch(V, 4 * u0)
        prefetch(V, 4 * u1)
        prefetch(V, 4 * u2)
        prefetch(V, 4 * u3)
        prefetch(A, 4 * u0)
        prefetch(A, 4 * u1)
        prefetch(A, 4 * u2)
        prefetch(A, 4 * u3)
        for f in range(4):
            u = u0 if f == 0 else (u1 if f == 1 else (u2 if f == 2 else u3))
            mu = m0 if f == 0 else (m1 if f == 1 else (m2 if f == 2 else m3))
            if mu == inside:
                continue
            if mu != outside:
                r = _conflict_filter(pts, V, u, p)
                if r < 0:
                    bu = 4 * u
                    if (V[bu] | V[bu + 1] | V[bu + 2] | V[bu + 3]) >= 0:
                        s = _insphere_rest(pts, V[bu], V[bu + 1], V[bu + 2], V[bu + 3], p, work)
                    else:
                        s = 1 if _ghost_conflict(pts, V, A, u, p, work) else -1
                    r = 1 if s > 0 else 0
                if r > 0:
                    if nc == ncav_max:
                        state[_STATUS] = _GROW_BUFFERS
                        return
                    mark[u] = inside
                    cav[nc] = u
                    nc += 1
                    continue
                mark[u] = outside
            if nb == nbnd_max:
                state[_STATUS] = _GROW_BUFFERS
                return
            bnd[nb] = bc + f
            nb += 1
    if 8 * nb > hkey.shape[0]:
        state[_STATUS] = _GROW_BUFFERS
        return
    ntet = state[_NTET]
    nfree = state[_NFREE]
    if nb > nc + nfree + (mark.shape[0] - ntet):
        state[_STATUS] = _GROW_TETS
        return
    # --- read the cone's tetrahedra before their slots are reused --------
    for k in range(nb):
        corner = bnd[k]
        c = corner >> 2
        f = corner & 3
        for s in range(4):
            newv[4 * k + s] = V[4 * c + s]
        newv[4 * k + f] = p
        newslot[k] = f  # the face slot, until the tetrahedron's slot is known
        bnd[k] = A[corner]  # the outer corner across the face
    # --- allocate slots: cavity slots first, then freed ones, then new -----
    for k in range(nb):
        f = newslot[k]
        if k < nc:
            s = cav[k]
        elif nfree > 0:
            nfree -= 1
            s = free[nfree]
        else:
            s = ntet
            ntet += 1
        bs = 4 * s
        for q in range(4):
            V[bs + q] = newv[4 * k + q]
        oc = bnd[k]
        A[bs + f] = oc
        A[oc] = bs + f
        newslot[k] = s
        bnd[k] = f
    # Slots of the cavity not reused go to the free list.
    for k in range(nb, nc):
        s = cav[k]
        for q in range(4):
            V[4 * s + q] = -2
        free[nfree] = s
        nfree += 1
    # --- glue the new tetrahedra to each other across their faces through p
    glue_cone(A, vt, newslot, bnd, newv, nb, hkey, hval)
    # --- walk starts -------------------------------------------------------
    last = state[_LAST]
    for k in range(nb):
        s = newslot[k]
        bs = 4 * s
        if V[bs] >= 0 and V[bs + 1] >= 0 and V[bs + 2] >= 0 and V[bs + 3] >= 0:
            vt[V[bs]] = s
            vt[V[bs + 1]] = s
            vt[V[bs + 2]] = s
            vt[V[bs + 3]] = s
            last = s
    state[_NTET] = ntet
    state[_NFREE] = nfree
    state[_LAST] = last
    state[_NCAV] = nc
    state[_NNEW] = nb
    state[_STATUS] = _OK


@njit(cache=True)
def _insert_range(
    pts, hint, V, A, mark, vt, free, state, cav, bnd, newv, newslot, hkey, hval, work, lo, hi
):
    """Insert vertices lo..hi-1; stops at the first one not _OK (state[_INFO+...])."""
    for p in range(lo, hi):
        h = hint[p]
        start = state[_LAST]
        if h >= 0:
            s = vt[h]
            if V[4 * s] != -2:
                start = s
        _insert(
            pts, p, start, V, A, mark, vt, free, state, cav, bnd, newv, newslot, hkey, hval, work,
        )  # fmt: skip
        if state[_STATUS] != _OK:
            return p
    return hi


#: Codes of :meth:`IncrementalDelaunay3d.insert_guarded` for points not inserted.
SKIP_STALE, SKIP_CHANGED, SKIP_OUTSIDE, SKIP_DUPLICATE = -1, -2, -3, -4


@njit(cache=True)
def _insert_guarded(
    pts, n, Q, origin, allowed, stale, V, A, mark, vt, free, state, cav, bnd, newv, newslot,
    hkey, hval, work, k0, out,
):  # fmt: skip
    """Insert Q[k0:] in turn (see :meth:`IncrementalDelaunay3d.insert_guarded`).

    Vertex n is the next free one. Returns the first index not handled (the
    buffers or slots must grow: state[_STATUS]) or len(Q).
    """
    for k in range(k0, Q.shape[0]):
        s = origin[k]
        if stale[s]:
            out[k] = SKIP_STALE
            continue
        pts[n, 0] = Q[k, 0]
        pts[n, 1] = Q[k, 1]
        pts[n, 2] = Q[k, 2]
        t = _walk(pts, V, A, s, n, work)
        if stale[t]:
            out[k] = SKIP_CHANGED
            continue
        if _ghost_slot(V, 4 * t) >= 0 or not allowed[t]:
            out[k] = SKIP_OUTSIDE
            continue
        _insert(
            pts, n, t, V, A, mark, vt, free, state, cav, bnd, newv, newslot, hkey, hval, work,
        )  # fmt: skip
        status = state[_STATUS]
        if status == _DUPLICATE:
            out[k] = SKIP_DUPLICATE
            continue
        if status != _OK:
            return k
        for i in range(state[_NCAV]):
            stale[cav[i]] = True
        for i in range(state[_NNEW]):
            stale[newslot[i]] = True
        out[k] = n
        n += 1
    return Q.shape[0]


@njit(cache=True)
def _collinear(pts, a, b, c, work):
    """Exactly collinear: zero orientation in the three coordinate planes."""
    for k in range(3):
        u = k
        v = (k + 1) % 3
        if (
            orient2d_filtered(
                pts[a, u], pts[a, v], pts[b, u], pts[b, v], pts[c, u], pts[c, v], work
            )
            != 0
        ):
            return False
    return True


@njit(cache=True)
def _start(pts, order, n, V, A, vt, state, work):
    """First tetrahedron and its four ghosts; moves its corners to rows 0..3.

    state[_STATUS]: _OK, _DUPLICATE (rows 0 and 1 coincide) or _COPLANAR.
    """
    if pts[0, 0] == pts[1, 0] and pts[0, 1] == pts[1, 1] and pts[0, 2] == pts[1, 2]:
        state[_STATUS] = _DUPLICATE
        state[_INFO] = 1
        return
    i0, i1, i2, i3 = np.int64(0), np.int64(1), np.int64(2), np.int64(3)  # no literal copies
    k = i2
    while k < n and _collinear(pts, i0, i1, k, work):
        k += 1
    if k == n:
        state[_STATUS] = _COPLANAR
        return
    _swap_rows(pts, order, i2, k)
    m = i3
    while m < n and _orient(pts, i0, i1, i2, m, work) == 0:
        m += 1
    if m == n:
        state[_STATUS] = _COPLANAR
        return
    _swap_rows(pts, order, i3, m)
    a, b = 0, 1
    if _orient(pts, i0, i1, i2, i3, work) < 0:
        a, b = 1, 0
    V[0], V[1], V[2], V[3] = a, b, 2, 3
    for i in range(4):
        g = 4 * (i + 1)
        for q in range(4):
            V[g + q] = V[q]
        V[g + i] = -1
        # swap the first two slots other than i: the ghost faces outward
        s1 = 0 if i != 0 else 1
        s2 = s1 + 1 if s1 + 1 != i else s1 + 2
        tmp = V[g + s1]
        V[g + s1] = V[g + s2]
        V[g + s2] = tmp
    # glue the five tetrahedra by their shared faces
    for t in range(5):
        for f in range(4):
            for u in range(5):
                if u == t:
                    continue
                for e in range(4):
                    same = 0
                    for q in range(4):
                        if q == f:
                            continue
                        for r in range(4):
                            if r != e and V[4 * u + r] == V[4 * t + q]:
                                same += 1
                    if same == 3:
                        A[4 * t + f] = 4 * u + e
    for v in range(4):
        vt[v] = 0
    state[_NTET] = 5
    state[_NFREE] = 0
    state[_LAST] = 0
    state[_STATUS] = _OK


@njit(cache=True)
def _swap_rows(pts, order, i, j):
    if i == j:
        return
    for c in range(3):
        tmp = pts[i, c]
        pts[i, c] = pts[j, c]
        pts[j, c] = tmp
    tmp = order[i]
    order[i] = order[j]
    order[j] = tmp


def _slot_tables(cap: int) -> tuple[np.ndarray, np.ndarray]:
    """The vertex and adjacency tables of ``cap`` slots (int32): the two halves of one
    buffer, where :func:`delaunay3d` then writes its int64 tetrahedra (:func:`_output`)."""
    both = np.empty(8 * cap, np.int32)
    return both[: 4 * cap], both[4 * cap :]


@njit(cache=True)
def _slot_rows(V, ntet, ids):
    """``ids[t]``: the output row of slot ``t`` (real tetrahedra in slot order), -1 for
    ghosts and free slots; returns the number of rows."""
    m = 0
    for t in range(ntet):
        b = 4 * t
        if V[b] >= 0 and V[b + 1] >= 0 and V[b + 2] >= 0 and V[b + 3] >= 0:
            ids[t] = m
            m += 1
        else:
            ids[t] = -1
    return m


@njit(cache=True)
def _tetra_rows(V, ids, order, tetra):
    """``tetra[ids[t]]``: slot ``t``'s vertices as external point indices."""
    for t in range(ids.shape[0]):
        r = ids[t]
        if r >= 0:
            for i in range(4):
                tetra[r, i] = order[V[4 * t + i]]


@njit(cache=True)
def _tetra_in_place(both, ids, m, order):
    """:func:`_tetra_rows` into the memory of the slot tables (``both``, vertices then
    adjacency, int32): the rows are first moved down to their output rows (``ids[t] <=
    t``), then widened to int64 from the last one down (row r's eight words only cover
    rows from r on, already read). The adjacency is lost."""
    for t in range(ids.shape[0]):
        r = ids[t]
        if 0 <= r < t:
            for i in range(4):
                both[4 * r + i] = both[4 * t + i]
    wide = both.view(np.int64)
    for r in range(m - 1, -1, -1):
        b = 4 * r
        v0, v1, v2, v3 = both[b], both[b + 1], both[b + 2], both[b + 3]
        wide[b] = order[v0]
        wide[b + 1] = order[v1]
        wide[b + 2] = order[v2]
        wide[b + 3] = order[v3]


@njit(cache=True)
def _neighbor_rows(A, ids, m):
    """The neighbour table of the rows ``ids`` numbers: -1 across the hull (a ghost)."""
    out = np.empty((m, 4), np.int64)
    for t in range(ids.shape[0]):
        r = ids[t]
        if r >= 0:
            for i in range(4):
                out[r, i] = ids[A[4 * t + i] >> 2]
    return out


def _output(builder: IncrementalDelaunay3d, release: bool = False):
    """Real tetrahedra (rows in slot order) as external point indices, and their neighbours.

    ``release`` (:func:`delaunay3d`, done with ``builder``): the structure is
    emptied, the slots' rows written in its mark table, and the tetrahedra
    written over its vertex and adjacency tables once the neighbours are read:
    only the (m, 4) int64 neighbours are new memory (at 1M random points 216
    MB, beside the tables' 224 MB, which then hold the tetrahedra).
    """
    V, A, order = builder._V, builder._A, builder._order
    ntet = int(builder._state[_NTET])
    if not release:
        ids = np.empty(ntet, np.int32)
        m = _slot_rows(V, ntet, ids)
        tetra = np.empty((m, 4), np.int64)
        _tetra_rows(V, ids, order, tetra)
        return tetra, _neighbor_rows(A, ids, m)
    ids = builder._mark[:ntet]
    vars(builder).clear()
    m = _slot_rows(V, ntet, ids)
    neighbors = _neighbor_rows(A, ids, m)
    both = V.base
    _tetra_in_place(both, ids, m, order)
    return both.view(np.int64)[: 4 * m].reshape(m, 4), neighbors


@njit(cache=True)
def _scan(pts):
    """(all finite, max |coordinate|, min nonzero |coordinate|) in one pass."""
    big = 0.0
    small = np.inf
    for i in range(pts.shape[0]):
        for c in range(3):
            x = pts[i, c]
            if not np.isfinite(x):
                return False, 0.0, 0.0
            x = abs(x)
            big = max(big, x)
            if x > 0.0:
                small = min(small, x)
    return True, big, small


@njit(cache=True)
def _gather(pts, order, factor):
    out = np.empty((order.shape[0], 3))
    for i in range(order.shape[0]):
        j = order[i]
        for c in range(3):
            out[i, c] = pts[j, c] * factor
    return out


# ---------------------------------------------------------------------------
# Validation
# ---------------------------------------------------------------------------


def _validated(points, name: str = "points") -> np.ndarray:
    try:
        pts = np.asarray(points, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(
            f"{name} must be an (n, 3) array of numbers", loc=(name,), code="bad_shape"
        ) from exc
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise InputError(
            f"{name} must have shape (n, 3), got {pts.shape}", loc=(name,), code="bad_shape"
        )
    finite, _, _ = _scan(pts)
    if not finite:
        rows = np.flatnonzero((~np.isfinite(pts)).any(axis=1))
        raise InputError(
            f"{rows.size} point(s) have a non-finite coordinate, first point {rows[0]}",
            code="non_finite",
            errors=[
                {
                    "loc": [name, int(i)],
                    "msg": f"point {i} has a non-finite coordinate",
                    "type": "non_finite",
                }
                for i in rows[:20]
            ],
        )
    return pts


def _scale_factor(pts: np.ndarray) -> float:
    """Power of two bringing max |coordinate| into [0.5, 1) (exact scaling)."""
    _, big, small = _scan(pts)
    if big == 0.0:
        return 1.0
    e = int(np.frexp(big)[1])
    if small < np.inf and np.ldexp(small, -e) < _MIN_SCALED:
        raise InputError(
            "coordinate magnitudes span more than 2**100: the exact predicates would "
            "underflow; round tiny coordinates to zero or split the input",
            loc=("points",),
            code="coordinates_out_of_range",
        )
    return float(np.ldexp(1.0, -e))


def _duplicates_error(pts: np.ndarray) -> InputError:
    """An InputError naming duplicate points (all groups, up to 20)."""
    order = np.lexsort((pts[:, 2], pts[:, 1], pts[:, 0]))
    s = pts[order]
    same = np.flatnonzero((s[1:] == s[:-1]).all(axis=1))
    pairs = sorted(tuple(sorted((int(order[k]), int(order[k + 1])))) for k in same[:20])
    first = pairs[0]
    return InputError(
        f"{same.size} duplicate point pair(s); first: points {first[0]} and {first[1]} "
        f"coincide at {pts[first[0]].tolist()}",
        code="duplicate_points",
        errors=[
            {
                "loc": ["points", b],
                "msg": f"point {b} duplicates point {a}",
                "type": "duplicate_points",
            }
            for a, b in pairs
        ],
    )


def _has_duplicates(pts: np.ndarray) -> bool:
    s = pts[np.lexsort((pts[:, 2], pts[:, 1], pts[:, 0]))]
    return bool((s[1:] == s[:-1]).all(axis=1).any())


# ---------------------------------------------------------------------------
# The incremental structure and the public entry point
# ---------------------------------------------------------------------------


class IncrementalDelaunay3d:
    """A Delaunay tetrahedralization that accepts further points.

    Parameters
    ----------
    points : (n, 3) float64
        Initial points: distinct, finite, not all coplanar, ``n >= 4``.
    progress : callable, optional
        ``progress(fraction, message)`` between batches of the initial
        insertions; it may raise to stop.

    Notes
    -----
    Every operation keeps the structure the exact Delaunay
    tetrahedralization of the points inserted so far (ties broken as in
    :func:`delaunay3d`, so the result depends only on the point set).
    Vertex ``i`` is the i-th initial point, then the inserted points in turn.
    Later points may lie anywhere (outside the hull too) but are scaled by
    the initial points' power-of-two factor: their coordinates must stay
    within 2**40 times the initial points' largest. See the module
    docstring for the data structure. References: methods text §9.2-§9.3;
    DESIGN.md "Our own Delaunay kernels".

    Raises
    ------
    InputError
        As :func:`delaunay3d`.
    """

    def __init__(self, points, *, progress: Callable[[float, str], None] | None = None) -> None:
        pts_in = _validated(points)
        n = len(pts_in)
        if n >= _MAX_POINTS:
            raise InputError(
                f"at most {_MAX_POINTS - 1} points can be tetrahedralized at once, got {n}",
                loc=("points",),
                code="too_many_points",
            )
        if n < 4:
            raise InputError(
                f"a tetrahedralization needs at least 4 points, got {n}",
                loc=("points",),
                code="too_few_points",
            )
        self._factor = _scale_factor(pts_in)
        order, curve = insertion_order(pts_in, 0)
        curve = curve[order]
        along = radix_argsort(curve)
        hint = _walk_hints(along, curve[along])
        del curve, along
        cap_pts = n + 16
        self._pts = np.empty((cap_pts, 3))
        self._pts[:n] = _gather(pts_in, order, self._factor)
        self._order = np.empty(cap_pts, np.int64)
        self._order[:n] = order
        self._inv = np.empty(cap_pts, np.int64)
        self._n = n
        cap = 7 * n + 64
        self._V, self._A = _slot_tables(cap)
        self._mark = np.zeros(cap, np.int32)
        self._free = np.empty(cap, np.int32)
        self._vt = np.zeros(cap_pts, np.int32)
        self._state = np.zeros(8, np.int64)
        self._work = np.empty(WORK_SIZE)
        self._alloc_buffers(256)
        _start(self._pts, self._order, n, self._V, self._A, self._vt, self._state, self._work)
        status = int(self._state[_STATUS])
        if status == _DUPLICATE:
            raise _duplicates_error(pts_in)
        self._inv[self._order[:n]] = np.arange(n)
        if status == _COPLANAR:
            if _has_duplicates(pts_in):
                raise _duplicates_error(pts_in)
            raise InputError(
                f"all {n} points are coplanar: there is no tetrahedron to make",
                loc=("points",),
                code="coplanar_points",
            )
        # The start moved rows to 0..3: hints naming them are stale, but a
        # hint is only a walk's starting point (any alive tetrahedron will do).
        done = 4
        while done < n:
            stop = min(n, done + _CHUNK)
            while done < stop:
                done = self._run(hint, done, stop, pts_in)
            if progress is not None:
                progress(done / n, f"inserted {done} of {n} points")

    # -- internals ---------------------------------------------------------

    def _alloc_buffers(self, size: int) -> None:
        self._cav = np.empty(size, np.int32)
        self._bnd = np.empty(2 * size, np.int32)
        self._newv = np.empty(8 * size, np.int32)
        self._newslot = np.empty(2 * size, np.int32)
        hsize = max(1 << int(np.ceil(np.log2(8 * size))), TABLE_MIN)
        self._hkey = np.empty(hsize, np.int64)
        self._hval = np.empty(hsize, np.int32)

    def _grow_tets(self) -> None:
        cap = self._mark.shape[0]
        if cap >= _MAX_SLOTS:  # int32 slot numbers would wrap around
            raise InputError(
                f"the tetrahedralization needs more than {_MAX_SLOTS} tetrahedra, the most "
                f"the kernel's tables hold ({self._n} points; a random set needs about 7 a point)",
                loc=("points",),
                code="too_many_points",
            )
        new = min(2 * cap, _MAX_SLOTS)
        V, A = _slot_tables(new)
        V[: self._V.size] = self._V
        A[: self._A.size] = self._A
        self._V, self._A = V, A
        mark = np.zeros(new, np.int32)
        mark[:cap] = self._mark
        self._mark = mark
        free = np.empty(new, np.int32)
        free[:cap] = self._free
        self._free = free

    def _handle(self, status: int) -> None:
        if status == _GROW_BUFFERS:
            self._alloc_buffers(2 * self._cav.shape[0])
        elif status == _GROW_TETS:
            self._grow_tets()

    def _run(self, hint, lo, hi, pts_in) -> int:
        stop = _insert_range(
            self._pts, hint, self._V, self._A, self._mark, self._vt, self._free, self._state,
            self._cav, self._bnd, self._newv, self._newslot, self._hkey, self._hval,
            self._work, lo, hi,
        )  # fmt: skip
        if stop < hi:
            status = int(self._state[_STATUS])
            if status == _DUPLICATE and pts_in is not None:
                raise _duplicates_error(pts_in)
            self._handle(status)
        return stop

    def _scaled(self, point, name: str) -> np.ndarray:
        q = _validated(np.reshape(np.asarray(point, dtype=np.float64), (-1, 3)), name)
        q = q * self._factor
        a = np.abs(q)
        if (a > _MAX_SCALED).any() or ((a > 0) & (a < _MIN_SCALED)).any():
            raise InputError(
                f"{name} is out of the range the exact predicates allow for this "
                "tetrahedralization (more than 2**40 times the initial points' extent, "
                "or a nonzero coordinate below 2**-100 of it)",
                loc=(name,),
                code="coordinates_out_of_range",
            )
        return q

    def _ensure_points(self, extra: int) -> None:
        cap = self._pts.shape[0]
        if self._n + extra <= cap:
            return
        new = max(2 * cap, self._n + extra)
        pts = np.empty((new, 3))
        pts[: self._n] = self._pts[: self._n]
        order = np.empty(new, np.int64)
        order[: self._n] = self._order[: self._n]
        inv = np.empty(new, np.int64)
        inv[: self._n] = self._inv[: self._n]
        vt = np.zeros(new, np.int32)
        vt[: self._n] = self._vt[: self._n]
        self._pts, self._order, self._inv, self._vt = pts, order, inv, vt

    # -- public ------------------------------------------------------------

    @property
    def n_points(self) -> int:
        """Number of vertices."""
        return self._n

    @property
    def points(self) -> np.ndarray:
        """(n, 3) float64: the vertices, in vertex order (a copy)."""
        out = np.empty((self._n, 3))
        out[self._order[: self._n]] = self._pts[: self._n] / self._factor
        return out

    def insert(self, point, *, near: int | None = None) -> Insertion:
        """Insert one point; the structure stays Delaunay.

        Parameters
        ----------
        point : (3,) float64
        near : int, optional
            A vertex close to the point, where the search starts (default:
            the last tetrahedron created).

        Returns
        -------
        Insertion
            The new vertex (or the coinciding one, ``duplicate=True``) and the
            slots of the tetrahedra removed and created.
        """
        q = self._scaled(point, "point")[0]
        self._ensure_points(1)
        p = self._n
        self._pts[p] = q
        self._order[p] = p
        start = int(self._state[_LAST])
        if near is not None:
            try:  # a string, NaN or infinity is no integer either (int() raises)
                integral = near == int(near)
            except (TypeError, ValueError, OverflowError):
                integral = False
            if not integral:
                raise InputError(
                    f"near must be an integer, got {near!r}", loc=("near",), code="bad_parameter"
                )
            if not 0 <= near < self._n:
                raise InputError(
                    f"near must be a vertex index in [0, {self._n}), got {near}",
                    loc=("near",),
                    code="bad_vertex",
                )
            s = int(self._vt[self._inv[int(near)]])
            if self._V[4 * s] != -2:
                start = s
        while True:
            _insert(
                self._pts, p, start, self._V, self._A, self._mark, self._vt, self._free,
                self._state, self._cav, self._bnd, self._newv, self._newslot, self._hkey,
                self._hval, self._work,
            )  # fmt: skip
            status = int(self._state[_STATUS])
            if status == _OK:
                break
            if status == _DUPLICATE:
                v = int(self._order[int(self._state[_INFO])])
                empty = np.empty(0, np.int64)
                return Insertion(vertex=v, duplicate=True, removed=empty, created=empty)
            self._handle(status)
        self._inv[p] = p
        self._n += 1
        removed = self._cav[: int(self._state[_NCAV])].astype(np.int64)
        created = self._newslot[: int(self._state[_NNEW])].astype(np.int64)
        return Insertion(vertex=p, duplicate=False, removed=removed, created=created)

    def insert_many(self, points) -> np.ndarray:
        """Insert a batch of points (in BRIO / Hilbert order); their vertex indices.

        Parameters
        ----------
        points : (k, 3) float64

        Returns
        -------
        (k,) int64
            The vertex of each point: a new one, or the existing vertex it
            coincides with (duplicates within the batch map to the first).
        """
        q = self._scaled(points, "points")
        k = len(q)
        out = np.empty(k, np.int64)
        if k == 0:
            return out
        src, _ = insertion_order(q, self._n)  # the point at row n0 + i, in insertion order
        n0, hi = self._n, self._n + k
        self._ensure_points(k)
        self._pts[n0:hi] = q[src]
        self._order[n0:hi] = self._inv[n0:hi] = np.arange(n0, hi)  # provisional: the rows
        hint = np.empty(hi, np.int32)  # each walk starts at the last vertex inserted (int32:
        # the dtype of _walk_hints', one compiled _insert_range)
        hint[n0:] = np.concatenate([[-1], np.arange(n0, hi - 1)])
        p = n0
        while p < hi:  # one compiled loop, left only to grow buffers or at a duplicate
            p = self._run(hint, p, hi, None)
            if p < hi and int(self._state[_STATUS]) == _DUPLICATE:
                out[src[p - n0]] = self._order[int(self._state[_INFO])]
                self._pts[p : hi - 1] = self._pts[p + 1 : hi]  # the next points move up a row
                src[p - n0 : hi - n0 - 1] = src[p - n0 + 1 : hi - n0].copy()
                hi -= 1
        out[src[: hi - n0]] = np.arange(n0, hi)
        self._n = hi
        if self._n == n0:  # every point coincided with a vertex
            return out
        # Renumber the new vertices in batch order: the first new point of
        # the batch becomes vertex n0, the next n0 + 1, ...
        new = np.flatnonzero(out >= n0)
        _, at = unique_ints(out[new], return_index=True)
        provisional = out[new[np.sort(at)]]  # in batch order
        final = n0 + np.arange(provisional.size)
        relabel = np.empty(self._n - n0, np.int64)
        relabel[provisional - n0] = final
        internal = self._inv[provisional]
        self._order[internal] = final
        self._inv[final] = internal
        return np.where(out >= n0, relabel[np.maximum(out - n0, 0)], out)

    def insert_guarded(self, points, origin, allowed) -> np.ndarray:
        """Insert points in turn, each only where the structure is as it was.

        The batch form of Delaunay refinement's lazy queue: point ``k`` was
        computed from the tetrahedron at slot ``origin[k]`` (alive when the
        call starts). It is skipped (code ``SKIP_STALE``) when an earlier
        insertion of the batch removed that tetrahedron, ``SKIP_CHANGED``
        when it lies in a tetrahedron an earlier insertion created,
        ``SKIP_OUTSIDE`` when it lies outside the convex hull or in a
        tetrahedron whose slot is not ``allowed`` (``allowed[s]`` for the
        slots alive at the start; e.g. tetrahedra outside the meshed
        region), ``SKIP_DUPLICATE`` on an existing vertex. One compiled loop:
        the walk starts at the origin tetrahedron, every sign exact.

        Parameters
        ----------
        points : (k, 3) float64
        origin : (k,) int
            Slots of real tetrahedra alive at the call (else ``InputError``).
        allowed : (s,) bool
            Per slot; slots beyond its length are not allowed.

        Returns
        -------
        (k,) int64
            The new vertex of each point (numbered in turn from
            :attr:`n_points`), or its negative skip code.
        """
        q = self._scaled(points, "points")
        k = len(q)
        out = np.empty(k, np.int64)
        if k == 0:
            return out
        self._ensure_points(k)
        org = np.asarray(origin, dtype=np.int64)
        V = self._V.reshape(-1, 4)
        if len(org) != k or not (
            ((org >= 0) & (org < int(self._state[_NTET]))).all() and (V[org] >= 0).all()
        ):
            raise InputError(
                "origin must give one alive real tetrahedron slot per point",
                loc=("origin",),
                code="bad_slot",
            )
        ok = np.asarray(allowed, dtype=np.bool_)
        n0 = self._n
        k0 = 0
        stale = np.zeros(0, np.bool_)
        while True:
            cap = self._mark.shape[0]
            if stale.shape[0] < cap:
                grown = np.zeros(cap, np.bool_)
                grown[: min(cap, len(ok))] = ok[:cap]
                ok = grown
                st = np.zeros(cap, np.bool_)
                st[: stale.shape[0]] = stale
                stale = st
            n = n0 + int((out[:k0] >= 0).sum())
            k0 = _insert_guarded(
                self._pts, n, q, org, ok, stale, self._V, self._A, self._mark, self._vt,
                self._free, self._state, self._cav, self._bnd, self._newv, self._newslot,
                self._hkey, self._hval, self._work, k0, out,
            )  # fmt: skip
            if k0 == k:
                break
            self._handle(int(self._state[_STATUS]))
        m = int((out >= 0).sum())
        new = np.arange(n0, n0 + m)
        self._order[new] = new
        self._inv[new] = new
        self._n = n0 + m
        return out

    def locate(self, point) -> Location:
        """Where ``point`` lies: a real tetrahedron whose closure holds it, and how.

        Returns
        -------
        Location
            ``tet`` -1 and ``kind == "outside"`` when the point is outside the
            convex hull.
        """
        q = self._scaled(point, "point")[0]
        self._ensure_points(1)
        p = self._n
        self._pts[p] = q
        t = int(_walk(self._pts, self._V, self._A, int(self._state[_LAST]), p, self._work))
        b = 4 * t
        verts = self._V[b : b + 4]
        if (verts < 0).any():
            return Location(tet=-1, kind="outside", vertex=-1)
        for v in verts:
            if (self._pts[v] == q).all():
                return Location(tet=t, kind="vertex", vertex=int(self._order[v]))
        zeros = sum(
            int(_orient_replaced(self._pts, self._V, b, i, p, self._work) == 0) for i in range(4)
        )
        kind = {0: "inside", 1: "face", 2: "edge"}[zeros]
        return Location(tet=t, kind=kind, vertex=-1)

    def tets(self, slots) -> np.ndarray:
        """(k, 4) int64: the vertices of the tetrahedra at ``slots`` (-1: infinity)."""
        s = np.asarray(slots, dtype=np.int64)
        v = self._V.reshape(-1, 4)[s].astype(np.int64)
        return np.where(v >= 0, self._order[np.maximum(v, 0)], -1)

    def adjacent(self, slots) -> np.ndarray:
        """(k, 4) int64: the slot across the face opposite each vertex slot."""
        s = np.asarray(slots, dtype=np.int64)
        return (self._A.reshape(-1, 4)[s] >> 2).astype(np.int64)

    def alive(self) -> np.ndarray:
        """(m,) int64: the slots of the real tetrahedra."""
        v = self._V.reshape(-1, 4)[: int(self._state[_NTET])]
        return np.flatnonzero((v >= 0).all(axis=1))

    def tetrahedralization(self) -> Tetrahedralization:
        """The current tetrahedralization, compacted (rows in slot order)."""
        tetra, neighbors = _output(self)
        pts = self.points
        for arr in (pts, tetra, neighbors):
            arr.flags.writeable = False
        return Tetrahedralization(points=pts, tetra=tetra, neighbors=neighbors)


def delaunay3d(points, progress: Callable[[float, str], None] | None = None) -> Tetrahedralization:
    """Delaunay tetrahedralization of 3D points, exact and deterministic.

    Parameters
    ----------
    points : (n, 3) float64
        Distinct, finite points, not all coplanar; ``n >= 4``.
    progress : callable, optional
        ``progress(fraction, message)``, called between batches of
        insertions; it may raise (e.g. :class:`~meshcore.errors.Cancelled`)
        to stop.

    Returns
    -------
    Tetrahedralization
        Positively oriented tetrahedra (``orient3d > 0``, see
        :class:`Tetrahedralization`) tiling exactly the convex hull of the
        points, each point a vertex, every interior face locally Delaunay by
        the exact insphere test; neighbours as ``scipy.spatial.Delaunay``;
        ``hull_facets`` the hull's triangles oriented outward.

    Raises
    ------
    InputError
        ``bad_shape`` (not an ``(n, 3)`` array), ``too_few_points`` (fewer
        than 4), ``non_finite`` (NaN or infinite coordinates, naming the
        points), ``duplicate_points`` (naming the coinciding indices),
        ``coplanar_points`` (all points on one plane),
        ``coordinates_out_of_range`` (nonzero coordinates more than 2**100
        times smaller than the largest), ``too_many_points`` (2**26 or more,
        or a placement needing more than 2**29 tetrahedra, such as tens of
        thousands of points on a moment curve).

    Notes
    -----
    Co-spherical ties are broken by symbolic perturbation of the liftings in
    lexicographic order of the points (module docstring): the set of
    tetrahedra depends only on the point set, and is unchanged by exact
    translations and power-of-two scalings. The order of the output rows and
    the starting vertex of each row are deterministic for a given input
    array but otherwise unspecified.

    Cost: a radix sort of the insertion keys plus O(n) insertions of expected
    constant work, in compiled code. Memory: 40 bytes a tetrahedron slot
    while inserting (vertices, adjacency, mark, free list: int32), then the
    int64 neighbours (32 bytes a tetrahedron) beside the vertex and adjacency
    tables, whose memory then holds the int64 tetrahedra: at 1M random points
    (6.75M tetrahedra) about 545 MB at the peak.

    References
    ----------
    Methods text §9.2-§9.3; DESIGN.md "Our own Delaunay kernels".
    """
    pts_in = _validated(points)
    builder = IncrementalDelaunay3d(pts_in, progress=progress)
    tetra, neighbors = _output(builder, release=True)
    pts_out = pts_in if pts_in is not points else pts_in.copy()
    for arr in (pts_out, tetra, neighbors):
        arr.flags.writeable = False
    return Tetrahedralization(points=pts_out, tetra=tetra, neighbors=neighbors)
