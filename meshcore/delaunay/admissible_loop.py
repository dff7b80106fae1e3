"""The compiled splitting loop of the admissible boundaries (§9.1.2-§9.1.5).

:func:`_split_loop` takes the missing pieces one at a time from a work
stack: a piece that is an edge of the triangulation by now is dropped;
otherwise its widest-angle encroacher is found (:func:`_widest_angle`), the
piece is split at that point's projection (or at the protection radius of
an acute end, or on its circle), the split point is inserted into the one
growing triangulation (the kernel's own insertion,
:func:`~meshcore.delaunay.kernel2d._insert_range`), and the new pieces and
every piece whose edge the insertion removed go on the stack, to be checked
next while they are in cache. A piece is missing only after an insertion
removed it or when it is new (an edge once removed comes back only at an
insertion of one of its ends), so every missing piece is on the stack or
deferred, and the loop ends when none is left: every piece is an edge.

What needs more than the piece at hand goes back to the caller
(:mod:`meshcore.delaunay.admissible`) with a status: room to grow, the
protection radii of acute vertices (the pieces that need them are deferred
until the stack is empty, then all their vertices are protected at once),
the errors, and a tick now and then for progress.

References
----------
Methods text §9.1.2-§9.1.5, Exercises 9.2-9.5.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from meshcore.delaunay.admissible_pieces import (
    NEAR_END_FRACTION,
    NEAR_END_TRIGGER,
    NUDGE,
    _ball_radius,
    _near_segment,
    _push,
)
from meshcore.delaunay.kernel2d import _DUPLICATE, _corner, _insert_range, _nxt, _prv
from meshcore.geometry.predicates import dot2d_filtered, orient2d_filtered

__all__: list[str] = []

#: Statuses of :func:`_split_loop`: every piece is an edge; arrays to grow;
#: acute vertices to protect; a point inside a piece (not a PSLG); a split
#: point not strictly inside its piece's ball; a split point on an existing
#: point; the added points' limit; a missing piece with an empty ball
#: (inconsistent predicates); a pause for progress.
DONE, ROOM, PROTECT, ON_SEGMENT, BAD_SPLIT, DUPLICATE, BUDGET, EMPTY_BALL, TICK = range(9)
#: Points added between two progress reports.
TICK_POINTS = 1 << 16


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
    """Seeds of :func:`_widest_angle`: a triangle at ``ia``, then the
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


@njit(cache=True)
def _widest_angle(pts, V, A, vt, order, ia, ib, radius, tie, tstamp, vstamp, stamp, work, buf):
    """The point of the closed diametral ball of the segment of slots
    ``(ia, ib)`` seen under the widest angle (§9.1.2).

    That point is a vertex of the triangles the segment crosses (the seeds,
    :func:`_crossed_triangles`): on each side of a segment that is not an
    edge, the triangle of the constrained triangulation (the segment the
    only constraint) has an empty circle, so its apex, a vertex of those
    triangles, sees the segment under the widest angle of that side. When
    the walk reached the far end and found a point of the ball, the search
    stops there: ties within ``tie`` are broken among the seeds' points.
    Otherwise it is a search over the triangles that meet the region still
    worth looking in: first the ball (radius ``radius``, enlarged), then,
    once a point with angle ``w`` is found, the lens of the points that see
    the segment under at least ``w - tie`` (the intersection of two discs
    through both ends; convex, so the triangles meeting it are connected,
    and each one meets the segment). Regions only shrink, so no point that
    can still win is missed. The points of the seeds come first, so that
    the lens is tight before the search spreads. The disc tests pass for
    every edge at an end of the segment, so such an edge is crossed only
    when it leaves that end inside the region's tangent cone
    (:func:`_enters_cone`): otherwise it meets the region at the end alone.
    Triangle tests are float, padded; ball membership is exact (``dot2d``);
    angles are float. ``buf`` is the scratch ``(queue, cand, cang, cflat)``,
    grown when too short. Returns the chosen point (input index; -1 for an
    empty ball), whether it lies on the segment's line, and ``buf``.
    """
    queue, cand, cang, cflat = buf
    ax = pts[ia, 0]
    ay = pts[ia, 1]
    bx = pts[ib, 0]
    by = pts[ib, 1]
    cx = 0.5 * (ax + bx)
    cy = 0.5 * (ay + by)
    r2 = radius * radius
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
            flat = angle > np.pi - 1e-6 and (orient2d_filtered(ax, ay, bx, by, px, py, work) == 0)
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
            queue, tail = _push(queue, tail, t2)
    best_id = -1
    collinear = False
    for c in range(nc):
        if cang[c] >= best - tie:
            idx = order[cand[c]]
            if best_id < 0 or idx < best_id:
                best_id = idx
                collinear = cflat[c]
    return best_id, collinear, (queue, cand, cang, cflat)


@njit(cache=True, inline="always")
def _is_edge(V, A, vt, u, w):
    """Whether slots ``u`` and ``w`` are joined by an edge (a turn around ``u``)."""
    t0 = vt[u]
    t = t0
    while True:
        k = _corner(V, t, u)
        if V[_nxt(k)] == w:
            return True
        t = A[_prv(k)] // 3
        if t == t0:
            return False


@njit(cache=True, inline="always")
def _projection(ax, ay, bx, by, px, py):
    """Split point of §9.1.4 of the segment ``AB``: the projection of the
    encroaching point ``X = (px, py)``, measured from the nearer end ``E``;
    kept at least ``NEAR_END_FRACTION * |EX|`` from ``E`` when closer than
    ``NEAR_END_TRIGGER * |EX|``; moved away from ``E`` by :data:`NUDGE` of
    that distance (at most half the room that keeps ``X`` outside the new
    piece's ball). Returns the point and the side (0: A, 1: B) of ``E``."""
    tiny = np.finfo(np.float64).tiny
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
    return ex + (fx - ex) * f, ey + (fy - ey) * f, s


@njit(cache=True, inline="always")
def _onto_circle(x, y, circle):
    """``(x, y)`` moved radially onto the circle ``(cx, cy, r)`` (§9.1.5)."""
    dx = x - circle[0]
    dy = y - circle[1]
    f = circle[2] / np.hypot(dx, dy)
    return circle[0] + dx * f, circle[1] + dy * f


@njit(cache=True, inline="always")
def _protection_point(xy, e, f, r, circ, circles):
    """The point at distance ``r`` from vertex ``e`` toward ``f`` (Exercise
    9.4): on the segment, or for a curved piece on its circle, at chord
    distance ``r`` from ``e`` on the arc toward ``f``."""
    if circ < 0:
        dx = xy[f, 0] - xy[e, 0]
        dy = xy[f, 1] - xy[e, 1]
        scale = r / np.hypot(dx, dy)
        return xy[e, 0] + dx * scale, xy[e, 1] + dy * scale
    cx = circles[circ, 0]
    cy = circles[circ, 1]
    R = circles[circ, 2]
    ux = xy[e, 0] - cx
    uy = xy[e, 1] - cy
    g = R / np.hypot(ux, uy)
    ux *= g
    uy *= g
    turn = np.sign(ux * (xy[f, 1] - cy) - uy * (xy[f, 0] - cx))
    phi = 2.0 * np.arcsin(min(r / (2.0 * R), 1.0)) * turn
    c = np.cos(phi)
    s = np.sin(phi)
    return cx + c * ux - s * uy, cy + s * ux + c * uy


@njit(cache=True)
def _split_loop(kernel, piece, point, ends, circles, work_stack, deferred, counts, params, stamps):
    """Split the missing pieces one at a time until every piece is an edge.

    ``kernel`` are the growing triangulation's arrays
    (:meth:`~meshcore.delaunay.kernel2d.IncrementalDelaunay.insertion_arrays`),
    ``piece`` and ``point`` the pieces' and points' rows
    (:class:`~meshcore.delaunay.admissible_pieces._Pieces`), ``ends`` the
    chains at each input point, ``circles`` the curves (local frame),
    ``work_stack`` ``(stack, size)`` the pieces to check (the last first),
    ``deferred`` ``(rows, vertex, distance, size)`` the pieces waiting for
    the protection of an acute vertex and the distance of their projection
    from it, ``counts`` ``(m, n, n0, n_stop, tick)``: pieces, points, input
    points, the points' limit and the next progress report; ``params``
    ``(factor, grow, pad, tie)``, ``stamps`` ``(tstamp, vstamp, counter)``
    the searches' marks.

    Each piece taken: dropped when it is an edge; else its widest-angle
    encroacher ``X`` (:func:`_widest_angle`); it is split at the protection
    radius of each unprotected acute end whose vertex has one (Exercise
    9.4), else at the projection of ``X`` (:func:`_projection`; on its
    circle for a curved piece, §9.1.5), unless that projection is the
    second near an unprotected acute end: then the piece is deferred until
    the vertex is protected (Exercise 9.3's chase may have begun). The new
    points go into the triangulation (walked to from the protected end or
    from ``X``); the new pieces and the pieces whose edges the insertions
    removed are pushed. Returns ``(status, stack, size, deferred arrays,
    size, m, n, info)``: ``info`` names the piece and points of an error.
    """
    pts, V, A, tstack, vt, hint, state, work, order, slot, log = kernel
    a, b, nxt, src, circ, acute, done, near, head, tail = piece
    xy, radius, left, right, beside = point
    end_start, end_chain, end_side = ends
    stack, sp = work_stack
    drows, dvert, ddist, nd = deferred
    m, n, n0, n_stop, tick = counts
    factor, grow, pad, tie = params
    tstamp, vstamp, counter = stamps
    info = np.full(4, -1, np.int64)
    buf = (
        np.empty(256, np.int64),
        np.empty(64, np.int64),
        np.empty(64),
        np.empty(64, np.bool_),
    )
    new_xy = np.empty((2, 2))
    new_t = np.empty(2, np.int64)  # protected side, or -1: a projection
    new_from = np.empty(2, np.int64)
    stamp = counter[0]
    status = DONE
    while sp > 0:
        if n > n_stop:
            status = BUDGET
            break
        if n >= tick:
            status = TICK
            break
        if (
            m + 2 > a.shape[0]
            or n + 2 > xy.shape[0]
            or n + 2 > pts.shape[0]
            or 2 * (n + 2) > tstamp.shape[0]
            or n + 2 > vstamp.shape[0]
        ):
            status = ROOM
            break
        sp -= 1
        r = stack[sp]
        pa = a[r]
        pb = b[r]
        ia = slot[pa]
        ib = slot[pb]
        if _is_edge(V, A, vt, ia, ib):
            continue
        stamp += 1
        rad = _ball_radius(xy, pa, pb, grow, pad) * factor
        x, flat, buf = _widest_angle(
            pts, V, A, vt, order, ia, ib, rad, tie, tstamp, vstamp, stamp, work, buf
        )
        if x < 0 or flat:
            status = EMPTY_BALL if x < 0 else ON_SEGMENT
            info[0] = r
            info[1] = x
            sp += 1
            break
        # The split points, in order along the piece.
        k = 0
        side = -1
        for s in range(2):
            e = pa if s == 0 else pb
            if acute[r, s] and not done[r, s] and not np.isnan(radius[e]):
                f = pb if s == 0 else pa
                px, py = _protection_point(xy, e, f, radius[e], circ[r], circles)
                new_xy[k, 0] = px
                new_xy[k, 1] = py
                new_t[k] = s
                new_from[k] = e
                k += 1
        if k == 0:
            px, py, side = _projection(
                xy[pa, 0], xy[pa, 1], xy[pb, 0], xy[pb, 1], xy[x, 0], xy[x, 1]
            )
            if circ[r] >= 0:
                px, py = _onto_circle(px, py, circles[circ[r]])
            e = pa if side == 0 else pb
            if acute[r, side] and not done[r, side] and near[r, side] >= 1 and np.isnan(radius[e]):
                if nd == drows.shape[0]:
                    drows = np.concatenate((drows, np.empty(nd, np.int64)))
                    dvert = np.concatenate((dvert, np.empty(nd, np.int64)))
                    ddist = np.concatenate((ddist, np.empty(nd)))
                drows[nd] = r
                dvert[nd] = e
                ddist[nd] = np.hypot(px - xy[e, 0], py - xy[e, 1])
                nd += 1
                continue
            new_xy[0, 0] = px
            new_xy[0, 1] = py
            new_t[0] = -1
            new_from[0] = x
            k = 1
        for i in range(k):
            if (
                dot2d_filtered(
                    xy[pa, 0], xy[pa, 1], xy[pb, 0], xy[pb, 1], new_xy[i, 0], new_xy[i, 1], work
                )
                >= 0
            ):
                status = BAD_SPLIT
                info[0] = r
                info[1] = x
                info[2] = side
                break
        if status == BAD_SPLIT:
            sp += 1
            break
        # Split: the piece keeps its id for its first part, new piece m + i
        # starts at new point n + i (the chains' bookkeeping).
        old_b = pb
        old_nxt = nxt[r]
        b[r] = n
        nxt[r] = m
        for i in range(k):
            q = m + i
            a[q] = n + i
            b[q] = n + i + 1 if i < k - 1 else old_b
            nxt[q] = q + 1 if i < k - 1 else old_nxt
            src[q] = src[r]
            circ[q] = circ[r]
            for s in range(2):
                acute[q, s] = False
                done[q, s] = False
                near[q, s] = 0
            xy[n + i, 0] = new_xy[i, 0]
            xy[n + i, 1] = new_xy[i, 1]
            radius[n + i] = np.nan
            left[n + i] = r if i == 0 else q - 1
            right[n + i] = q
            beside[n + i, 0] = pa if i == 0 else n + i - 1
            beside[n + i, 1] = b[q]
        last = m + k - 1
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
            beside[old_b, 0] = n + k - 1
        if pa >= n0:
            beside[pa, 1] = n
        if new_t[0] == 0:
            done[r, 0] = True
        if new_t[k - 1] == 1:
            done[last, 1] = True
        if side == 0:
            near[r, 0] += 1
        elif side == 1:
            near[last, 1] += 1
        # Insert the new points; push the pieces whose edges they removed.
        for i in range(k):
            p = n + i
            pts[p, 0] = xy[p, 0] * factor
            pts[p, 1] = xy[p, 1] * factor
            order[p] = p
            slot[p] = p
            hint[p] = slot[new_from[i]]
            nlog = _insert_range(pts, V, A, tstack, vt, hint, state, work, p, p + 1, log)
            if state[2] == _DUPLICATE:
                status = DUPLICATE
                info[0] = r
                info[1] = order[state[4]]
                info[2] = p
                info[3] = last
                break
            for j in range(nlog):
                u = log[2 * j]
                w = log[2 * j + 1]
                if u < 0 or w < 0:
                    continue
                u = order[u]
                w = order[w]
                if u < n0:
                    u, w = w, u
                if u >= n0:
                    if beside[u, 0] == w:
                        stack, sp = _push(stack, sp, left[u])
                    elif beside[u, 1] == w:
                        stack, sp = _push(stack, sp, right[u])
                    continue
                for g in range(end_start[u], end_start[u + 1]):
                    c = end_chain[g]
                    q = head[c] if end_side[g] == 0 else tail[c]
                    if (b[q] if end_side[g] == 0 else a[q]) == w:
                        stack, sp = _push(stack, sp, q)
        if status == DUPLICATE:
            m += k
            n += k
            break
        for i in range(k - 1, -1, -1):
            stack, sp = _push(stack, sp, m + i)
        stack, sp = _push(stack, sp, r)
        m += k
        n += k
    if status == DONE and nd > 0:
        status = PROTECT
    counter[0] = stamp
    return status, stack, sp, (drows, dvert, ddist, nd), m, n, info
