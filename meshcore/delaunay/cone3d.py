"""Gluing the cone of a 3D Bowyer-Watson insertion: the new tetrahedra's faces through the point.

:mod:`meshcore.delaunay.kernel3d` replaces the cavity of a new point ``p`` by
the cone of the cavity's boundary faces to ``p``. Each new tetrahedron keeps
its outer neighbour across its boundary face; its three other faces hold ``p``
and an edge of the boundary, and the cavity's boundary is a closed surface
(a topological sphere, the vertex at infinity one of its vertices), so every
boundary edge joins exactly two boundary faces and the two cone tetrahedra on
them share the face through ``p`` and that edge. :func:`glue_cone` finds the
pairs; the adjacency it writes depends only on the cone, not on how the pairs
are found.

Small cavities (at most 58 boundary faces, so at most 31 boundary vertices
besides the one at infinity: nearly every insertion of points in general
position) number their boundary vertices locally and pair the directed edges
in a dense 32 x 32 table: each boundary face lists its edges in the outward
orientation of the cavity, so the face across edge ``a -> b`` lists ``b -> a``,
and the table is written once and read once, with no clearing, hashing or
probing (the approach of HXT's ``computeAdjacenciesFast``, C. Marot, J.
Pellerin and J.-F. Remacle, "One machine, one minute, three billion
tetrahedra", 2019). Larger cavities key the undirected edges in an open
addressing hash table cleared per insertion.

References
----------
Methods text §9.2-§9.3; DESIGN.md "Our own Delaunay kernels".
"""

from __future__ import annotations

import numpy as np
from numba import njit

_FIB64 = np.int64(-7046029254386353131)  # 0x9E3779B97F4A7C15 as int64
#: Most boundary faces glued through the dense table: a closed surface with
#: nb triangles has nb / 2 + 2 vertices, at most 31 local numbers 1..31 here
#: (0 is the vertex at infinity).
_DENSE_FACES = 58
_DENSE = 32
#: The least size of :func:`glue_cone`'s ``hval``: the dense table.
TABLE_MIN = _DENSE * _DENSE


@njit(cache=True, inline="always")
def glue_cone(A, vt, newslot, bnd, newv, nb, hkey, hval):
    """Glue the cone tetrahedra ``newslot[:nb]`` to each other across their faces through p.

    ``bnd[k]`` is the slot of p in tetrahedron ``newslot[k]``, whose vertices
    are ``newv[4 k : 4 k + 4]`` (the other three slots a cavity boundary face,
    in the outward orientation of :data:`meshcore.delaunay.kernel3d._FACES`).
    Writes the adjacency ``A`` of the three faces through p of each. ``newv``
    is then scratch, and so is ``vt`` (the vertices' walk starts, all >= 0
    between insertions) for the boundary vertices' local numbers: the caller
    writes their walk starts afterwards. ``hkey`` (at least 8 nb entries) and
    ``hval`` (at least 8 nb and :data:`TABLE_MIN`) are scratch. Inlined: a call
    would add reference counting of its arrays to every insertion.
    """
    # A boundary that is not one sphere (only predicates disagreeing with each
    # other would make one) may number more than 32 vertices: the dense table
    # would be written past its end, unchecked. The hash takes the local numbers.
    if nb <= _DENSE_FACES and _number_locally(vt, bnd, newv, nb) <= _DENSE:
        _glue_dense(A, newslot, bnd, newv, nb, hval)
    else:
        _glue_hashed(A, newslot, bnd, newv, nb, hkey, hval)


@njit(cache=True, inline="always")
def _number_locally(vt, bnd, newv, nb):
    """Each boundary vertex's local number, 1.. (0 at infinity), in newv in place of the
    vertex; vt holds it negated meanwhile (walk starts are >= 0). Returns the next one."""
    nid = 1
    for k in range(nb):
        f = bnd[k]
        for q in range(4):
            if q != f:
                w = newv[4 * k + q]
                lid = 0
                if w >= 0:
                    x = vt[w]
                    fresh = x >= 0
                    lid = nid if fresh else -x
                    vt[w] = -lid
                    nid += fresh
                newv[4 * k + q] = lid
    return nid


@njit(cache=True, inline="always")
def _glue_dense(A, newslot, bnd, newv, nb, table):
    # The outward face opposite p lists slots (f1, f2, f3) = _FACES[f]; its
    # directed edge f1 -> f2 belongs to the face through p opposite f3, etc.
    for k in range(nb):
        bs = 4 * newslot[k]
        f1, f2, f3 = _outward(bnd[k])
        a = newv[4 * k + f1]
        b = newv[4 * k + f2]
        c = newv[4 * k + f3]
        table[a * _DENSE + b] = bs + f3
        table[b * _DENSE + c] = bs + f1
        table[c * _DENSE + a] = bs + f2
    for k in range(nb):
        bs = 4 * newslot[k]
        f1, f2, f3 = _outward(bnd[k])
        a = newv[4 * k + f1]
        b = newv[4 * k + f2]
        c = newv[4 * k + f3]
        A[bs + f3] = table[b * _DENSE + a]
        A[bs + f1] = table[c * _DENSE + b]
        A[bs + f2] = table[a * _DENSE + c]


@njit(cache=True, inline="always")
def _outward(f):
    """kernel3d._FACES[f]: the face opposite slot f, its normal pointing out."""
    if f == 0:
        return 1, 3, 2
    if f == 1:
        return 0, 2, 3
    if f == 2:
        return 0, 3, 1
    return 0, 1, 2


@njit(cache=True, inline="always")
def _glue_hashed(A, newslot, bnd, newv, nb, hkey, hval):
    # The face (p, x, y) of two cone tetrahedra is keyed by the boundary edge
    # (x, y), met exactly twice. Open addressing, table cleared per insertion.
    hsize = 16
    while hsize < 8 * nb:  # load at most 3/8 (each edge keyed twice, one tombstone)
        hsize *= 2
    for h in range(hsize):
        hkey[h] = -1
    big = np.int64(1) << 31
    mask = hsize - 1
    for k in range(nb):
        s = newslot[k]
        bs = 4 * s
        f = bnd[k]
        for g in range(4):
            if g == f:
                continue
            x = np.int64(-1)
            y = np.int64(-1)
            for q in range(4):
                if q != f and q != g:
                    w = np.int64(newv[4 * k + q])
                    if w < 0:
                        w = big - 1
                    if x < 0:
                        x = w
                    else:
                        y = w
            if x > y:
                x, y = y, x
            key = x * big + y
            # Fibonacci hashing: bits 32.. of the product mix both vertices.
            h = ((key * _FIB64) >> 32) & mask
            while True:
                kk = hkey[h]
                if kk == -1:
                    hkey[h] = key
                    hval[h] = bs + g
                    break
                if kk == key:
                    other = hval[h]
                    A[bs + g] = other
                    A[other] = bs + g
                    hkey[h] = -2  # tombstone: lookups probe past it
                    break
                h = (h + 1) & mask
