"""The pieces of the admissible-boundary rounds and their compiled searches (§9.1).

:class:`_Pieces` holds the boundary segments cut into pieces (chains of
subsegments per input segment, their protecting circles, the split points)
together with the one growing triangulation the rounds insert into
(:class:`~meshcore.delaunay.kernel2d.IncrementalDelaunay`); the compiled
functions here search that triangulation: the triangles a segment crosses,
the vertex of widest angle in a segment's ball (the encroacher of §9.1 whose
projection splits it), the edges inside a disc; and, on a grid, the pieces
near each vertex to protect (:func:`_grid_reach`). Split from
:mod:`meshcore.delaunay.admissible`, which runs the rounds; the names stay
private to the package but :func:`located_in_domain` (the errors of the
rounds located in a domain), which that module exports.

References
----------
Methods text §9.1 (Delaunay-admissible boundaries in R^2: the ball of a
segment, the point of maximal angle, splitting at its projection).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from meshcore.delaunay.kernel2d import IncrementalDelaunay, _corner, _nxt, _prv
from meshcore.delaunay.prefetch import prefetch
from meshcore.domain.planar import Domain
from meshcore.errors import AlgorithmError, InputError
from meshcore.geometry.constructions import point_segment_distance_2d
from meshcore.geometry.ordering import radix_argsort, radix_sort
from meshcore.geometry.predicates import WORK_SIZE, dot2d_filtered, orient2d_filtered
from meshcore.mesh.topology import edge_keys, group_slots

#: A projection closer than this fraction of ``|EP|`` to the nearer endpoint
#: ``E`` (``P`` the encroaching point) is too close ...
NEAR_END_TRIGGER = 0.125
#: ... and is replaced by the point at this fraction of ``|EP|`` from ``E``.
NEAR_END_FRACTION = 0.5
#: Split points move away from the nearer end by this fraction of their
#: distance to it (see "Ties of the projection" above).
NUDGE = 2.0**-20
#: Split points of two segments that meet this close (times the largest
#: coordinate magnitude) to an end of one of them: that end is within float64
#: rounding of the other segment (:meth:`_Pieces.split`).
TOUCH = 2.0**-40

__all__: list[str] = []


@njit(cache=True, inline="always")
def _near_segment(pts, u, v, cx, cy, r2):
    """Float test, padded by the caller: segment uv comes within sqrt(r2) of (cx, cy)."""
    ux = pts[u, 0] - cx
    uy = pts[u, 1] - cy
    dx = pts[v, 0] - pts[u, 0]
    dy = pts[v, 1] - pts[u, 1]
    ll = dx * dx + dy * dy
    s = 0.0
    if ll > 0.0:
        s = min(1.0, max(0.0, -(ux * dx + uy * dy) / ll))
    fx = ux + s * dx
    fy = uy + s * dy
    return fx * fx + fy * fy <= r2


@njit(cache=True, inline="always")
def _enters_cone(pts, e, f, x, tip):
    """Float test, padded: the edge from end ``e`` toward ``x`` leaves ``e``
    within the angle ``arccos(tip)`` of the segment ``e f``, i.e. into the
    ball (``tip`` 0) or the lens whose boundary arcs make that angle with
    the segment at its ends."""
    ux = pts[x, 0] - pts[e, 0]
    uy = pts[x, 1] - pts[e, 1]
    vx = pts[f, 0] - pts[e, 0]
    vy = pts[f, 1] - pts[e, 1]
    c = (ux * vx + uy * vy) / (np.hypot(ux, uy) * np.hypot(vx, vy))
    return c > tip - 1e-9


@njit(cache=True)
def _crossed_triangles(pts, V, A, vt, ia, ib, tstamp, stamp, queue):
    """Seeds of :func:`_widest_angle_points`: a triangle at ``ia``, then the
    triangles the segment ``ia ib`` crosses, walked in float arithmetic,
    stamped and put in ``queue``. Returns how many (at most the queue's
    length) and whether the walk reached ``ib``: then, unless rounding
    misled it, they are the triangles the segment crosses."""
    t0 = vt[ia]
    tstamp[t0] = stamp
    queue[0] = t0
    count = 1
    ax = pts[ia, 0]
    ay = pts[ia, 1]
    ex = pts[ib, 0] - ax
    ey = pts[ib, 1] - ay
    t = t0
    kin = -1
    while True:  # the triangle at ia whose angle holds the direction to ib
        k = _corner(V, t, ia)
        u = V[_nxt(k)]
        w = V[_prv(k)]
        if u >= 0 and w >= 0:
            su = ex * (pts[u, 1] - ay) - ey * (pts[u, 0] - ax)
            sw = ex * (pts[w, 1] - ay) - ey * (pts[w, 0] - ax)
            if su <= 0.0 <= sw:
                kin = A[k]
                break
        t = A[_prv(k)] // 3
        if t == t0:
            return count, False
    while count < queue.shape[0]:
        x = V[kin]
        if x < 0:
            break
        # Ask for both possible next triangles while this one's apex loads.
        prefetch(V, A[_nxt(kin)])
        prefetch(V, A[_prv(kin)])
        t = kin // 3
        if tstamp[t] != stamp:
            tstamp[t] = stamp
            queue[count] = t
            count += 1
        if x == ib:
            return count, True
        sx = ex * (pts[x, 1] - ay) - ey * (pts[x, 0] - ax)
        p1 = V[_nxt(kin)]
        s1 = ex * (pts[p1, 1] - ay) - ey * (pts[p1, 0] - ax)
        if sx == 0.0:
            break
        kin = A[_nxt(kin)] if (sx > 0.0) == (s1 > 0.0) else A[_prv(kin)]
    return count, False


@njit(cache=True, inline="always")
def _prefetch_ahead(pts, V, A, vt, a, b, tstamp, vstamp, i):
    """Ask for what the searches of segments ``i + 2`` to ``i + 4`` read first,
    one level of indirection per segment ahead (the walk-start triangle at
    ``a``, its corners, neighbours and vertices, their stamps, the far end
    ``b``): a search reads some 6 triangles, and the misses of its pointer
    chase, not its arithmetic, were its time (1.0 to 0.5 us a segment on
    the 10,000-vertex star)."""
    k = a.shape[0]
    if i + 4 < k:
        prefetch(vt, a[i + 4])
        prefetch(pts, b[i + 4])
    if i + 3 < k:
        t = vt[a[i + 3]]
        prefetch(V, 3 * t)
        prefetch(A, 3 * t)
        prefetch(tstamp, t)
    if i + 2 < k:
        c = 3 * vt[a[i + 2]]
        for j in range(3):
            if V[c + j] >= 0:
                prefetch(pts, V[c + j])
                prefetch(vstamp, V[c + j])
            prefetch(V, A[c + j])
            prefetch(A, A[c + j])


@njit(cache=True)
def _widest_angle_points(pts, V, A, vt, order, a, b, radius, tie, tstamp, vstamp, counter, work):
    """Per segment (a[i], b[i]) of the triangulation's points, the point of
    its closed diametral ball seen under the widest angle (§9.1.2).

    That point is a vertex of the triangles the segment crosses (the seeds,
    :func:`_crossed_triangles`): on each side of a segment that is not an
    edge, the triangle of the constrained triangulation (the segment the
    only constraint) has an empty circle, so its apex, a vertex of those
    triangles, sees the segment under the widest angle of that side. When
    the walk reached the far end and found a point of the ball, the search
    stops there: ties within ``tie`` are broken among the seeds' points.
    Otherwise it is a search over the triangles that meet the region still
    worth looking in: first the ball (radius ``radius[i]``, enlarged),
    then, once a point with angle ``w`` is found, the lens of the points
    that see the segment under at least ``w - tie`` (the intersection of two
    discs through both ends; convex, so the triangles meeting it are
    connected, and each one meets the segment). Regions only shrink, so no
    point that can still win is missed. The points of the seeds come
    first, so that the lens is tight before the search spreads. The disc
    tests pass for every edge at an end of the segment, so such an edge is
    crossed only when it leaves that end inside the region's tangent cone
    (:func:`_enters_cone`): otherwise it meets the region at the end alone.
    Triangle tests are float, padded; ball membership is exact (``dot2d``);
    angles are float. Returns the chosen point (input index; -1 for an
    empty ball) and whether it lies on the segment's line.
    """
    k = a.shape[0]
    choice = np.full(k, -1, np.int64)
    collinear = np.zeros(k, np.bool_)
    queue = np.empty(256, np.int64)
    cand = np.empty(64, np.int64)
    cang = np.empty(64)
    cflat = np.empty(64, np.bool_)
    stamp = counter[0]
    for i in range(k):
        _prefetch_ahead(pts, V, A, vt, a, b, tstamp, vstamp, i)
        stamp += 1
        ia = a[i]
        ib = b[i]
        ax = pts[ia, 0]
        ay = pts[ia, 1]
        bx = pts[ib, 0]
        by = pts[ib, 1]
        cx = 0.5 * (ax + bx)
        cy = 0.5 * (ay + by)
        r2 = radius[i] * radius[i]
        ball2 = r2 * (1.0 + 1e-6)
        # The lens of the angles >= w - tie (w the widest angle with a lens,
        # ``lens_angle``), made when the spreading search first needs it.
        lens_angle = made = -np.inf
        lx1 = ly1 = lx2 = ly2 = lens2 = 0.0
        tip = 0.0  # cosine of the region's half-angle at the ends: the ball's
        best = -np.inf
        nc = 0
        seeds, crossed = _crossed_triangles(pts, V, A, vt, ia, ib, tstamp, stamp, queue)
        tail = seeds
        head = 0
        spreading = False
        while True:
            if head == tail or (not spreading and head == seeds):
                if spreading:
                    break
                if crossed and nc > 0:
                    break
                spreading = True
                head = 0
                continue
            t = queue[head]
            head += 1
            for j in range(3):
                v = V[3 * t + j]
                if vstamp[v] == stamp or v == ia or v == ib:
                    continue
                vstamp[v] = stamp
                px = pts[v, 0]
                py = pts[v, 1]
                if (px - cx) ** 2 + (py - cy) ** 2 > r2:
                    continue
                if dot2d_filtered(ax, ay, bx, by, px, py, work) > 0:
                    continue
                ux = ax - px
                uy = ay - py
                wx = bx - px
                wy = by - py
                angle = np.arctan2(abs(ux * wy - uy * wx), ux * wx + uy * wy)
                # A point on the segment makes a float angle within rounding
                # (a few ulps) of pi: only such angles are tested exactly.
                flat = angle > np.pi - 1e-6 and (
                    orient2d_filtered(ax, ay, bx, by, px, py, work) == 0
                )
                if flat:
                    angle = np.pi
                if nc == cand.shape[0]:
                    cand = np.concatenate((cand, np.empty(nc, np.int64)))
                    cang = np.concatenate((cang, np.empty(nc)))
                    cflat = np.concatenate((cflat, np.empty(nc, np.bool_)))
                cand[nc] = v
                cang[nc] = angle
                cflat[nc] = flat
                nc += 1
                if angle > best:
                    best = angle
                    if 1e-6 < np.pi - (best - tie - 1e-9) < 0.5 * np.pi:
                        lens_angle = best
            if not spreading:
                continue
            if lens_angle != made:
                # Lens of the angles >= lens_angle - tie, a little wider.
                made = lens_angle
                phi = np.pi - (lens_angle - tie - 1e-9)
                half = 0.5 * np.hypot(bx - ax, by - ay)
                nx = -(by - ay) / (2.0 * half)
                ny = (bx - ax) / (2.0 * half)
                d = half / np.tan(phi)
                rr = half / np.sin(phi)
                lx1 = cx + nx * d
                ly1 = cy + ny * d
                lx2 = cx - nx * d
                ly2 = cy - ny * d
                lens2 = (rr * (1.0 + 1e-9) + 1e-9 * half) ** 2
                tip = np.cos(phi)
            lens = made > -np.inf
            for j in range(3):
                kk = 3 * t + j
                u = V[_nxt(kk)]
                w = V[_prv(kk)]
                t2 = A[kk] // 3
                if tstamp[t2] == stamp or V[A[kk]] < 0:
                    continue  # seen, or a ghost across a hull edge
                if not _near_segment(pts, u, w, cx, cy, ball2):
                    continue
                if lens and not (
                    _near_segment(pts, u, w, lx1, ly1, lens2)
                    and _near_segment(pts, u, w, lx2, ly2, lens2)
                ):
                    continue
                # An edge at an end meets the region only at that end (where
                # the disc tests above always pass) unless it leaves the end
                # inside the region's tangent cone.
                if (u == ia or u == ib) != (w == ia or w == ib):
                    if u == ia or w == ia:
                        e, f = ia, ib
                    else:
                        e, f = ib, ia
                    x = w if u == e else u
                    if not _enters_cone(pts, e, f, x, tip):
                        continue
                tstamp[t2] = stamp
                if tail == queue.shape[0]:
                    queue = np.concatenate((queue, np.empty(tail, np.int64)))
                queue[tail] = t2
                tail += 1
        best_id = -1
        for c in range(nc):
            if cang[c] >= best - tie:
                idx = order[cand[c]]
                if best_id < 0 or idx < best_id:
                    best_id = idx
                    collinear[i] = cflat[c]
        choice[i] = best_id
    counter[0] = stamp
    return choice, collinear


@njit(cache=True)
def _disc_edges(pts, V, A, vt, verts, radius, tstamp, counter):
    """Edges that come within ``radius[i]`` (padded) of vertex ``verts[i]``
    and do not end at it: the edges of the triangles meeting that disc (a
    search from the vertex's triangles). Returns (query, u, w) slot triples."""
    queue = np.empty(64, np.int64)
    qs = np.empty(64, np.int64)
    us = np.empty(64, np.int64)
    ws = np.empty(64, np.int64)
    m = 0
    stamp = counter[0]
    for i in range(verts.shape[0]):
        stamp += 1
        x = verts[i]
        cx = pts[x, 0]
        cy = pts[x, 1]
        r2 = (radius[i] * (1.0 + 1e-6)) ** 2
        t = vt[x]
        tstamp[t] = stamp
        queue[0] = t
        head = 0
        tail = 1
        while head < tail:
            t = queue[head]
            head += 1
            for j in range(3):
                kk = 3 * t + j
                u = V[_nxt(kk)]
                w = V[_prv(kk)]
                if not _near_segment(pts, u, w, cx, cy, r2):
                    continue
                if u != x and w != x:
                    if m == qs.shape[0]:
                        qs = np.concatenate((qs, np.empty(m, np.int64)))
                        us = np.concatenate((us, np.empty(m, np.int64)))
                        ws = np.concatenate((ws, np.empty(m, np.int64)))
                    qs[m] = i
                    us[m] = u
                    ws[m] = w
                    m += 1
                t2 = A[kk] // 3
                if tstamp[t2] == stamp or V[A[kk]] < 0:
                    continue
                tstamp[t2] = stamp
                if tail == queue.shape[0]:
                    queue = np.concatenate((queue, np.empty(tail, np.int64)))
                queue[tail] = t2
                tail += 1
    counter[0] = stamp
    return qs[:m], us[:m], ws[:m]


@njit(cache=True)
def _grid_reach(xy, a, b, rows, verts, reach, radius, cell):
    """``reach`` (one per vertex ``verts[i]``) lowered to the distance from
    the vertex to the nearest piece ``rows[j]`` (ends ``a``, ``b``, points
    ``xy``) not incident to it, where that is closer; ``radius`` (at least
    ``reach``) bounds the search. Each vertex is filed in the cells of side
    ``cell`` that its disc's bounding box meets; each piece meets the
    vertices filed in the cells it crosses, column by column (its span in
    each column of cells, padded by a millionth of a cell: the cell of its
    nearest point to the vertex is among them), so every piece within
    ``radius`` is measured, each pair once; a farther one would not lower
    ``reach``. The distance is :func:`point_segment_distance`'s, to the
    same rounding."""
    k = verts.shape[0]
    X = np.empty((k, 2))
    for i in range(k):
        X[i, 0] = xy[verts[i], 0]
        X[i, 1] = xy[verts[i], 1]
    out = reach.copy()
    x0 = (X[:, 0] - radius).min()
    y0 = (X[:, 1] - radius).min()
    nx = int(((X[:, 0] + radius).max() - x0) / cell) + 1
    ny = int(((X[:, 1] + radius).max() - y0) / cell) + 1
    start = np.zeros(nx * ny + 1, np.int64)
    lx = ((X[:, 0] - radius - x0) / cell).astype(np.int64)
    hx = np.minimum(((X[:, 0] + radius - x0) / cell).astype(np.int64), nx - 1)
    ly = ((X[:, 1] - radius - y0) / cell).astype(np.int64)
    hy = np.minimum(((X[:, 1] + radius - y0) / cell).astype(np.int64), ny - 1)
    for i in range(k):
        for ix in range(lx[i], hx[i] + 1):
            for iy in range(ly[i], hy[i] + 1):
                start[ix * ny + iy + 1] += 1
    for c in range(nx * ny):
        start[c + 1] += start[c]
    fill = start[:-1].copy()
    members = np.empty(start[-1], np.int64)
    for i in range(k):
        for ix in range(lx[i], hx[i] + 1):
            for iy in range(ly[i], hy[i] + 1):
                members[fill[ix * ny + iy]] = i
                fill[ix * ny + iy] += 1
    seen = np.full(k, -1, np.int64)
    pad = 1e-6
    for j in range(rows.shape[0]):
        pa = a[rows[j]]
        pb = b[rows[j]]
        ux = xy[pa, 0]
        uy = xy[pa, 1]
        vx = xy[pb, 0]
        vy = xy[pb, 1]
        dx = vx - ux
        dy = vy - uy
        xa = min(ux, vx)
        xb = max(ux, vx)
        ya = min(uy, vy)
        yb = max(uy, vy)
        c0 = max(int(np.floor((xa - x0) / cell - pad)), 0)
        c1 = min(int(np.floor((xb - x0) / cell + pad)), nx - 1)
        for ix in range(c0, c1 + 1):
            lo = ya
            hi = yb
            if dx != 0.0:  # the piece's span of y over this column
                xl = max(xa, x0 + (ix - pad) * cell)
                xh = min(xb, x0 + (ix + 1 + pad) * cell)
                y1 = uy + (xl - ux) * (dy / dx)
                y2 = uy + (xh - ux) * (dy / dx)
                lo = max(ya, min(y1, y2))
                hi = min(yb, max(y1, y2))
            r0 = max(int(np.floor((lo - y0) / cell - pad)), 0)
            r1 = min(int(np.floor((hi - y0) / cell + pad)), ny - 1)
            for iy in range(r0, r1 + 1):
                c = ix * ny + iy
                for e in range(start[c], start[c + 1]):
                    i = members[e]
                    if seen[i] == j:
                        continue
                    seen[i] = j
                    if verts[i] == pa or verts[i] == pb:
                        continue
                    d = point_segment_distance_2d(X[i, 0], X[i, 1], ux, uy, vx, vy)
                    if d < out[i]:
                        out[i] = d
    return out


@njit(cache=True, inline="always")
def _position(ring, lo, hi, w):
    """Position of ``w`` in ``ring[lo:hi]``, or -1."""
    for i in range(lo, hi):
        if ring[i] == w:
            return i
    return -1


@njit(cache=True, inline="always")
def _push(buf, nb, r):
    if nb == buf.shape[0]:
        buf = np.concatenate((buf, np.empty(nb, np.int64)))
    buf[nb] = r
    return buf, nb + 1


@njit(cache=True)
def _missing_pieces(first, n0, rows, ends, rings, gone):
    """The pieces that are not edges after the insertion of points
    ``first, first + 1, ...`` (:meth:`_Pieces.missing`), from the
    neighbours each point had when it went in (``rings``) and the edges
    its insertion removed (``gone``).

    Every piece that is not new was an edge before (a round splits every
    missing piece), and an edge once removed comes back only at an
    insertion of one of its ends. So a piece is missing when the later of
    its ends went in without it (the other end not among that point's
    neighbours: a new point's first piece, and its second one when that
    ends at an older point), or when a later insertion removed it. A
    removed edge is a piece when it joins an added point to the next or
    previous point of its chain, or two input points that end one chain.
    Returns the ids, increasing.
    """
    a, b, left, right, beside, head, tail = rows
    end_start, end_chain, end_side = ends
    ring_start, ring = rings
    gone_start, gone = gone
    out = np.empty(64, np.int64)
    no = 0
    for i in range(ring_start.shape[0] - 1):
        lo = ring_start[i]
        hi = ring_start[i + 1]
        p = first + i
        if _position(ring, lo, hi, beside[p, 0]) < 0:
            out, no = _push(out, no, left[p])
        w = beside[p, 1]
        if w < first and _position(ring, lo, hi, w) < 0:
            out, no = _push(out, no, right[p])
    for j in range(gone_start[-1]):
        u = gone[2 * j]
        w = gone[2 * j + 1]
        if u < n0:
            u, w = w, u
        if u >= n0:  # (one load at a random place: the pieces' ends are two more)
            if beside[u, 0] == w:
                out, no = _push(out, no, left[u])
            elif beside[u, 1] == w:
                out, no = _push(out, no, right[u])
            continue
        for e in range(end_start[u], end_start[u + 1]):
            c = end_chain[e]
            r = head[c] if end_side[e] == 0 else tail[c]
            if (b[r] if end_side[e] == 0 else a[r]) == w:
                out, no = _push(out, no, r)
    ids = radix_sort(out[:no], out[:no])[0]
    k = 0
    for i in range(no):
        if i == 0 or ids[i] != ids[i - 1]:
            ids[k] = ids[i]
            k += 1
    return ids[:k]


#: Runs of one chain longer than this are sorted by merge sort, shorter ones
#: by insertion (a round's points on one chain are few).
_SHORT_RUN = 32


@njit(cache=True)
def _chain_key_order(first, chain, key):
    """The permutation ``first[p]`` of items sorted stably by ``chain``
    (non-negative int64), then ``key`` (float64): what
    ``np.lexsort((key, chain))`` gives for the items in the order ``first``.
    A radix sort of the chains, then each chain's run sorted by key (linear
    time when runs are short)."""
    order = first[radix_argsort(chain[first])]
    n = order.shape[0]
    i0 = 0
    while i0 < n:
        c = chain[order[i0]]
        i1 = i0 + 1
        while i1 < n and chain[order[i1]] == c:
            i1 += 1
        if i1 - i0 > _SHORT_RUN:
            run = order[i0:i1].copy()
            order[i0:i1] = run[np.argsort(key[run], kind="mergesort")]
        else:
            for i in range(i0 + 1, i1):
                x = order[i]
                kx = key[x]
                j = i - 1
                while j >= i0 and key[order[j]] > kx:
                    order[j + 1] = order[j]
                    j -= 1
                order[j + 1] = x
        i0 = i1
    return order


@njit(cache=True, inline="always")
def _ball_radius(xy, u, v, grow, pad):
    """The radius a ball query of segment ``uv`` searches: its half-length
    enlarged, ``half * grow + pad`` (``admissible._enlargement``)."""
    return 0.5 * np.hypot(xy[v, 0] - xy[u, 0], xy[v, 1] - xy[u, 1]) * grow + pad


@njit(cache=True)
def _ball_radii(xy, a, b, grow, pad):
    """:func:`_ball_radius` of each segment ``(a[i], b[i])``."""
    out = np.empty(a.shape[0])
    for i in range(a.shape[0]):
        out[i] = _ball_radius(xy, a[i], b[i], grow, pad)
    return out


@njit(cache=True)
def _search_order(rows, src, a, b, xy, direction, slot, grow, pad, scale):
    """Pieces ``rows`` in the order their searches go (:meth:`_Pieces.along`):
    by input segment, then by position of their midpoints along it
    (:func:`_chain_key_order`); and, in that order, the slots of their ends
    and the radii of their ball queries (:func:`_ball_radius`) in the
    kernel's scale."""
    k = rows.shape[0]
    key = np.empty(k)
    for i in range(k):
        r = rows[i]
        s = src[r]
        key[i] = (xy[a[r], 0] + xy[b[r], 0]) * direction[s, 0] + (
            xy[a[r], 1] + xy[b[r], 1]
        ) * direction[s, 1]
    seq = _chain_key_order(np.arange(k), src[rows], key)
    sa = np.empty(k, np.int64)
    sb = np.empty(k, np.int64)
    radii = np.empty(k)
    for i in range(k):
        r = rows[seq[i]]
        sa[i] = slot[a[r]]
        sb[i] = slot[b[r]]
        radii[i] = _ball_radius(xy, a[r], b[r], grow, pad) * scale
    return seq, sa, sb, radii


@njit(cache=True)
def _split_pieces(split, round_no, m, n, n0, origin, direction, piece, point):
    """Pieces split at new points ``n, n + 1, ...`` (:meth:`_Pieces.split`).

    ``split`` is ``(rows, t, xy, protect_side, near_side, near_vertex)``
    of the new points in any order: they are numbered by input segment,
    then position along it (``xy`` projected on the segment's direction),
    then ``t``. A piece keeps its id for its first part, new piece ``m + i``
    starts at new point ``n + i``; chains, chain tails, the pieces at each
    point, the new points' coordinates and the protection bookkeeping
    follow. Returns the vertex each new point's insertion walks from and
    the order of the new points.
    """
    rows, t, xy_new, protect_side, near_side, near_vertex = split
    a, b, nxt, src, circ, acute, done, near, tail = piece
    xy, radius, left, right, beside, born = point
    key = np.empty(rows.shape[0])
    for i in range(rows.shape[0]):
        s = src[rows[i]]
        key[i] = (xy_new[i, 0] - origin[s, 0]) * direction[s, 0] + (
            xy_new[i, 1] - origin[s, 1]
        ) * direction[s, 1]
    # np.lexsort((t, key, src[rows])): by t (0, 0.5 or 1) stably, then by chain and key
    order = _chain_key_order(np.argsort(t, kind="mergesort"), src[rows], key)
    rows = rows[order]
    protect_side = protect_side[order]
    near_side = near_side[order]
    for i in range(rows.shape[0]):
        xy[n + i, 0] = xy_new[order[i], 0]
        xy[n + i, 1] = xy_new[order[i], 1]
        radius[n + i] = np.nan
    k = rows.shape[0]
    i0 = 0
    while i0 < k:
        r = rows[i0]
        i1 = i0
        while i1 + 1 < k and rows[i1 + 1] == r:
            i1 += 1
        old_b = b[r]
        old_nxt = nxt[r]
        b[r] = n + i0
        nxt[r] = m + i0
        for i in range(i0, i1 + 1):
            q = m + i
            a[q] = n + i
            b[q] = n + i + 1 if i < i1 else old_b
            nxt[q] = q + 1 if i < i1 else old_nxt
            src[q] = src[r]
            circ[q] = circ[r]
            for s in range(2):
                acute[q, s] = False
                done[q, s] = False
                near[q, s] = 0
            left[n + i] = r if i == i0 else q - 1
            right[n + i] = q
            beside[n + i, 0] = a[r] if i == i0 else n + i - 1
            beside[n + i, 1] = b[q]
            born[n + i] = round_no
        last = m + i1
        acute[last, 1] = acute[r, 1]
        done[last, 1] = done[r, 1]
        near[last, 1] = near[r, 1]
        acute[r, 1] = False
        done[r, 1] = False
        near[r, 1] = 0
        if old_nxt < 0:
            tail[src[r]] = last
        if old_b >= n0:
            left[old_b] = last
            beside[old_b, 0] = n + i1
        if a[r] >= n0:
            beside[a[r], 1] = n + i0
        if protect_side[i0] == 0:
            done[r, 0] = True
        if protect_side[i1] == 1:
            done[last, 1] = True
        if near_side[i0] == 0:
            near[r, 0] += 1
        if near_side[i1] == 1:
            near[last, 1] += 1
        i0 = i1 + 1
    return near_vertex[order], order


def _near_segment_message(point: str, segment: str) -> str:
    """The message of ``point_near_segment``, the point and segment named."""
    return (
        f"{point} lies within float64 rounding of {segment} (closer than float64 resolves "
        "there: a split point between them rounds onto an existing point); segments must "
        "stay apart by more than rounding"
    )


def _unresolvable(xy: np.ndarray, segment: int, point: int) -> None:
    """Raise for input point ``point`` lying within float64 rounding of input
    segment ``segment`` (valid in floating point, not resolvable: a split
    point between them rounds onto the point or onto an end of the piece)."""
    msg = _near_segment_message(f"point {point} {xy[point].tolist()}", f"segment {segment}")
    code = "point_near_segment"
    raise InputError(
        msg,
        code=code,
        errors=[
            {"loc": ["segments", segment], "msg": msg, "type": code},
            {"loc": ["points", point], "msg": msg, "type": code},
        ],
    )


def located_in_domain(
    exc: InputError,
    domain: Domain,
    segments: np.ndarray,
    rows: np.ndarray | None = None,
    point_segment: np.ndarray | None = None,
) -> InputError:
    """``exc`` of :func:`admissible_segments` located in the domain (§9.1.5).

    ``segments`` are the domain's segments then constraints; a point the
    error names is located at its vertex, a segment at its first vertex
    (:meth:`Domain.vertex_loc`). When :func:`admissible_segments` ran on
    pieces of them (the triangulator's subsegments), ``rows`` gives each
    piece's segment and ``point_segment`` the segment each point beyond
    the domain's lies on: such a point is located at that segment. The
    message of ``point_near_segment`` then names the point and the segment
    by their rings and vertices (:meth:`Domain.vertex_name`).
    """
    errors = []
    names = {}
    for e in exc.errors:
        path = list(e["loc"])
        if len(path) == 2 and path[0] in ("points", "segments"):
            kind, i = path[0], int(path[1])
            if kind == "points" and i >= len(domain.points) and point_segment is not None:
                path[0], i = "segments", int(point_segment[i])
            elif kind == "segments" and rows is not None:
                i = int(rows[i])
            at = path[0]
            v = i if at == "points" else int(segments[i, 0])
            if v < len(domain.points):
                path = list(domain.vertex_loc(v))
                names[kind] = _domain_name(domain, segments, kind, at, i)
        errors.append({**e, "loc": path})
    message = exc.message
    if exc.code == "point_near_segment" and len(names) == 2:
        message = _near_segment_message(names["points"], names["segments"])
        errors = [{**e, "msg": message} for e in errors]
    return InputError(message, code=exc.code, errors=errors)


def _domain_name(domain: Domain, segments: np.ndarray, kind: str, at: str, i: int) -> str:
    """A point or segment of :func:`located_in_domain` named in the domain:
    an input point (``kind`` "points", located there: ``at`` "points") by
    its vertex, a segment or a point added on one (located at segment ``i``)
    by the segment's vertices."""
    if kind == "points" and at == "points":
        return f"{domain.vertex_name(i)} {domain.points[i].tolist()}"
    a, b = (domain.vertex_name(int(u)) for u in segments[i])
    name = f"the segment from {a} to {b}"
    return name if kind == "segments" else "a point added on " + name


@dataclass
class _State:
    P: np.ndarray
    S: np.ndarray
    source: np.ndarray
    seg_circle: np.ndarray
    acute: np.ndarray  # (m, 2) the end is in an acute cluster (of the input)
    done: np.ndarray  # (m, 2): the end is protected (an apex subsegment)
    radius: np.ndarray  # (n,) protection radius per vertex, NaN if none yet
    near: np.ndarray  # (m, 2) projection splits made near that end of the piece
    n0: int  # input points (the first rows of P)


@njit(cache=True)
def _chain_order(head, nxt, m):
    """Piece ids chain by chain (input segment order), each from its first end."""
    out = np.empty(m, np.int64)
    k = 0
    for s in range(head.shape[0]):
        r = head[s]
        while r >= 0:
            out[k] = r
            k += 1
            r = nxt[r]
    return out


@njit(cache=True)
def _in_chain_order(base, n, m, head, nxt, piece, point):
    """The pieces in chain order and the points added (``base, ..., n - 1``)
    numbered by round, then position of their piece (:meth:`_Pieces.to_state`):
    ``(xy, radius)`` of the points and ``(ends, src, circ, acute, done, near)``
    of the pieces, new arrays."""
    a, b, src, circ, acute, done, near = piece
    xy, radius, right, born = point
    order = _chain_order(head, nxt, m)
    pos = np.empty(m, np.int64)
    for i in range(m):
        pos[order[i]] = i
    k = n - base
    key = np.empty(k, np.int64)
    for i in range(k):
        key[i] = born[base + i] * m + pos[right[base + i]]
    # by round, then position (one linear-time sort of a unique key)
    new = radix_sort(key, np.arange(base, n))[1]
    label = np.arange(n)
    xy_out = np.empty((n, 2))
    radius_out = np.empty(n)
    xy_out[:base] = xy[:base]
    radius_out[:base] = radius[:base]
    for i in range(k):
        label[new[i]] = base + i
        xy_out[base + i, 0] = xy[new[i], 0]
        xy_out[base + i, 1] = xy[new[i], 1]
        radius_out[base + i] = radius[new[i]]
    ends = np.empty((m, 2), np.int64)
    src_out = np.empty(m, src.dtype)
    circ_out = np.empty(m, circ.dtype)
    acute_out = np.empty((m, 2), acute.dtype)
    done_out = np.empty((m, 2), done.dtype)
    near_out = np.empty((m, 2), near.dtype)
    for i in range(m):
        r = order[i]
        ends[i, 0] = label[a[r]]
        ends[i, 1] = label[b[r]]
        src_out[i] = src[r]
        circ_out[i] = circ[r]
        for s in range(2):
            acute_out[i, s] = acute[r, s]
            done_out[i, s] = done[r, s]
            near_out[i, s] = near[r, s]
    return (xy_out, radius_out), (ends, src_out, circ_out, acute_out, done_out, near_out)


def _grown(arr: np.ndarray, size: int) -> np.ndarray:
    """``arr`` in a longer array (the rows beyond it are written before
    they are read: :func:`_split_pieces` fills every new piece and point)."""
    out = np.empty((size,) + arr.shape[1:], dtype=arr.dtype)
    out[: len(arr)] = arr
    return out


class _Pieces:
    """The segments during the rounds, by piece id, in growable arrays.

    A split keeps the piece's id for its first part and gives each new
    point the id of the piece that starts there, so a round costs time in
    the pieces it splits and checks, not in all of them; :meth:`to_state`
    puts the pieces back in chain order and numbers the added points as
    the whole-array rounds did (by round, then along the chains), so the
    output does not depend on this bookkeeping.
    """

    _ROW = ("a", "b", "nxt", "src", "circ", "acute", "done", "near")
    _POINT = ("xy", "radius", "left", "right", "beside", "born")

    def __init__(self, st: _State, dt: IncrementalDelaunay) -> None:
        S, m, n = st.S, len(st.S), len(st.P)
        self.dt, self.n0, self.base, self.m, self.n = dt, st.n0, n, m, n
        self.a, self.b = S[:, 0].copy(), S[:, 1].copy()
        self.src = st.source.copy()
        self.circ = st.seg_circle.copy()
        self.acute, self.done, self.near = st.acute.copy(), st.done.copy(), st.near.copy()
        last = np.ones(m, dtype=bool)
        last[:-1] = self.src[1:] != self.src[:-1]
        self.nxt = np.where(last, -1, np.arange(1, m + 1))
        m0 = int(self.src[-1]) + 1 if m else 0
        self.head = np.full(m0, -1, dtype=np.int64)
        self.head[self.src[::-1]] = np.arange(m)[::-1]
        self.tail = np.full(m0, -1, dtype=np.int64)
        self.tail[self.src[last]] = np.flatnonzero(last)
        self.xy, self.radius = st.P.copy(), st.radius.copy()
        self.left = np.full(n, -1, dtype=np.int64)
        self.right = np.full(n, -1, dtype=np.int64)
        self.left[S[:, 1]] = np.arange(m)
        self.right[S[:, 0]] = np.arange(m)
        # The points before and after each added point along its chain
        # (those of input points are not read).
        self.beside = np.full((n, 2), -1, dtype=np.int64)
        self.beside[S[:, 1], 0] = S[:, 0]
        self.beside[S[:, 0], 1] = S[:, 1]
        self.born = np.zeros(n, dtype=np.int64)
        # Chain ends at the input points: (chain, side) per point, CSR.
        ends = np.concatenate([S[self.head, 0], S[self.tail, 1]])
        chain = np.concatenate([np.arange(m0), np.arange(m0)])
        side = np.repeat([0, 1], m0)
        order, self.end_start = group_slots(ends, n)
        self.end_chain, self.end_side = chain[order], side[order]
        # Position of a point along its input segment (ordering key only).
        self.origin = st.P[S[self.head, 0]]
        self.direction = st.P[S[self.tail, 1]] - self.origin
        keys = edge_keys(S[self.head, 0], S[self.tail, 1], st.n0)
        self.input_chain = np.argsort(keys)
        self.input_keys = keys[self.input_chain]
        # Scratch of the compiled searches.
        self.tstamp = np.zeros(0, np.int64)
        self.vstamp = np.zeros(0, np.int64)
        self.counter = np.zeros(1, np.int64)
        self.work = np.empty(WORK_SIZE)

    # Views of the live rows, as _split_round reads them.
    @property
    def P(self) -> np.ndarray:
        return self.xy[: self.n]

    @property
    def S(self) -> np.ndarray:
        return np.column_stack([self.a[: self.m], self.b[: self.m]])

    @property
    def source(self) -> np.ndarray:
        return self.src[: self.m]

    @property
    def seg_circle(self) -> np.ndarray:
        return self.circ[: self.m]

    def _reserve(self, rows: int, points: int) -> None:
        if self.m + rows > len(self.a):
            size = max(self.m + rows, 2 * len(self.a))
            for name in self._ROW:
                setattr(self, name, _grown(getattr(self, name), size))
        if self.n + points > len(self.xy):
            size = max(self.n + points, 2 * len(self.xy))
            for name in self._POINT:
                setattr(self, name, _grown(getattr(self, name), size))

    def split(self, rows, t, xy, protect_side, near_side, near_vertex, round_no) -> None:
        """Split pieces ``rows`` at the points ``xy`` (ordered along each piece
        by ``t``); the new points go into the triangulation, walked to from
        ``near_vertex``. ``protect_side``/``near_side`` as in the module's
        protection bookkeeping (-1: none)."""
        k = len(rows)
        self._reserve(k, k)
        m, n = self.m, self.n
        near_vertex, order = _split_pieces(
            (rows, t, xy, protect_side, near_side, near_vertex),
            round_no, m, n, self.n0, self.origin, self.direction,
            (self.a, self.b, self.nxt, self.src, self.circ, self.acute, self.done, self.near,
             self.tail),
            (self.xy, self.radius, self.left, self.right, self.beside, self.born),
        )  # fmt: skip
        self.m, self.n, self.first = m + k, n + k, n
        xy = self.xy[n : n + k]
        dup = self.dt.insert(xy, near_vertex)
        if dup is not None:
            i = dup[0] - n
            rows = rows[order]
            if dup[1] < self.n0:
                _unresolvable(self.xy, int(self.src[rows[i]]), dup[1])
            self._touching(int(self.src[rows[i]]), int(self.src[self.right[dup[1]]]), dup[1])
            last = i + int(np.count_nonzero(rows[i:] == rows[i])) - 1  # the piece's last part
            ends_a, ends_b = self.xy[self.a[rows[i]]], self.xy[self.b[m + last]]
            raise AlgorithmError(
                f"cannot split the segment from {ends_a.tolist()} to {ends_b.tolist()}: "
                f"the split "
                f"point {xy[i].tolist()} is an existing point (do segments cross or touch?)"
            )

    def _touching(self, s1: int, s2: int, y: int) -> None:
        """Raise ``point_near_segment`` when the split points of input
        segments ``s1`` and ``s2`` met at added point ``y`` next to an end
        ``E`` of one of them (within :data:`TOUCH` times the largest
        coordinate magnitude): ``E`` lies within float64 rounding of the
        other segment, and the splits between them reached float64
        resolution (a valid polygon in floating point whose vertex is on
        another side in exact rationals). Segments that cross meet away
        from their ends and are left to the caller's AlgorithmError."""
        if s1 == s2:
            return
        chains = np.array([s1, s2])
        ends = np.concatenate([self.a[self.head[chains]], self.b[self.tail[chains]]])
        d = np.hypot(*(self.xy[ends] - self.xy[y]).T)
        k = int(np.argmin(d))
        if d[k] <= TOUCH * float(np.abs(self.xy[: self.n]).max()):
            _unresolvable(self.xy, s2 if k % 2 == 0 else s1, int(ends[k]))

    def edge_pieces_near(self, verts, radius):
        """(query, piece) pairs: pieces that are edges of the triangulation,
        come within ``radius[i]`` (padded) of ``verts[i]`` and do not end there."""
        pts, V, A, vt, order, slot = self.dt.arrays()
        if len(self.tstamp) < len(V) // 3 or len(self.vstamp) < len(pts):
            self.tstamp = np.zeros(len(V) // 3, np.int64)
            self.vstamp = np.zeros(len(pts), np.int64)
            self.counter[0] = 0
        q, u, w = _disc_edges(
            pts, V, A, vt, slot[verts], radius * self.dt.scale, self.tstamp, self.counter
        )
        u, w = order[u], order[w]
        # Candidate pieces: those at an added end, and the unsplit input
        # segment joining two input points.
        cand = [self.left[u], self.right[u], self.left[w], self.right[w]]
        both = (u < self.n0) & (w < self.n0)
        s = self._input_segment(u[both], w[both])
        row = np.full(len(u), -1, dtype=np.int64)
        row[np.flatnonzero(both)[s >= 0]] = self.head[s[s >= 0]]
        cand.append(row)
        qq = np.tile(q, len(cand))
        uu, ww = np.tile(u, len(cand)), np.tile(w, len(cand))
        rows = np.concatenate(cand)
        ok = rows >= 0
        qq, uu, ww, rows = qq[ok], uu[ok], ww[ok], rows[ok]
        ra, rb = self.a[rows], self.b[rows]
        match = ((ra == uu) & (rb == ww)) | ((ra == ww) & (rb == uu))
        return qq[match], rows[match]

    def along(self, rows, grow, pad):
        """Pieces ``rows`` in search order, the slots of their ends and their
        balls' radii in the triangulation's scale (:func:`_search_order`)."""
        slot = self.dt.arrays()[5]
        return _search_order(
            rows, self.src, self.a, self.b, self.xy, self.direction, slot, grow, pad, self.dt.scale
        )

    def end_pieces(self, verts):
        """The pieces at input points ``verts`` (the first or last piece of
        each chain that ends there): their ends (k, 2) and acute flags (k, 2)."""
        lo, hi = self.end_start[verts], self.end_start[verts + 1]
        counts = hi - lo
        idx = np.repeat(lo - (np.cumsum(counts) - counts), counts) + np.arange(counts.sum())
        chain, side = self.end_chain[idx], self.end_side[idx]
        rows = np.where(side == 0, self.head[chain], self.tail[chain])
        return np.column_stack([self.a[rows], self.b[rows]]), self.acute[rows]

    def _input_segment(self, u, w) -> np.ndarray:
        """The chain (input segment) joining input points u and w, or -1."""
        keys = edge_keys(u, w, self.n0)
        pos = np.minimum(np.searchsorted(self.input_keys, keys), len(self.input_keys) - 1)
        return np.where(self.input_keys[pos] == keys, self.input_chain[pos], -1)

    def missing(self) -> np.ndarray:
        """The pieces that are not edges after the last split (the new and
        shortened pieces, and those its insertions removed)."""
        return _missing_pieces(
            self.first, self.n0,
            (self.a, self.b, self.left, self.right, self.beside, self.head, self.tail),
            (self.end_start, self.end_chain, self.end_side),
            self.dt.rings(),
            self.dt.removed(),
        )  # fmt: skip

    def to_state(self, st: _State) -> None:
        """Back to chain order; the points added here numbered by round, then
        along the chains (as the whole-array rounds numbered them)."""
        (st.P, st.radius), (st.S, st.source, st.seg_circle, st.acute, st.done, st.near) = (
            _in_chain_order(
                self.base, self.n, self.m, self.head, self.nxt,
                (self.a, self.b, self.src, self.circ, self.acute, self.done, self.near),
                (self.xy, self.radius, self.right, self.born),
            )
        )  # fmt: skip


@njit(cache=True)
def _projection_points(xy, a, b, missing, enc, acute, done, near_count, radius):
    """Split points of §9.1.4 of the pieces ``missing`` (straight; curved
    ones are moved onto their circles by the caller): the projection of the
    encroaching point ``X = enc[i]`` on the piece, measured from the nearer
    end ``E``; kept at least ``NEAR_END_FRACTION * |EX|`` from ``E`` when
    closer than ``NEAR_END_TRIGGER * |EX|``; moved away from ``E`` by
    :data:`NUDGE` of that distance (at most half the room that keeps ``X``
    outside the new piece's ball).

    Returns the points (k, 2), the side (0 or 1) of the nearer end, and
    (k, 2) whether that end is an unprotected acute end that had a
    projection split near it already (the chase of Exercise 9.3: it is to
    be protected now).
    """
    k = missing.shape[0]
    M = np.empty((k, 2))
    near = np.empty(k, np.int64)
    again = np.zeros((k, 2), np.bool_)
    tiny = np.finfo(np.float64).tiny
    for i in range(k):
        r = missing[i]
        ax = xy[a[r], 0]
        ay = xy[a[r], 1]
        bx = xy[b[r], 0]
        by = xy[b[r], 1]
        px = xy[enc[i], 0]
        py = xy[enc[i], 1]
        dx = bx - ax
        dy = by - ay
        length = np.sqrt(dx * dx + dy * dy)
        t = ((px - ax) * dx + (py - ay) * dy) / (dx * dx + dy * dy)
        if t <= 0.5:
            s, ex, ey, fx, fy, foot = 0, ax, ay, bx, by, t * length
        else:
            s, ex, ey, fx, fy, foot = 1, bx, by, ax, ay, (1.0 - t) * length
        ep = np.hypot(px - ex, py - ey)
        if foot < NEAR_END_TRIGGER * ep:
            along = NEAR_END_FRACTION * ep
            room = np.inf
        else:
            along = foot
            # X stays outside the ball of [E, M] while height**2 >= foot * (|EM| - foot).
            room = 0.5 * max(ep * ep - foot * foot, 0.0) / max(foot, tiny)
        along = along + min(NUDGE * along, room)
        f = along / length
        M[i, 0] = ex + (fx - ex) * f
        M[i, 1] = ey + (fy - ey) * f
        near[i] = s
        e = a[r] if s == 0 else b[r]
        again[i, s] = acute[r, s] and not done[r, s] and near_count[r, s] >= 1
        again[i, s] = again[i, s] and np.isnan(radius[e])
    return M, near, again


@njit(cache=True)
def _split_points(xy, a, b, missing, M, near, enc, acute, done, radius, work):
    """The round's split points, protection points first (§9.1.4,
    Exercise 9.4): every unprotected acute end of a missing piece whose
    vertex has a protection radius gets the point at that distance from it
    (straight; the caller moves curved ones onto their circles); the other
    pieces their projection point ``M`` of the encroaching point ``enc``.

    Returns, per point: its piece, coordinates, order along the piece (the
    protected side, 0.5 for a projection), protected side (-1: none), side
    of the nearer end of a projection (-1: none), the vertex its insertion
    walks from (the protected end, or the encroaching point, whose
    projection the point is: nearer than the piece's end), and whether it
    fails to lie strictly inside the piece's diametral ball (exact
    ``dot2d``).
    """
    k = missing.shape[0]
    protect = np.zeros((k, 2), np.bool_)
    total = 0
    for i in range(k):
        r = missing[i]
        protect[i, 0] = acute[r, 0] and not done[r, 0] and not np.isnan(radius[a[r]])
        protect[i, 1] = acute[r, 1] and not done[r, 1] and not np.isnan(radius[b[r]])
        total += max(1, int(protect[i, 0]) + int(protect[i, 1]))
    rows = np.empty(total, np.int64)
    pts = np.empty((total, 2))
    t = np.empty(total)
    protect_side = np.full(total, -1, np.int64)
    near_side = np.full(total, -1, np.int64)
    near_vertex = np.empty(total, np.int64)
    j = 0
    for i in range(k):
        r = missing[i]
        for s in range(2):
            if not protect[i, s]:
                continue
            e = a[r] if s == 0 else b[r]
            f = b[r] if s == 0 else a[r]
            dx = xy[f, 0] - xy[e, 0]
            dy = xy[f, 1] - xy[e, 1]
            scale = radius[e] / np.hypot(dx, dy)
            rows[j] = r
            pts[j, 0] = xy[e, 0] + dx * scale
            pts[j, 1] = xy[e, 1] + dy * scale
            t[j] = s
            protect_side[j] = s
            near_vertex[j] = e
            j += 1
    for i in range(k):
        if protect[i, 0] or protect[i, 1]:
            continue
        r = missing[i]
        rows[j] = r
        pts[j, 0] = M[i, 0]
        pts[j, 1] = M[i, 1]
        t[j] = 0.5
        near_side[j] = near[i]
        near_vertex[j] = enc[i]
        j += 1
    bad = np.empty(total, np.bool_)
    for j in range(total):
        ia = a[rows[j]]
        ib = b[rows[j]]
        sign = dot2d_filtered(
            xy[ia, 0], xy[ia, 1], xy[ib, 0], xy[ib, 1], pts[j, 0], pts[j, 1], work
        )
        bad[j] = sign >= 0
    return rows, pts, t, protect_side, near_side, near_vertex, bad
