"""Constrained Delaunay triangulations: segment recovery, regions, Delaunay refinement.

The compiled kernels behind :func:`meshcore.triangulation.refinement.triangulate`. They
take the Delaunay triangulation of :func:`meshcore.delaunay.kernel2d.delaunay` (never
another one), recover missing segments by edge flips, keep the triangles of
the domain by region, and refine by inserting circumcentres and segment
split points one at a time (Bowyer-Watson cavities that never cross a
segment). Every sign is an exact predicate of
:mod:`meshcore.geometry.predicates` behind a float filter; the refinement
*criteria* (is an angle small, is a triangle large) are float comparisons of
lengths, not signs, and cannot make the mesh invalid.

Data structure (the one of :mod:`meshcore.delaunay.kernel2d`, without ghosts): triangle
``t`` has corners ``3t, 3t+1, 3t+2``, counter-clockwise. ``V[k]`` is the
vertex at corner ``k``; the edge of corner ``k`` is the one opposite it,
from ``V[nxt(k)]`` to ``V[prv(k)]`` (counter-clockwise in ``t``); ``A[k]``
is the corner of the neighbouring triangle opposite the same edge, or -1 on
the border of the triangulation; ``S[k]`` is the id of the input segment the
edge lies on, or -1 (the same on both sides of the edge). ``vt[p]`` is some
triangle having ``p`` as a vertex.

Algorithms, each a sequential loop (a stack or a queue) in numba:

* **Segment recovery** (``keep_boundary`` and any segment that the Delaunay
  triangulation misses): the edges crossed by the segment are collected by a
  walk from one endpoint and flipped away in a queue (a flip only when the
  quadrilateral is strictly convex, else the edge goes to the back of the
  queue; Sloan, 1993), then the new edges are flipped back to constrained
  Delaunay (Lawson's flips, segments locked).
* **Regions**: a flood fill from the triangle on the left of every boundary
  segment (the domain's side, :class:`meshcore.domain.planar.Domain` orients them
  so) across every edge that is not a boundary segment; constraints are
  crossed. What is not reached is a hole or the exterior.
* **Refinement** (Ruppert's algorithm as Shewchuk's Triangle runs it): bad
  triangles (smallest angle under the bound, area over the maximum,
  circumradius over the size) wait in buckets by their shortest edge,
  shortest first (without this order refinement above 30 degrees may not
  stop); each gets its circumcentre, or Ungor's off-centre when that is
  nearer (fewer points). A point that lies in the open diametral ball of a
  segment (or behind it) is not inserted and the segment is split instead,
  or, when the boundary is kept, the triangle is given up. Splits of a subsegment with an
  input vertex at one end fall on concentric shells (powers of two of a unit
  length from that vertex), and a triangle whose shortest edge joins two
  split points equidistant from the input vertex shared by their segments is
  not split: the two safeguards that make the algorithm terminate at small
  input angles (Shewchuk, "Delaunay refinement algorithms for triangular mesh
  generation", 2002, §3.6 and §4).

References
----------
Methods text §9.1 (segments as Delaunay edges, the diametral ball
:math:`B_f^{min}`, splitting at a point of the segment), §9.1.5 (new points
on the curve); J. Ruppert (1995); L. P. Chew (1989); S. W. Sloan, "A fast
algorithm for generating constrained Delaunay triangulations" (1993).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from meshcore.geometry.predicates import dot2d_filtered, incircle_filtered, orient2d_filtered

# Insertion outcomes.
OK, BLOCKED, ENCROACH, DEGENERATE, WALK_LIMIT, NO_SPACE = 0, 1, 2, 3, 4, 5
# Kernel statuses (returned to the Python driver).
DONE, NEED_SPACE, NEED_SCRATCH, NEED_QUEUE, YIELD, BUDGET, COLLINEAR, CROSSING = range(8)

# Layout of the integer state array of the refinement kernel.
ST_NPTS, ST_NTRI, ST_ROUNDS, ST_SQN, ST_STAMP, ST_ADD_B, ST_ADD_I = 0, 1, 2, 3, 4, 5, 6
ST_GIVEN_UP, ST_INFO, ST_NINPUT, ST_QFIRST, ST_QUSED, ST_QFREE, ST_QCOUNT = range(7, 14)
ST_SIZE = 16
# Layout of the float parameters of the refinement kernel.
PR_SIN2, PR_AREA, PR_SIZE2, PR_KEEP, PR_UNIT, PR_EQUI, PR_BUDGET, PR_OPS, PR_COS, PR_OFF = range(10)
PR_SIZE = 10

_WALK_LIMIT_STEPS = 1 << 22


# ---------------------------------------------------------------------------
# Corners and predicates
# ---------------------------------------------------------------------------


@njit(cache=True, inline="always")
def _nxt(k):
    return k - 2 if k % 3 == 2 else k + 1


@njit(cache=True, inline="always")
def _prv(k):
    return k + 2 if k % 3 == 0 else k - 1


@njit(cache=True, inline="always")  # int32 and int64 indices: no compiled copy per mix
def _orient(P, a, b, c, work):
    return orient2d_filtered(P[a, 0], P[a, 1], P[b, 0], P[b, 1], P[c, 0], P[c, 1], work)


@njit(cache=True)
def _incircle_tri(P, V, t, x, y, work):
    a = V[3 * t]
    b = V[3 * t + 1]
    c = V[3 * t + 2]
    return incircle_filtered(P[a, 0], P[a, 1], P[b, 0], P[b, 1], P[c, 0], P[c, 1], x, y, work)


# ---------------------------------------------------------------------------
# Building the structure, finding edges, flipping
# ---------------------------------------------------------------------------


@njit(cache=True)
def build(triangles, neighbors, V, A, S, vt):
    """Fill V, A, S (no segment yet) and vt from a Delaunay triangulation."""
    m = triangles.shape[0]
    for t in range(m):
        for i in range(3):
            V[3 * t + i] = triangles[t, i]
            S[3 * t + i] = -1
    for t in range(m):
        for i in range(3):
            nb = neighbors[t, i]
            A[3 * t + i] = -1
            if nb >= 0:
                for j in range(3):
                    if neighbors[nb, j] == t:
                        A[3 * t + i] = 3 * nb + j
                        break
        vt[triangles[t, 0]] = t
        vt[triangles[t, 1]] = t
        vt[triangles[t, 2]] = t


@njit(cache=True)
def _corner_of(V, t, a):
    for i in range(3):
        if V[3 * t + i] == a:
            return 3 * t + i
    return -1


@njit(cache=True)
def find_edge(V, A, vt, a, b):
    """A corner whose edge joins a and b (either direction), or -1.

    Turns around ``a`` counter-clockwise from ``vt[a]``, then clockwise if a
    border stopped the first turn.
    """
    ka = _corner_of(V, vt[a], a)
    if ka < 0:
        return -1
    k = ka
    while True:
        if V[_nxt(k)] == b:
            return _prv(k)
        if V[_prv(k)] == b:
            return _nxt(k)
        kk = A[_nxt(k)]
        if kk < 0:
            break
        k = _nxt(kk)
        if k == ka:
            return -1
    k = ka
    while True:
        kk = A[_prv(k)]
        if kk < 0:
            return -1
        k = _prv(kk)
        if k == ka:
            return -1
        if V[_nxt(k)] == b:
            return _prv(k)
        if V[_prv(k)] == b:
            return _nxt(k)


@njit(cache=True)
def find_directed(V, A, vt, a, b):
    """The corner whose edge runs from a to b counter-clockwise in its triangle, or -1."""
    k = find_edge(V, A, vt, a, b)
    if k < 0:
        return -1
    if V[_nxt(k)] == a:
        return k
    kk = A[k]
    return kk


@njit(cache=True)
def _flip(V, A, S, vt, k):
    """Flip the edge of corner k; the two triangles keep their slots."""
    kk = A[k]
    t = k // 3
    t2 = kk // 3
    kn = _nxt(k)
    kp = _prv(k)
    p = V[k]
    u = V[kn]
    v = V[kp]
    q = V[kk]
    e_vp = A[kn]
    e_pu = A[kp]
    e_uq = A[_nxt(kk)]
    e_qv = A[_prv(kk)]
    s_vp = S[kn]
    s_pu = S[kp]
    s_uq = S[_nxt(kk)]
    s_qv = S[_prv(kk)]
    b0 = 3 * t
    b2 = 3 * t2
    V[b0] = p
    V[b0 + 1] = u
    V[b0 + 2] = q
    A[b0] = e_uq
    A[b0 + 1] = b2 + 2
    A[b0 + 2] = e_pu
    S[b0] = s_uq
    S[b0 + 1] = -1
    S[b0 + 2] = s_pu
    V[b2] = p
    V[b2 + 1] = q
    V[b2 + 2] = v
    A[b2] = e_qv
    A[b2 + 1] = e_vp
    A[b2 + 2] = b0 + 1
    S[b2] = s_qv
    S[b2 + 1] = s_vp
    S[b2 + 2] = -1
    if e_uq >= 0:
        A[e_uq] = b0
    if e_pu >= 0:
        A[e_pu] = b0 + 2
    if e_qv >= 0:
        A[e_qv] = b2
    if e_vp >= 0:
        A[e_vp] = b2 + 1
    vt[p] = t
    vt[u] = t
    vt[q] = t
    vt[v] = t2


# ---------------------------------------------------------------------------
# Segment recovery by flips (Sloan), then constrained Delaunay by Lawson flips
# ---------------------------------------------------------------------------


@njit(cache=True)
def _push_pair(qa, qb, n, a, b):
    """Append (a, b) to growable pair arrays; returns the (possibly new) arrays."""
    if n >= qa.shape[0]:
        na = np.empty(2 * qa.shape[0], qa.dtype)
        nb = np.empty(2 * qb.shape[0], qb.dtype)
        na[:n] = qa[:n]
        nb[:n] = qb[:n]
        qa = na
        qb = nb
    qa[n] = a
    qb[n] = b
    return qa, qb


@njit(cache=True)
def recover_segments(P, V, A, S, vt, seg, sid, work, info):
    """Make every segment an edge, mark it, and restore constrained Delaunay.

    Parameters
    ----------
    seg : (k, 2) int64 endpoints; sid : (k,) int64 segment ids stored in S.
    info : (4,) int64 out: [status, segment row, vertex, flips].

    Returns status DONE, or COLLINEAR (a vertex lies on the open segment;
    ``info[1:3]`` name it) or CROSSING (two segments cross).
    """
    nq = 64
    qa = np.empty(nq, np.int64)
    qb = np.empty(nq, np.int64)
    ea = np.empty(nq, np.int64)
    eb = np.empty(nq, np.int64)
    ne = np.int64(0)  # typed, not literal: one compiled _push_pair
    flips = 0
    for r in range(seg.shape[0]):
        a = seg[r, 0]
        b = seg[r, 1]
        k = find_edge(V, A, vt, a, b)
        if k < 0:
            # Crossing edges: start in the triangle of a's star whose wedge holds b.
            ka = _corner_of(V, vt[a], a)
            start = -1
            kk0 = ka
            # turn counter-clockwise, then clockwise
            direction = 0
            k2 = ka
            while True:
                u = V[_nxt(k2)]
                w = V[_prv(k2)]
                o1 = _orient(P, a, u, b, work)
                o2 = _orient(P, a, w, b, work)
                if (
                    o1 == 0
                    and dot2d_filtered(P[u, 0], P[u, 1], P[b, 0], P[b, 1], P[a, 0], P[a, 1], work)
                    > 0
                ):
                    info[0] = COLLINEAR
                    info[1] = r
                    info[2] = u
                    return COLLINEAR
                if o1 > 0 and o2 < 0:
                    start = k2
                    break
                if direction == 0:
                    nk = A[_nxt(k2)]
                    if nk < 0:
                        direction = 1
                        k2 = kk0
                        continue
                    k2 = _nxt(nk)
                    if k2 == kk0:
                        break
                else:
                    nk = A[_prv(k2)]
                    if nk < 0:
                        break
                    k2 = _prv(nk)
            if start < 0:
                info[0] = CROSSING
                info[1] = r
                info[2] = a
                return CROSSING
            # Walk to b, queueing the crossed edges (right vertex, left vertex).
            nq = np.int64(0)
            k = start
            while True:
                if S[k] >= 0:
                    info[0] = CROSSING
                    info[1] = r
                    info[2] = S[k]
                    return CROSSING
                qa, qb = _push_pair(qa, qb, nq, V[_nxt(k)], V[_prv(k)])
                nq += 1
                kk = A[k]
                q = V[kk]
                if q == b:
                    break
                o = _orient(P, a, b, q, work)
                if o == 0:
                    info[0] = COLLINEAR
                    info[1] = r
                    info[2] = q
                    return COLLINEAR
                k = _nxt(kk) if o > 0 else _prv(kk)
            # Flip them away (circular queue over the arrays).
            head = 0
            count = nq
            cap = qa.shape[0]
            # make the queue circular in place: indices modulo cap
            tail = nq % cap
            while count > 0:
                x = qa[head]
                y = qb[head]
                head = (head + 1) % cap
                count -= 1
                ke = find_edge(V, A, vt, x, y)
                p = V[ke]
                u = V[_nxt(ke)]
                v = V[_prv(ke)]
                q = V[A[ke]]
                if _orient(P, p, u, q, work) > 0 and _orient(P, p, q, v, work) > 0:
                    _flip(V, A, S, vt, ke)
                    flips += 1
                    op = _orient(P, a, b, p, work)
                    oq = _orient(P, a, b, q, work)
                    if op * oq < 0:
                        qa[tail] = p
                        qb[tail] = q
                        tail = (tail + 1) % cap
                        count += 1
                    else:
                        ea, eb = _push_pair(ea, eb, ne, p, q)
                        ne += 1
                else:
                    qa[tail] = x
                    qb[tail] = y
                    tail = (tail + 1) % cap
                    count += 1
            k = find_edge(V, A, vt, a, b)
        S[k] = sid[r]
        if A[k] >= 0:
            S[A[k]] = sid[r]
    # Lawson: the new edges (and those around flipped ones) back to Delaunay.
    while ne > 0:
        ne -= 1
        x = ea[ne]
        y = eb[ne]
        k = find_edge(V, A, vt, x, y)
        if k < 0 or S[k] >= 0 or A[k] < 0:
            continue
        p = V[k]
        u = V[_nxt(k)]
        v = V[_prv(k)]
        q = V[A[k]]
        if (
            incircle_filtered(
                P[p, 0], P[p, 1], P[u, 0], P[u, 1], P[v, 0], P[v, 1], P[q, 0], P[q, 1], work
            )
            > 0
        ):
            _flip(V, A, S, vt, k)
            flips += 1
            ea, eb = _push_pair(ea, eb, ne, u, q)
            ne += 1
            ea, eb = _push_pair(ea, eb, ne, q, v)
            ne += 1
            ea, eb = _push_pair(ea, eb, ne, v, p)
            ne += 1
            ea, eb = _push_pair(ea, eb, ne, p, u)
            ne += 1
    info[0] = DONE
    info[3] = flips
    return DONE


# ---------------------------------------------------------------------------
# Regions
# ---------------------------------------------------------------------------


@njit(cache=True)
def domain_triangles(V, A, S, vt, ntri, bseg, n_boundary_ids):
    """Mask of the triangles reached from the left of the boundary segments.

    ``bseg`` holds the boundary subsegments oriented with the domain on the
    left; segment ids below ``n_boundary_ids`` stop the fill.
    """
    inside = np.zeros(ntri, np.bool_)
    stack = np.empty(ntri + 1, np.int64)
    sp = 0
    for r in range(bseg.shape[0]):
        k = find_directed(V, A, vt, bseg[r, 0], bseg[r, 1])
        if k < 0:
            continue
        t = k // 3
        if not inside[t]:
            inside[t] = True
            stack[sp] = t
            sp += 1
    while sp > 0:
        sp -= 1
        t = stack[sp]
        for i in range(3):
            k = 3 * t + i
            kk = A[k]
            if kk < 0:
                continue
            if S[k] >= 0 and S[k] < n_boundary_ids:
                continue
            t2 = kk // 3
            if not inside[t2]:
                inside[t2] = True
                stack[sp] = t2
                sp += 1
    return inside


@njit(cache=True)
def compact(V, A, S, keep, vt):
    """Keep only the triangles of ``keep``, renumbered in order, in place in V, A, S;
    returns their count.

    In place because the new row of triangle ``t`` is ``ids[t] <= t``: when row
    ``ids[t]`` is written, every triangle numbered below ``t`` (the only ones whose
    rows it may hold) has been read already, and triangle ``t`` itself is read
    corner by corner before its corner is written. A neighbour is renumbered
    through ``ids`` only, never read from its rows.
    """
    ntri = keep.shape[0]
    ids = np.empty(ntri, np.int64)
    m = 0
    for t in range(ntri):
        if keep[t]:
            ids[t] = m
            m += 1
        else:
            ids[t] = -1
    for t in range(ntri):
        r = ids[t]
        if r < 0:
            continue
        for i in range(3):
            k = 3 * t + i
            v = V[k]
            s = S[k]
            kk = A[k]
            if kk >= 0 and ids[kk // 3] >= 0:
                A[3 * r + i] = 3 * ids[kk // 3] + kk % 3
            else:
                A[3 * r + i] = -1
            V[3 * r + i] = v
            S[3 * r + i] = s
            vt[v] = r
    return m


# ---------------------------------------------------------------------------
# Refinement
# ---------------------------------------------------------------------------
#
# The kernels take bundles (numba tuples) rather than dozens of arguments:
#
#   M   = (P, V, A, S, G, vt, pseg, ppar, fan, mark)  the mesh and its per-item
#         arrays: G[t] is the generation of triangle t (the depth of the
#         refinement cascade that made it) or -1 once given up; pseg[p] the
#         input segment a split point lies on (-1 otherwise), ppar[p] its
#         parameter along it; fan and mark are scratch (per point, per triangle)
#   D   = (prm, segends, segcurve, circles, H, hg)  the fixed data
#   Qs  = (Qe, Qb, SQ)  bad triangles: entries (3, cap) [triangle, next entry,
#         free stack], buckets (2, NBUCKETS) [first entry, last entry]; SQ
#         (2, cap) the stack of encroached subsegments (their endpoints)
#   scr (8, cap) int64: one insertion's cavity, border corners, border
#         endpoints, outer corners, segment ids, and two rows for the
#         segments a refused point encroaches
#
# Bad triangles wait in buckets by the squared length of their shortest edge
# (two per power of two, as Triangle's 4096 queues), shortest first, first in
# first out within a bucket.

NBUCKETS = 4400
_BUCKET_OFFSET = 2200
_SQRT_HALF = math.sqrt(0.5)


@njit(cache=True)
def _size_at(H, hg, x, y):
    """Bilinear interpolation of the size grid, clamped to it (a grid one node
    wide in x or y reads that node: the index -1 wraps to it, with weight 0)."""
    nx = H.shape[1]
    ny = H.shape[0]
    fx = (x - hg[0]) / hg[2]
    fy = (y - hg[1]) / hg[3]
    fx = min(max(fx, 0.0), nx - 1.0)
    fy = min(max(fy, 0.0), ny - 1.0)
    i = min(int(fx), nx - 2)
    j = min(int(fy), ny - 2)
    u = fx - i
    v = fy - j
    return (1.0 - v) * ((1.0 - u) * H[j, i] + u * H[j, i + 1]) + v * (
        (1.0 - u) * H[j + 1, i] + u * H[j + 1, i + 1]
    )


@njit(cache=True)
def _small_angle(P, segends, sp, sq, j, cos_bound):
    """Whether input segments sp and sq meet at their common vertex j at an
    angle below the bound (cosine above ``cos_bound``)."""
    u = segends[sp, 1] if segends[sp, 0] == j else segends[sp, 0]
    v = segends[sq, 1] if segends[sq, 0] == j else segends[sq, 0]
    ux = P[u, 0] - P[j, 0]
    uy = P[u, 1] - P[j, 1]
    vx = P[v, 0] - P[j, 0]
    vy = P[v, 1] - P[j, 1]
    dot = ux * vx + uy * vy
    return dot > cos_bound * math.sqrt((ux * ux + uy * uy) * (vx * vx + vy * vy))


@njit(cache=True)
def _is_bad(P, V, t, D, pseg):
    """(code, squared shortest edge): code 0 fine, 1 smallest angle under the
    bound, 2 too large (area over the maximum or circumradius over the size)."""
    prm, segends, _, _, H, hg = D
    a = V[3 * t]
    b = V[3 * t + 1]
    c = V[3 * t + 2]
    ax = P[a, 0]
    ay = P[a, 1]
    bx = P[b, 0] - ax
    by = P[b, 1] - ay
    cx = P[c, 0] - ax
    cy = P[c, 1] - ay
    cross = bx * cy - by * cx
    lab = bx * bx + by * by
    lca = cx * cx + cy * cy
    dx = cx - bx
    dy = cy - by
    lbc = dx * dx + dy * dy
    # the shortest edge pq, and the product of the two others
    if lab <= lbc and lab <= lca:
        lmin = lab
        p = a
        q = b
        prod = lbc * lca
    elif lbc <= lca:
        lmin = lbc
        p = b
        q = c
        prod = lab * lca
    else:
        lmin = lca
        p = c
        q = a
        prod = lab * lbc
    if cross <= 0.0:
        return 0, lmin  # never for valid triangles; nothing to refine
    if 0.5 * cross > prm[PR_AREA]:
        return 2, lmin
    if prm[PR_SIZE2] > 0.0:
        # a uniform size is a 1 x 1 grid, read here: no call and no centroid per triangle
        if H.size == 1:
            h = H[0, 0]
        else:
            h = _size_at(H, hg, ax + (bx + cx) / 3.0, ay + (by + cy) / 3.0)
        # circumradius**2 = lab * lbc * lca / (4 cross**2)
        if lab * lbc * lca > 4.0 * cross * cross * prm[PR_SIZE2] * h * h:
            return 2, lmin
    s2 = prm[PR_SIN2]
    # sin(smallest angle) = cross / (product of the two longer edges)
    if s2 <= 0.0 or cross * cross >= s2 * prod:
        return 0, lmin
    # Small input angle (Miller, Pav and Walkington's rule, as Triangle): the
    # shortest edge joins split points of two segments meeting at an input
    # vertex at a small angle, at equal distances from it: left as it is.
    sp = pseg[p]
    sq = pseg[q]
    if sp >= 0 and sq >= 0 and sp != sq:
        j = -1
        if segends[sp, 0] == segends[sq, 0] or segends[sp, 0] == segends[sq, 1]:
            j = segends[sp, 0]
        elif segends[sp, 1] == segends[sq, 0] or segends[sp, 1] == segends[sq, 1]:
            j = segends[sp, 1]
        if j >= 0 and _small_angle(P, segends, sp, sq, j, prm[PR_COS]):
            d1x = P[p, 0] - P[j, 0]
            d1y = P[p, 1] - P[j, 1]
            d2x = P[q, 0] - P[j, 0]
            d2y = P[q, 1] - P[j, 1]
            d1 = d1x * d1x + d1y * d1y
            d2 = d2x * d2x + d2y * d2y
            tol = prm[PR_EQUI]
            if d1 < (1.0 + tol) * d2 and d1 > (1.0 - tol) * d2:
                return 0, lmin
    return 1, lmin


@njit(cache=True)
def _push_bad(Qs, st, t, lmin):
    """Queue triangle t in the bucket of its squared shortest edge."""
    Qe, Qb, _ = Qs
    if st[ST_QFREE] > 0:
        st[ST_QFREE] -= 1
        e = Qe[2, st[ST_QFREE]]
    else:
        e = st[ST_QUSED]
        st[ST_QUSED] = e + 1
    Qe[0, e] = t
    Qe[1, e] = -1
    m, x = math.frexp(lmin)
    b = 2 * x + (1 if m > _SQRT_HALF else 0) + _BUCKET_OFFSET
    b = min(max(b, 0), NBUCKETS - 1)
    if Qb[0, b] < 0:
        Qb[0, b] = e
    else:
        Qe[1, Qb[1, b]] = e
    Qb[1, b] = e
    if b < st[ST_QFIRST]:
        st[ST_QFIRST] = b
    st[ST_QCOUNT] += 1


@njit(cache=True)
def _pop_bad(Qs, st):
    """The next bad triangle (shortest edge first), or -1."""
    Qe, Qb, _ = Qs
    b = st[ST_QFIRST]
    while b < NBUCKETS and Qb[0, b] < 0:
        b += 1
    st[ST_QFIRST] = b
    if b >= NBUCKETS:
        return -1
    e = Qb[0, b]
    Qb[0, b] = Qe[1, e]
    Qe[2, st[ST_QFREE]] = e
    st[ST_QFREE] += 1
    st[ST_QCOUNT] -= 1
    return Qe[0, e]


@njit(cache=True)
def _queue_room(Qs, st):
    """Entries that can still be pushed without growing the arrays."""
    Qe, _, SQ = Qs
    return min(Qe.shape[1] - st[ST_QUSED] + st[ST_QFREE], SQ.shape[1] - st[ST_SQN])


@njit(cache=True)
def _locate(P, V, A, S, x, y, t0, work):
    """Visibility walk from t0 to (x, y): triangle >= 0, or -2 - corner when a
    segment or the border blocks the way, or -1 past the step limit."""
    t = t0
    entry = -1
    for step in range(_WALK_LIMIT_STEPS):
        base = 3 * t
        blocked = -1
        nxt_k = -1
        for j in range(3):
            k = base + (j + step) % 3
            if k == entry:
                continue
            u = V[_nxt(k)]
            v = V[_prv(k)]
            if orient2d_filtered(P[u, 0], P[u, 1], P[v, 0], P[v, 1], x, y, work) < 0:
                if A[k] < 0 or S[k] >= 0:
                    blocked = k
                else:
                    nxt_k = k
                    break
        if nxt_k < 0:
            if blocked >= 0:
                return -2 - blocked
            return t
        entry = A[nxt_k]
        t = entry // 3
    return -1


@njit(cache=True)
def _insert(M, st, x, y, t0, split_k, sid, par, check_enc, gen, scr, work):
    """Insert (x, y) by a Bowyer-Watson cavity that crosses no segment.

    ``split_k >= 0``: the point splits the subsegment of that corner (its two
    sides seed the cavity, and its two halves become segment ``sid``);
    otherwise it is located by a walk from ``t0``. With ``check_enc`` the
    point is refused (ENCROACH) when it lies in the open diametral ball of a
    segment on the cavity border, or behind a segment (BLOCKED); the corners
    of those segments are then ``scr[6, :st[ST_INFO]]``. On OK the new
    triangles are ``scr[0, :st[ST_INFO]]`` (generation ``gen``) and the new
    point is ``st[ST_NPTS] - 1``. Nothing changes unless the outcome is OK.
    """
    P, V, A, S, G, vt, pseg, ppar, fan, mark = M
    cap = scr.shape[1]
    stamp = st[ST_STAMP] + 1
    st[ST_STAMP] = stamp
    skip1 = -1
    skip2 = -1
    if split_k >= 0:
        t = split_k // 3
        scr[0, 0] = t
        mark[t] = stamp
        nc = 1
        skip1 = split_k
        skip2 = A[split_k]
        if skip2 >= 0:
            scr[0, 1] = skip2 // 3
            mark[skip2 // 3] = stamp
            nc = 2
    else:
        t = _locate(P, V, A, S, x, y, t0, work)
        if t == -1:
            return WALK_LIMIT
        if t <= -2:
            scr[6, 0] = -2 - t
            st[ST_INFO] = 1
            return BLOCKED
        scr[0, 0] = t
        mark[t] = stamp
        nc = 1
    nb = 0
    i = 0
    while i < nc:
        t = scr[0, i]
        i += 1
        for j in range(3):
            k = 3 * t + j
            if k == skip1 or k == skip2:
                continue
            kk = A[k]
            if kk >= 0 and S[k] < 0:
                t2 = kk // 3
                if mark[t2] == stamp:
                    continue
                if _incircle_tri(P, V, t2, x, y, work) > 0:
                    if nc >= cap:
                        return NO_SPACE
                    scr[0, nc] = t2
                    mark[t2] = stamp
                    nc += 1
                    continue
            if nb >= cap:
                return NO_SPACE
            scr[1, nb] = k
            nb += 1
    # Encroachment: the point in the open diametral ball of a border segment.
    if check_enc:
        ne = 0
        for i in range(nb):
            k = scr[1, i]
            if S[k] >= 0:
                u = V[_nxt(k)]
                v = V[_prv(k)]
                if dot2d_filtered(P[u, 0], P[u, 1], P[v, 0], P[v, 1], x, y, work) < 0:
                    scr[6, ne] = k
                    ne += 1
        if ne > 0:
            st[ST_INFO] = ne
            return ENCROACH
    # Every new triangle strictly counter-clockwise, else refuse.
    for i in range(nb):
        k = scr[1, i]
        u = V[_nxt(k)]
        v = V[_prv(k)]
        if orient2d_filtered(P[u, 0], P[u, 1], P[v, 0], P[v, 1], x, y, work) <= 0:
            return DEGENERATE
    # A simple cavity border (no vertex twice, e.g. around a dangling segment).
    dup = False
    for i in range(nb):
        u = V[_nxt(scr[1, i])]
        if fan[u] != -1:
            dup = True
        fan[u] = 0
    for i in range(nb):
        fan[V[_nxt(scr[1, i])]] = -1
    if dup:
        return DEGENERATE
    npts = st[ST_NPTS]
    ntri = st[ST_NTRI]
    if npts >= P.shape[0] or ntri + nb - nc > G.shape[0]:
        return NO_SPACE
    # Commit: the fan of new triangles (c, u, v) over the border edges (u, v).
    for i in range(nb):
        k = scr[1, i]
        scr[2, i] = V[_nxt(k)]
        scr[3, i] = V[_prv(k)]
        scr[4, i] = A[k]
        scr[5, i] = S[k]
    c = npts
    P[c, 0] = x
    P[c, 1] = y
    pseg[c] = sid
    ppar[c] = par
    st[ST_NPTS] = npts + 1
    for i in range(nb):
        if i >= nc:
            scr[0, i] = ntri
            ntri += 1
        T = scr[0, i]
        u = scr[2, i]
        v = scr[3, i]
        b0 = 3 * T
        V[b0] = c
        V[b0 + 1] = u
        V[b0 + 2] = v
        A[b0] = scr[4, i]
        S[b0] = scr[5, i]
        if scr[4, i] >= 0:
            A[scr[4, i]] = b0
        A[b0 + 1] = -1
        A[b0 + 2] = -1
        S[b0 + 1] = -1
        S[b0 + 2] = -1
        G[T] = gen
        fan[u] = T
        vt[u] = T
        vt[v] = T
        vt[c] = T
    st[ST_NTRI] = ntri
    if gen > st[ST_ROUNDS]:
        st[ST_ROUNDS] = gen
    for i in range(nb):
        T = scr[0, i]
        T2 = fan[scr[3, i]]
        if T2 >= 0:
            A[3 * T + 1] = 3 * T2 + 2
            A[3 * T2 + 2] = 3 * T + 1
    for i in range(nb):
        fan[scr[2, i]] = -1
    st[ST_INFO] = nb
    return OK


@njit(cache=True)
def _mark_split_edges(V, A, S, scr, nb, a, b, sid):
    """After a split of ab by the new point, mark its two halves as segment sid."""
    for i in range(nb):
        T = scr[0, i]
        u = V[3 * T + 1]
        v = V[3 * T + 2]
        if u == a or u == b:
            S[3 * T + 2] = sid
            if A[3 * T + 2] >= 0:
                S[A[3 * T + 2]] = sid
        if v == a or v == b:
            S[3 * T + 1] = sid
            if A[3 * T + 1] >= 0:
                S[A[3 * T + 1]] = sid


@njit(cache=True)
def _split_point(P, ppar, D, a, b, sid, n_input):
    """Where to split subsegment ab of input segment sid: (x, y, parameter).

    The parameter runs from 0 at the segment's first input vertex to 1 at
    its second; the point is computed from the input endpoints (one rounding
    off the line). With an input vertex at exactly one end the split is on a
    concentric shell around it: at ``unit * 2**k`` from it, the power of two
    that lands in the middle third of ab (Ruppert's "concentric shells", as
    Triangle). Otherwise at the midpoint. A ring declared as a circle gets
    the point on the circle (§9.1.5).
    """
    prm, segends, segcurve, circles, _, _ = D
    s0 = segends[sid, 0]
    s1 = segends[sid, 1]
    if a == s0:
        ta = 0.0
    elif a == s1:
        ta = 1.0
    else:
        ta = ppar[a]
    if b == s0:
        tb = 0.0
    elif b == s1:
        tb = 1.0
    else:
        tb = ppar[b]
    ex = P[s1, 0] - P[s0, 0]
    ey = P[s1, 1] - P[s0, 1]
    length = math.sqrt(ex * ex + ey * ey)
    sub = abs(tb - ta) * length
    a_in = a < n_input
    b_in = b < n_input
    if a_in != b_in and sub > 0.0:
        p = prm[PR_UNIT]
        while sub > 3.0 * p:
            p *= 2.0
        while sub < 1.5 * p:
            p *= 0.5
        frac = p / sub
        if a_in:
            tm = ta + frac * (tb - ta)
        else:
            tm = tb + frac * (ta - tb)
    else:
        tm = 0.5 * (ta + tb)
    x = P[s0, 0] + tm * ex
    y = P[s0, 1] + tm * ey
    cv = segcurve[sid]
    if cv >= 0:
        cx = circles[cv, 0]
        cy = circles[cv, 1]
        r = circles[cv, 2]
        dx = x - cx
        dy = y - cy
        d = math.sqrt(dx * dx + dy * dy)
        if d > 0.0:
            x = cx + dx * (r / d)
            y = cy + dy * (r / d)
    return x, y, tm


@njit(cache=True)
def _encroached(P, V, A, k, work):
    """Whether a triangle apex on either side lies in the open diametral ball of edge k."""
    u = V[_nxt(k)]
    v = V[_prv(k)]
    w = V[k]
    if dot2d_filtered(P[u, 0], P[u, 1], P[v, 0], P[v, 1], P[w, 0], P[w, 1], work) < 0:
        return True
    kk = A[k]
    if kk >= 0:
        w = V[kk]
        if dot2d_filtered(P[u, 0], P[u, 1], P[v, 0], P[v, 1], P[w, 0], P[w, 1], work) < 0:
            return True
    return False


@njit(cache=True)
def _enqueue_new(M, D, Qs, st, scr, nb, split, work):
    """Queue the bad new triangles and, after a split, the subsegments that the
    new point or the new halves' apexes encroach."""
    P, V, A, S, G, vt, pseg, ppar, fan, mark = M
    SQ = Qs[2]
    c = st[ST_NPTS] - 1
    sqn = st[ST_SQN]
    for i in range(nb):
        T = scr[0, i]
        bad, lmin = _is_bad(P, V, T, D, pseg)
        if bad != 0:
            _push_bad(Qs, st, T, lmin)
        if split:
            k = 3 * T
            if S[k] >= 0:
                u = V[3 * T + 1]
                v = V[3 * T + 2]
                if dot2d_filtered(P[u, 0], P[u, 1], P[v, 0], P[v, 1], P[c, 0], P[c, 1], work) < 0:
                    SQ[0, sqn] = u
                    SQ[1, sqn] = v
                    sqn += 1
            for j in (1, 2):
                k = 3 * T + j
                if S[k] >= 0 and _encroached(P, V, A, k, work):
                    SQ[0, sqn] = V[_nxt(k)]
                    SQ[1, sqn] = V[_prv(k)]
                    sqn += 1
    st[ST_SQN] = sqn


@njit(cache=True)
def _split(M, D, Qs, st, k, gen, scr, work):
    """Split the subsegment of corner k; returns the insertion outcome."""
    P, V, A, S, G, vt, pseg, ppar, fan, mark = M
    segends = D[1]
    segcurve = D[2]
    n_input = st[ST_NINPUT]
    a = V[_nxt(k)]
    b = V[_prv(k)]
    sid = S[k]
    x, y, tm = _split_point(P, ppar, D, a, b, sid, n_input)
    r = _insert(M, st, x, y, np.int64(-1), k, sid, tm, np.bool_(False), gen, scr, work)
    if r == DEGENERATE and segcurve[sid] >= 0:
        # The point on the curve does not fit the neighbourhood: take the chord's.
        s0 = segends[sid, 0]
        s1 = segends[sid, 1]
        x = P[s0, 0] + tm * (P[s1, 0] - P[s0, 0])
        y = P[s0, 1] + tm * (P[s1, 1] - P[s0, 1])
        r = _insert(M, st, x, y, np.int64(-1), k, sid, tm, np.bool_(False), gen, scr, work)
    if r != OK:
        return r
    nb = st[ST_INFO]
    _mark_split_edges(V, A, S, scr, nb, a, b, sid)
    st[ST_ADD_B] += 1
    _enqueue_new(M, D, Qs, st, scr, nb, np.bool_(True), work)
    return OK


@njit(cache=True)
def init_queues(M, D, Qs, st, work):
    """Queue every bad triangle and (unless the boundary is kept) every
    encroached subsegment. The caller sizes the queues for every triangle
    and three subsegments per triangle."""
    P, V, A, S, G, vt, pseg, ppar, fan, mark = M
    prm = D[0]
    Qb = Qs[1]
    SQ = Qs[2]
    for b in range(NBUCKETS):
        Qb[0, b] = -1
        Qb[1, b] = -1
    st[ST_QFIRST] = NBUCKETS
    st[ST_QUSED] = 0
    st[ST_QFREE] = 0
    st[ST_QCOUNT] = 0
    split = prm[PR_KEEP] <= 0.0
    sqn = 0
    for t in range(st[ST_NTRI]):
        G[t] = 0
        bad, lmin = _is_bad(P, V, t, D, pseg)
        if bad != 0:
            _push_bad(Qs, st, t, lmin)
        if split:
            for j in range(3):
                k = 3 * t + j
                if S[k] >= 0 and (A[k] < 0 or A[k] > k) and _encroached(P, V, A, k, work):
                    SQ[0, sqn] = V[_nxt(k)]
                    SQ[1, sqn] = V[_prv(k)]
                    sqn += 1
    st[ST_SQN] = sqn


@njit(cache=True)
def steiner_point(P, a, b, c, off):
    """Circumcentre of CCW (a, b, c), or Ungor's off-centre when it is closer.

    The off-centre lies on the bisector of the shortest edge pq, on the side
    of the triangle, at ``off * |pq|`` from its midpoint: with ``off`` a
    little under ``cot(theta / 2) / 2`` the triangle it makes with pq has
    an angle a little over the bound theta. Used when it is nearer to p
    than the circumcentre (a skinny triangle): fewer points, as Triangle.
    Shared with the insertion stage of :mod:`meshcore.optimize.refine2d`.

    References: A. Üngör, "Off-centers" (2004); methods text §9.1.
    """
    ax = P[a, 0]
    ay = P[a, 1]
    bx = P[b, 0] - ax
    by = P[b, 1] - ay
    cx = P[c, 0] - ax
    cy = P[c, 1] - ay
    lb = bx * bx + by * by
    lc = cx * cx + cy * cy
    d = 2.0 * (bx * cy - by * cx)
    ux = (cy * lb - by * lc) / d
    uy = (bx * lc - cx * lb) / d
    if off <= 0.0:
        return ax + ux, ay + uy
    # shortest edge (p -> q, counter-clockwise in the triangle), relative to a
    ex = cx - bx
    ey = cy - by
    la = ex * ex + ey * ey
    if lb <= lc and lb <= la:
        px, py, qx, qy = 0.0, 0.0, bx, by
    elif la <= lc:
        px, py, qx, qy = bx, by, cx, cy
    else:
        px, py, qx, qy = cx, cy, 0.0, 0.0
    dx = qx - px
    dy = qy - py
    ox = px + 0.5 * dx - off * dy
    oy = py + 0.5 * dy + off * dx
    if (ox - px) ** 2 + (oy - py) ** 2 < (ux - px) ** 2 + (uy - py) ** 2:
        return ax + ox, ay + oy
    return ax + ux, ay + uy


@njit(cache=True)
def refine(M, D, Qs, st, scr, work):
    """Delaunay refinement until no triangle is bad (see the module docstring).

    Returns a status: DONE; YIELD after ``prm[PR_OPS]`` insertions (for
    progress and cancellation); NEED_SPACE (points or triangles),
    NEED_QUEUE or NEED_SCRATCH (cavity arrays) to be grown by the caller
    before calling again; BUDGET when the point count reaches
    ``prm[PR_BUDGET]``. The queues live in ``st`` and ``Qs``, so a call
    resumes where the previous one stopped.
    """
    P, V, A, S, G, vt, pseg, ppar, fan, mark = M
    prm = D[0]
    SQ = Qs[2]
    keep = prm[PR_KEEP] > 0.0
    sc = scr.shape[1]
    ops = 0
    while True:
        if st[ST_NPTS] + 2 >= P.shape[0] or st[ST_NTRI] + sc >= G.shape[0]:
            return NEED_SPACE
        if _queue_room(Qs, st) < 4 * sc:
            return NEED_QUEUE
        if st[ST_NPTS] >= prm[PR_BUDGET]:
            return BUDGET
        if ops >= prm[PR_OPS]:
            return YIELD
        # 1. Encroached subsegments first (a stack).
        if st[ST_SQN] > 0:
            n = st[ST_SQN] - 1
            st[ST_SQN] = n
            a = SQ[0, n]
            b = SQ[1, n]
            k = find_edge(V, A, vt, a, b)
            if k < 0 or S[k] < 0 or not _encroached(P, V, A, k, work):
                continue
            gen = G[k // 3] + 1 if G[k // 3] >= 0 else st[ST_ROUNDS]
            r = _split(M, D, Qs, st, k, gen, scr, work)
            if r == NO_SPACE:
                SQ[0, n] = a
                SQ[1, n] = b
                st[ST_SQN] = n + 1
                return NEED_SCRATCH
            ops += 1
            continue
        # 2. The next bad triangle, shortest edge first.
        t = _pop_bad(Qs, st)
        if t < 0:
            return DONE
        if G[t] < 0:
            continue
        bad, lmin = _is_bad(P, V, t, D, pseg)
        if bad == 0:
            continue
        gen = G[t] + 1
        x, y = steiner_point(P, V[3 * t], V[3 * t + 1], V[3 * t + 2], prm[PR_OFF])
        r = _insert(M, st, x, y, t, np.int64(-1), np.int32(-1), 0.0, np.bool_(True), gen, scr, work)
        if r == OK:
            st[ST_ADD_I] += 1
            ops += 1
            _enqueue_new(M, D, Qs, st, scr, st[ST_INFO], np.bool_(False), work)
        elif r == ENCROACH or r == BLOCKED:
            if keep:
                G[t] = -1
                st[ST_GIVEN_UP] += 1
                continue
            # Split the segments instead (their corners move with each split,
            # so name them by their endpoints first).
            ne = st[ST_INFO]
            for i in range(ne):
                k = scr[6, i]
                scr[6, i] = V[_nxt(k)]
                scr[7, i] = V[_prv(k)]
            split_any = False
            for i in range(ne):
                k = find_edge(V, A, vt, scr[6, i], scr[7, i])
                if k < 0 or S[k] < 0:
                    continue
                r2 = _split(M, D, Qs, st, k, gen, scr, work)
                if r2 == OK:
                    split_any = True
                    ops += 1
                elif r2 == NO_SPACE:
                    _push_bad(Qs, st, t, lmin)
                    return NEED_SCRATCH
                if (
                    st[ST_NPTS] + 2 >= P.shape[0]
                    or st[ST_NTRI] + sc >= G.shape[0]
                    or _queue_room(Qs, st) < 2 * sc
                ):
                    break
            if split_any:
                _push_bad(Qs, st, t, lmin)
            else:
                G[t] = -1
                st[ST_GIVEN_UP] += 1
        elif r == NO_SPACE:
            _push_bad(Qs, st, t, lmin)
            return NEED_SCRATCH
        else:
            G[t] = -1
            st[ST_GIVEN_UP] += 1


@njit(cache=True)
def locate_many(points, triangles, neighbors, q, out_t, out_bary, work):
    """Triangle holding each query point (-1 outside the hull) and its barycentric
    weights, by visibility walks from the previous answer (queries in raster
    order walk a few triangles each)."""
    t = 0
    for i in range(q.shape[0]):
        x = q[i, 0]
        y = q[i, 1]
        cur = t
        found = -1
        for step in range(_WALK_LIMIT_STEPS):
            moved = False
            outside = False
            for j in range(3):
                e = (j + step) % 3
                a = triangles[cur, (e + 1) % 3]
                b = triangles[cur, (e + 2) % 3]
                if (
                    orient2d_filtered(
                        points[a, 0], points[a, 1], points[b, 0], points[b, 1], x, y, work
                    )
                    < 0
                ):
                    nb = neighbors[cur, e]
                    if nb < 0:
                        outside = True
                    else:
                        cur = nb
                        moved = True
                    break
            if outside:
                break
            if not moved:
                found = cur
                break
        out_t[i] = found
        if found < 0:
            continue
        t = found
        a = triangles[found, 0]
        b = triangles[found, 1]
        c = triangles[found, 2]
        ax = points[a, 0]
        ay = points[a, 1]
        bx = points[b, 0] - ax
        by = points[b, 1] - ay
        cx = points[c, 0] - ax
        cy = points[c, 1] - ay
        px = x - ax
        py = y - ay
        det = bx * cy - by * cx
        wb = (px * cy - py * cx) / det
        wc = (bx * py - by * px) / det
        wb = min(max(wb, 0.0), 1.0)
        wc = min(max(wc, 0.0), 1.0 - wb)
        out_bary[i, 0] = 1.0 - wb - wc
        out_bary[i, 1] = wb
        out_bary[i, 2] = wc
