"""Second stage of generation in the plane (§8.3.3): points inserted to reach size and quality.

The first stage (:mod:`.kernel2d`) ends with a valid mesh on the boundary
points only. §8.3.3 proposes to "start again while point insertions may be
used"; the text leaves open where the points go and which sub-topology each
replaces. Here, on the same store (:class:`meshcore.mesh.tetstore.CellStore`):

1. **Pairs** (:func:`delaunay_pairs`). Every pair of adjacent triangles (the
   text's second sub-topology) whose shared edge is not the Delaunay one is
   replaced by Op(Q, δ𝒮), Q the end of the other diagonal: of the two
   triangulations of a convex quadrilateral the Delaunay one has the larger
   least angle (Lawson), so this is criterion (8.2) with the least angle as
   the quality (Sur ties: both are valid). The in-circle sign is exact
   (:func:`meshcore.geometry.predicates.incircle_filtered`); boundary edges
   have one triangle and are never replaced. Lawson's flips end with the
   constrained Delaunay triangulation of the points.
2. **Insertion** (:func:`refine`). A triangle is *bad* when its least angle
   is under ``min_angle`` or its circumradius exceeds ``CIRCUMRADIUS *
   size`` (unless its longest edge is a boundary segment, which cannot be
   split). Bad triangles wait on a stack, those an insertion makes
   on top (the points go in near each other; a queue by shortest edge, as
   Triangle's, took twice as long for the same least angle). Each gets
   a point G (:func:`meshcore.delaunay.cdt.steiner_point`): its circumcentre,
   or Üngör's off-centre when that is nearer
   (on the bisector of the shortest edge, where that edge sees G under a
   little more than ``min_angle``: fewer points). 𝒮 is the connected set
   of triangles, grown across interior edges from the one holding G, whose
   circumcircle holds G strictly (exact in-circle): the sub-topology that
   Op(G, δ𝒮) replaces by the Delaunay triangles on G. Every new triangle is
   checked positive (exact orient2d) and δ𝒮 checked to be one cycle with
   every vertex of 𝒮 on it (no vertex removed) before the replacement; G is
   a new point, so the validity condition of §8.3.3 holds. Sur is unchanged
   (the mesh stays valid) and the mesh stays constrained Delaunay.
3. **Boundary kept.** No point goes on a boundary segment. When G lies
   behind one, or in its open diametral disk (exact sign) nearer it than
   √3/2 min(its length, ``size``) (the whole disk for a segment up to
   ``size``: Ruppert's rule; a band along a longer, coarse one, so that the
   interior is still refined), the point on the segment's inner bisector at
   that height (the equilateral apex) is tried instead; when that fails
   too, the triangle is given up (counted). A
   point budget bounds the stage (:data:`BUDGET_FACTOR`).

References
----------
Methods text §8.3.2-§8.3.3 (sub-topologies, Op(P, δ𝒯), (8.1)-(8.2), the
second stage with insertion); C. L. Lawson (1977); A. Üngör, "Off-centers"
(2004); J. R. Shewchuk, "Delaunay refinement algorithms for triangular mesh
generation" (2002).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from meshcore.delaunay.cdt import steiner_point
from meshcore.geometry.predicates import (
    WORK_SIZE,
    dot2d_filtered,
    incircle_filtered,
    orient2d_filtered,
)
from meshcore.mesh.tetstore import (
    N_FREE,
    N_PTS,
    N_ROWS,
    STAMP,
    link_row,
    room,
    take_row,
)
from meshcore.optimize.kernel2d import edge_index, find_edge

#: Kernel statuses: done, out of point rows, out of triangle rows, out of stack, budget reached.
DONE, NEED_POINTS, NEED_ROWS, NEED_STACK, BUDGET = range(5)
#: ``counts`` entries: pair replacements, circumcentres or off-centres, segment apexes, given up.
K_FLIP, K_STEINER, K_APEX, K_GIVEN_UP = range(4)
#: A triangle whose circumradius exceeds this times ``size`` is split (an equilateral
#: triangle of side ``size`` has circumradius 0.577 ``size``; ``triangulate``'s bound).
CIRCUMRADIUS = 0.8
#: Steps of the walk to the triangle holding G before it gives up.
WALK_MAX = 1 << 16
#: Üngör's off-centre at this times cot(min_angle / 2) times the shortest edge from its
#: midpoint (a little under a half: the new triangle's least angle a little over the bound).
OFFCENTRE = 0.475
#: The stage adds at most this many times the points the size calls for (plus the boundary's).
BUDGET_FACTOR = 8

_HALF_SQRT3 = 0.5 * math.sqrt(3.0)

# insertion outcomes
_OK, _FAIL, _ENCROACH = 0, 1, 2


@njit(cache=True)
def neighbours(T, alive, rows, n):
    """``(len(T), 3)``: N[t, j] the row across edge T[t, j] -> T[t, j + 1], -1 on the boundary.

    From the edges grouped by vertex (:func:`.kernel2d.edge_index`): the cost does not
    depend on vertex degrees (the initial fan has a vertex in every triangle).
    """
    N = np.full((T.shape[0], 3), -1, np.int64)
    start, dst, slot = edge_index(T, alive, rows, n)
    for a in range(n):
        for i in range(start[a], start[a + 1]):
            r = find_edge(start, dst, dst[i], a)
            if r >= 0:
                N[slot[i] // 3, slot[i] % 3] = slot[r] // 3
    return N


@njit(cache=True, inline="always")
def _redirect(T, N, x, p, q, t):
    """In triangle x (if any), the edge p -> q now has triangle t across it."""
    if x >= 0:
        for j in range(3):
            if T[x, j] == p and T[x, (j + 1) % 3] == q:
                N[x, j] = t


@njit(cache=True)
def delaunay_pairs(P, T, N, alive, head, nxt, prv, cnt, work):
    """Lawson's flips over every pair of adjacent triangles until none is replaced.

    A pair (a, b, c), (b, a, d) becomes (a, d, c), (d, b, c), in the same
    two rows, when d lies strictly inside the circumcircle of (a, b, c) and
    both new triangles are positive (exact). ``N`` (:func:`neighbours`) is
    kept up to date; the corner lists are relinked at the end. Returns the
    number of replacements.
    """
    rows = cnt[N_ROWS]
    stack = np.empty(max(rows, 16), np.int64)
    # rows taken in bit-reversed order (0, rows/2, rows/4, 3 rows/4, ...): the initial fan's
    # rows run round the boundary, and flipping them in turn makes long cascades
    bits = 1
    while (1 << bits) < rows:
        bits += 1
    key = np.empty(rows, np.int64)
    for t in range(rows):
        r, x = 0, t
        for _ in range(bits):
            r = (r << 1) | (x & 1)
            x >>= 1
        key[t] = r
    top = 0
    for t in np.argsort(key)[::-1]:
        if alive[t]:
            stack[top] = t
            top += 1
    flips = 0
    while top > 0:
        top -= 1
        t = stack[top]
        for j in range(3):
            u = N[t, j]
            if u < 0:
                continue
            a, b, c = T[t, j], T[t, (j + 1) % 3], T[t, (j + 2) % 3]
            ju = 0
            while T[u, ju] != b:
                ju += 1
            d = T[u, (ju + 2) % 3]
            if (
                incircle_filtered(
                    P[a, 0], P[a, 1], P[b, 0], P[b, 1], P[c, 0], P[c, 1], P[d, 0], P[d, 1], work
                )
                <= 0
            ):
                continue
            if (
                orient2d_filtered(P[a, 0], P[a, 1], P[d, 0], P[d, 1], P[c, 0], P[c, 1], work) <= 0
                or orient2d_filtered(P[d, 0], P[d, 1], P[b, 0], P[b, 1], P[c, 0], P[c, 1], work)
                <= 0
            ):
                continue
            x_ad, x_db = N[u, (ju + 1) % 3], N[u, (ju + 2) % 3]
            x_bc, x_ca = N[t, (j + 1) % 3], N[t, (j + 2) % 3]
            T[t, 0], T[t, 1], T[t, 2] = a, d, c
            T[u, 0], T[u, 1], T[u, 2] = d, b, c
            N[t, 0], N[t, 1], N[t, 2] = x_ad, u, x_ca
            N[u, 0], N[u, 1], N[u, 2] = x_db, x_bc, t
            _redirect(T, N, x_ad, d, a, t)
            _redirect(T, N, x_bc, c, b, u)
            if top + 2 > len(stack):
                grown = np.empty(2 * len(stack), np.int64)
                grown[:top] = stack[:top]
                stack = grown
            stack[top] = t
            stack[top + 1] = u
            top += 2
            flips += 1
            break
    _relink(T, alive, head, nxt, prv, cnt, head.shape[0])
    return flips


@njit(cache=True)
def _bad(P, T, N, t, sin2, r2max):
    """Whether triangle t is bad.

    Bad: the least angle under the bound (sin² under ``sin2``), or the
    squared circumradius over ``r2max`` unless the longest edge is a
    boundary segment (it cannot be split).
    """
    a, b, c = T[t, 0], T[t, 1], T[t, 2]
    ux, uy = P[b, 0] - P[a, 0], P[b, 1] - P[a, 1]
    vx, vy = P[c, 0] - P[a, 0], P[c, 1] - P[a, 1]
    l2 = ux * ux + uy * uy  # edge a-b
    l1 = vx * vx + vy * vy  # edge c-a
    l0 = (vx - ux) ** 2 + (vy - uy) ** 2  # edge b-c
    lo = min(l0, l1, l2)
    hi = max(l0, l1, l2)
    cross = ux * vy - uy * vx
    # the least angle is opposite the shortest edge: sin^2 = (2A)^2 / (product of the others)
    if cross * cross < sin2 * (l0 * l1 * l2 / lo):
        return True
    if l0 * l1 * l2 > 4.0 * r2max * cross * cross:
        j = 0 if hi == l2 else (1 if hi == l0 else 2)
        return N[t, j] >= 0  # the longest edge is not a boundary segment
    return False


@njit(cache=True)
def _locate(P, T, N, t, x, y, work, out):
    """Walk from triangle t to the one holding (x, y): ``out[0]`` its row.

    Returns _OK; _ENCROACH with the boundary edge crossed in ``out[1:3]``
    (its triangle in ``out[0]``) when (x, y) lies behind a boundary segment;
    _FAIL past :data:`WALK_MAX`.
    """
    for _ in range(WALK_MAX):
        moved = False
        for j in range(3):
            a, b = T[t, j], T[t, (j + 1) % 3]
            if orient2d_filtered(P[a, 0], P[a, 1], P[b, 0], P[b, 1], x, y, work) < 0:
                u = N[t, j]
                if u < 0:
                    out[0] = t
                    out[1] = a
                    out[2] = b
                    return _ENCROACH
                t = u
                moved = True
                break
        if not moved:
            out[0] = t
            return _OK
    return _FAIL


@njit(cache=True)
def _encroaches(P, a, b, x, y, size, work):
    """Whether (x, y) is too near the boundary segment a -> b to go in.

    In its open diametral disk (exact sign) and nearer its line than the
    apex height :func:`_apex` uses: for a segment up to ``size`` long, the
    whole disk (Ruppert's rule); for a longer one (kept coarse), a band
    along it, so that the interior can still be refined to ``size``.
    """
    if dot2d_filtered(P[a, 0], P[a, 1], P[b, 0], P[b, 1], x, y, work) > 0:
        return False
    dx, dy = P[b, 0] - P[a, 0], P[b, 1] - P[a, 1]
    L = math.sqrt(dx * dx + dy * dy)
    dist = abs(dx * (y - P[a, 1]) - dy * (x - P[a, 0])) / L
    return dist < _HALF_SQRT3 * min(L, size)


@njit(cache=True)
def _apex(P, a, b, size):
    """The point on the inner bisector of segment a -> b at √3/2 min(|ab|, size) from it: the
    apex of the equilateral triangle on a segment up to ``size`` long."""
    dx, dy = P[b, 0] - P[a, 0], P[b, 1] - P[a, 1]
    L = math.sqrt(dx * dx + dy * dy)
    f = _HALF_SQRT3 * min(L, size) / L
    return 0.5 * (P[a, 0] + P[b, 0]) - f * dy, 0.5 * (P[a, 1] + P[b, 1]) + f * dx


@njit(cache=True)
def _insert(P, T, N, alive, freeT, cnt, fixed, t, x, y, size, work, sc, tmark, vmark, vpos, out):
    """Op(G, δ𝒮) for G = (x, y) and 𝒮 its Delaunay cavity, reached by a walk from triangle t.

    ``sc`` is scratch ``(4, rows)``. Returns _OK (the new triangles' rows in
    ``sc[0, :out[3]]``), _FAIL (nothing changed), or _ENCROACH with the
    boundary segment in ``out[1:3]`` and its triangle in ``out[0]``.
    """
    r = _locate(P, T, N, t, x, y, work, out)
    if r != _OK:
        return r
    cav, eu, ej, en = sc[0], sc[1], sc[2], sc[3]
    cnt[STAMP] += 1
    stamp = cnt[STAMP]
    t0 = out[0]
    cav[0] = t0
    tmark[t0] = stamp
    k = 1
    i = 0
    while i < k:
        s = cav[i]
        i += 1
        for j in range(3):
            u = N[s, j]
            if u < 0 or tmark[u] == stamp or tmark[u] == -stamp:  # -stamp: tested, outside
                continue
            c0, c1, c2 = T[u, 0], T[u, 1], T[u, 2]
            if (
                incircle_filtered(
                    P[c0, 0], P[c0, 1], P[c1, 0], P[c1, 1], P[c2, 0], P[c2, 1], x, y, work
                )
                > 0
            ):
                tmark[u] = stamp
                cav[k] = u
                k += 1
            else:
                tmark[u] = -stamp
    # δ𝒮: the edges of 𝒮 whose other side is outside 𝒮 (a triangle, or none: a segment)
    nb = 0
    for i in range(k):
        s = cav[i]
        for j in range(3):
            u = N[s, j]
            if u >= 0 and tmark[u] == stamp:
                continue
            a, b = T[s, j], T[s, (j + 1) % 3]
            if u < 0 and _encroaches(P, a, b, x, y, size, work):
                out[0] = s
                out[1] = a
                out[2] = b
                return _ENCROACH
            if orient2d_filtered(P[a, 0], P[a, 1], P[b, 0], P[b, 1], x, y, work) <= 0:
                return _FAIL
            if nb >= k + 2:  # more edges than a disk without interior vertices has
                return _FAIL
            eu[nb] = s
            ej[nb] = j
            nb += 1
    if nb != k + 2:
        return _FAIL
    for e in range(nb):
        a = T[eu[e], ej[e]]
        if vmark[a] == stamp:  # a vertex twice on δ𝒮: not one simple cycle
            return _FAIL
        vmark[a] = stamp
        vpos[a] = e
    for e in range(nb):  # the cycle closes: every edge's end starts another edge
        if vmark[T[eu[e], (ej[e] + 1) % 3]] != stamp:
            return _FAIL
    g = cnt[N_PTS]
    cnt[N_PTS] += 1
    P[g, 0] = x
    P[g, 1] = y
    fixed[g] = 0
    # the outside triangles and their edges, before the cavity's rows are reused
    for e in range(nb):
        s, j = eu[e], ej[e]
        a, b = T[s, j], T[s, (j + 1) % 3]
        u = N[s, j]
        eu[e] = a
        ej[e] = b
        en[e] = u
    for i in range(k):  # rows freed; the corner lists are rebuilt at the end of refine
        alive[cav[i]] = 0
        freeT[cnt[N_FREE]] = cav[i]
        cnt[N_FREE] += 1
    for e in range(nb):
        t = take_row(alive, freeT, cnt)
        T[t, 0] = eu[e]
        T[t, 1] = ej[e]
        T[t, 2] = g
        cav[e] = t
    for e in range(nb):
        t = cav[e]
        u = en[e]
        N[t, 0] = u
        if u >= 0:
            for jj in range(3):
                if T[u, jj] == ej[e] and T[u, (jj + 1) % 3] == eu[e]:
                    N[u, jj] = t
        N[t, 1] = cav[vpos[ej[e]]]  # b -> g: the new triangle starting at b
        N[cav[vpos[ej[e]]], 2] = t
    out[3] = nb
    return _OK


@njit(cache=True)
def refine(P, T, N, alive, head, nxt, prv, freeT, cnt, fixed, ver, stack, prm, budget, counts):
    """Insert points at bad triangles until none is left (module docstring, step 2).

    ``prm``: sin² of ``min_angle``, the squared circumradius bound, the
    off-centre factor, ``size``. Bad triangles wait on ``stack`` (rows, and their
    versions ``ver`` that tell a reused row), filled from every live row
    first; the new bad triangles of an insertion go on top, so the points
    go in near each other (memory locality: a queue ordered by size jumps
    around the mesh and took twice as long). Returns DONE, BUDGET
    (``budget`` points reached), or NEED_POINTS / NEED_ROWS / NEED_STACK:
    the caller grows that and calls again (growing the store renumbers its
    rows: ``N`` is made again and the stack filled again). The kernel keeps
    ``N`` (:func:`neighbours`) up to date, not the corner lists: they are
    relinked on return.
    """
    sin2, r2max, off, size = prm[0], prm[1], prm[2], prm[3]
    work = np.empty(WORK_SIZE)
    mcap = T.shape[0]
    sc = np.empty((4, mcap + 2), np.int64)
    tmark = np.zeros(mcap, np.int64)
    vmark = np.zeros(P.shape[0], np.int64)
    vpos = np.zeros(P.shape[0], np.int64)
    out = np.zeros(4, np.int64)
    top = 0
    for t in range(cnt[N_ROWS]):
        if alive[t] and _bad(P, T, N, t, sin2, r2max):
            if top >= stack.shape[1]:
                _relink(T, alive, head, nxt, prv, cnt, P.shape[0])
                return NEED_STACK
            stack[0, top] = t
            stack[1, top] = ver[t]
            top += 1
    while top > 0:
        if cnt[N_PTS] >= budget:
            _relink(T, alive, head, nxt, prv, cnt, P.shape[0])
            return BUDGET
        if cnt[N_PTS] + 2 > P.shape[0]:
            _relink(T, alive, head, nxt, prv, cnt, P.shape[0])
            return NEED_POINTS
        if not room(T, cnt, 4):
            _relink(T, alive, head, nxt, prv, cnt, P.shape[0])
            return NEED_ROWS
        top -= 1
        t, v = stack[0, top], stack[1, top]
        if not alive[t] or ver[t] != v:
            continue
        x, y = steiner_point(P, T[t, 0], T[t, 1], T[t, 2], off)
        r = _FAIL if not (math.isfinite(x) and math.isfinite(y)) else _ENCROACH
        kind = K_STEINER
        s = t
        while r == _ENCROACH:
            r = _insert(
                P, T, N, alive, freeT, cnt, fixed, s, x, y, size, work, sc, tmark, vmark, vpos, out
            )  # fmt: skip
            if r == _ENCROACH and kind == K_STEINER:  # the apex on the segment, inside
                s = out[0]
                x, y = _apex(P, out[1], out[2], size)
                kind = K_APEX
            elif r == _ENCROACH:
                r = _FAIL
        if r != _OK:
            counts[K_GIVEN_UP] += 1
            continue
        counts[kind] += 1
        for e in range(out[3]):
            s = sc[0, e]
            ver[s] += 1
            if _bad(P, T, N, s, sin2, r2max):
                if top >= stack.shape[1]:
                    _relink(T, alive, head, nxt, prv, cnt, P.shape[0])
                    return NEED_STACK
                stack[0, top] = s
                stack[1, top] = ver[s]
                top += 1
    _relink(T, alive, head, nxt, prv, cnt, P.shape[0])
    return DONE


@njit(cache=True)
def _relink(T, alive, head, nxt, prv, cnt, n):
    """The corner lists of the live rows rebuilt."""
    head[:n] = -1
    for t in range(cnt[N_ROWS]):
        if alive[t]:
            link_row(T, head, nxt, prv, t)
