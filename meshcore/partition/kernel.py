"""Compiled kernels of the recursive partition (§8.7.2): separators and recursion.

A polygon is a cycle of point indices with the domain on its left (a hole
joined by a bridge visits the bridge's points twice, once each way: a weakly
simple polygon). Every geometric decision is a sign of
:func:`~meshcore.geometry.predicates.orient2d_scalar`:

* a separator between the vertices at positions ``i`` and ``j`` is *valid*
  when it leaves each end strictly inside the interior angle of that
  occurrence of the vertex (:func:`in_wedge`) and touches no polygon edge
  that does not end at ``a`` or ``b`` (closed segment test, collinear
  overlaps included);
* a quad is strictly convex when its four corners turn left.

The recursion is one sequential loop over a stack of polygons (inherently
sequential: each split depends on the last); polygons live in one flat
buffer, the top of the stack at its end.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from meshcore.geometry.predicates import orient2d_scalar

# status codes of recurse()
OK = 0
FULL = 1  # a buffer is full: the caller grows it and runs again
STUCK = 2  # quad mode: a polygon without a valid even split

# strategy codes
BALANCED = 0
ANGLE = 1

_SAMPLE = 30  # sampled positions per polygon above this count (twice, for parity)
_ANGLE_WEIGHT = 1.5
_MIN_SPLIT_ANGLE = 0.05  # radians: separators closer to an edge only in the full search
_QUAD_SPLIT_ANGLE = 0.3  # radians (17 degrees): quads, the least angle to an edge
_TINY_ANGLE = 1e-6  # radians: never closer than this
_TINY_Q = 2.0 * _TINY_ANGLE / math.pi  # corner quality (8.3) of a corner _TINY_ANGLE from flat
_RESOLUTION = 1e-7  # scores and separator integrals are compared at this resolution
_FLAT_BONUS = 0.5  # quads: score bonus per separator end at a flat vertex
_MIN_Q = 0.1  # quads: least corner quality (8.3) of a leaf or pattern quad
_FLAT_ANGLE = 0.15  # radians from a straight angle: a flat vertex
_CLOSABLE_MAX = 8  # quads: parts up to this many sides must have a pattern
_CENTRE_MAX = 12  # largest polygon closed by the centre pattern when no split is valid


@njit(cache=True)
def size_at(H, grid, x, y):
    """Bilinear read of the size grid (1x1: constant)."""
    ny, nx = H.shape
    if ny == 1 and nx == 1:
        return H[0, 0]
    fx = min(max((x - grid[0]) / grid[2], 0.0), nx - 1.0)
    fy = min(max((y - grid[1]) / grid[3], 0.0), ny - 1.0)
    i = min(int(fx), nx - 2)
    j = min(int(fy), ny - 2)
    u = fx - i
    v = fy - j
    return (1 - v) * ((1 - u) * H[j, i] + u * H[j, i + 1]) + v * (
        (1 - u) * H[j + 1, i] + u * H[j + 1, i + 1]
    )


@njit(cache=True)
def orient(P, a, b, c):
    return orient2d_scalar(P[a, 0], P[a, 1], P[b, 0], P[b, 1], P[c, 0], P[c, 1])


@njit(cache=True)
def in_wedge(P, p, v, q, t):
    """Whether the ray v -> t leaves v strictly inside the interior angle (p, v, q)."""
    turn = orient(P, p, v, q)
    s1 = orient(P, v, q, t)
    s2 = orient(P, p, v, t)
    if turn >= 0:
        return s1 > 0 and s2 > 0
    return s1 > 0 or s2 > 0


@njit(cache=True)
def touch(P, a, b, c, d):
    """Whether the closed segments ab and cd share a point."""
    o1 = orient(P, a, b, c)
    o2 = orient(P, a, b, d)
    if o1 * o2 > 0:
        return False
    o3 = orient(P, c, d, a)
    o4 = orient(P, c, d, b)
    if o3 * o4 > 0:
        return False
    if o1 == 0 and o2 == 0:
        ax = 0 if P[a, 0] != P[b, 0] else 1
        lo1 = min(P[a, ax], P[b, ax])
        hi1 = max(P[a, ax], P[b, ax])
        lo2 = min(P[c, ax], P[d, ax])
        hi2 = max(P[c, ax], P[d, ax])
        return not (hi1 < lo2 or hi2 < lo1)
    return True


@njit(cache=True)
def crosses_any(P, a, b, ea, eb, m):
    """Whether segment ab touches any of the m edges (ea[k], eb[k]) not ending at a or b."""
    for k in range(m):
        c = ea[k]
        d = eb[k]
        if c == a or c == b or d == a or d == b:
            continue
        if touch(P, a, b, c, d):
            return True
    return False


@njit(cache=True)
def _valid(P, poly, n, i, j):
    a = poly[i]
    b = poly[j]
    if a == b:
        return False
    if not in_wedge(P, poly[(i - 1) % n], a, poly[(i + 1) % n], b):
        return False
    if not in_wedge(P, poly[(j - 1) % n], b, poly[(j + 1) % n], a):
        return False
    for k in range(n):
        c = poly[k]
        d = poly[(k + 1) % n]
        if c == a or c == b or d == a or d == b:
            continue
        if touch(P, a, b, c, d):
            return False
    return True


@njit(cache=True)
def _angle(P, v, u, w):
    """Counter-clockwise angle at v from direction v->u to direction v->w, in [0, 2pi)
    (0 when the directions agree in floating point, whatever the exact sign)."""
    ux = P[u, 0] - P[v, 0]
    uy = P[u, 1] - P[v, 1]
    wx = P[w, 0] - P[v, 0]
    wy = P[w, 1] - P[v, 1]
    t = math.atan2(ux * wy - uy * wx, ux * wx + uy * wy)
    if t < 0.0:
        t += 2.0 * math.pi
    return t


@njit(cache=True)
def _convex4(P, a, b, c, d, nfix):
    """Strictly convex (exact signs), corner quality (8.3) at least _MIN_Q at fixed points."""
    if not (
        orient(P, a, b, c) > 0
        and orient(P, b, c, d) > 0
        and orient(P, c, d, a) > 0
        and orient(P, d, a, b) > 0
    ):
        return False
    # corners at fixed points (index < nfix) must be good; the others may be
    # nearly flat (smoothing moves them afterwards) but not within _TINY_ANGLE of
    # flat: a separator's own points are flat up to rounding, whose sign would choose
    return (
        _corner_q(_angle(P, b, c, a)) >= (_TINY_Q if b >= nfix else _MIN_Q)
        and _corner_q(_angle(P, c, d, b)) >= (_TINY_Q if c >= nfix else _MIN_Q)
        and _corner_q(_angle(P, d, a, c)) >= (_TINY_Q if d >= nfix else _MIN_Q)
        and _corner_q(_angle(P, a, b, d)) >= (_TINY_Q if a >= nfix else _MIN_Q)
    )


@njit(cache=True)
def _corner_q(theta):
    if theta < math.pi / 2:
        return 2.0 * theta / math.pi
    return max(0.0, 2.0 - 2.0 * theta / math.pi)


@njit(cache=True)
def _flat(P, p, v, q):
    """Whether the corner (p, v, q) is within _FLAT_ANGLE of a straight angle."""
    return abs(_angle(P, v, q, p) - math.pi) < _FLAT_ANGLE


@njit(cache=True)
def _pieces(t, quad):
    """Pieces of a separator whose integral of 1/h is t: nearest count (odd for quads)."""
    if not quad:
        return max(1, int(math.floor(t + 0.5)))
    k1 = max(1, 2 * int(math.floor((t - 1.0) / 2.0)) + 1)
    k2 = k1 + 2
    return k2 if (k2 - t) < (t - k1) else k1


@njit(cache=True)
def _rounded(x):
    """x rounded to _RESOLUTION: scores and counts that differ by rounding tie."""
    return math.floor(x / _RESOLUTION + 0.5) * _RESOLUTION


@njit(cache=True)
def _integral(L, ha, hb):
    if abs(hb - ha) <= 1e-9 * ha:
        return L / ha
    return L * math.log(hb / ha) / (hb - ha)


@njit(cache=True)
def _positions(n):
    if n <= 2 * _SAMPLE:
        return np.arange(n)
    out = np.empty(2 * _SAMPLE, np.int64)
    for s in range(_SAMPLE):
        p = (s * n) // _SAMPLE
        out[2 * s] = p
        out[2 * s + 1] = (p + 1) % n
    return np.unique(out)


@njit(cache=True)
def _score(nfix, P, poly, n, i, j, hv, quad, strategy, reflex_angle, scratch, relaxed):
    """(score, pieces) of the separator (i, j), i < j; score inf when not allowed (quads:
    separators down to _QUAD_SPLIT_ANGLE from an edge; triangles, relaxed: down to
    _TINY_ANGLE, else _MIN_SPLIT_ANGLE). ``hv``: the size at each vertex of ``poly``."""
    m1 = j - i
    m2 = n - m1
    if quad:
        if m1 % 2 == 0 or m1 < 3 or m2 < 3:
            return np.inf, 0
    elif m1 < 2 or m2 < 2:
        return np.inf, 0
    a = poly[i]
    b = poly[j]
    dx = P[b, 0] - P[a, 0]
    dy = P[b, 1] - P[a, 1]
    L = math.sqrt(dx * dx + dy * dy)
    ha = hv[i]
    hb = hv[j]
    # rounded: equal up to rounding means equal (the same mesh after scaling)
    t = _rounded(_integral(L, ha, hb))
    k = _pieces(t, quad)
    if quad and k >= 3 and min(m1, m2) == 3:
        # a hexagon with two flat neighbours has no convex quad pattern
        k = 1
    if quad and min(m1, m2) + k <= _CLOSABLE_MAX:
        # a small part must have a convex quad pattern: look ahead
        if scratch + k + 1 > len(P):
            return np.inf, 0
        for q in range(1, k):
            _sep_point(P, a, b, q, k, ha, hb, scratch + q - 1)
        if m1 + k <= _CLOSABLE_MAX:
            part = np.empty(m1 + k, np.int64)
            for q in range(m1 + 1):
                part[q] = poly[i + q]
            for q in range(k - 1):
                part[m1 + 1 + q] = scratch + k - 2 - q
            if not _closable(nfix, P, part, scratch + k - 1):
                return np.inf, 0
        if m2 + k <= _CLOSABLE_MAX:
            part = np.empty(m2 + k, np.int64)
            for q in range(m2 + 1):
                part[q] = poly[(j + q) % n]
            for q in range(k - 1):
                part[m2 + 1 + q] = scratch + q
            if not _closable(nfix, P, part, scratch + k - 1):
                return np.inf, 0
    # the four angles the separator makes at its ends
    pa = poly[(i - 1) % n]
    na = poly[i + 1]
    pb = poly[j - 1]
    nb = poly[(j + 1) % n]
    a1 = _angle(P, a, na, b)  # part 1 at a
    a2 = _angle(P, a, b, pa)  # part 2 at a
    b1 = _angle(P, b, a, pb)  # part 1 at b
    b2 = _angle(P, b, nb, a)  # part 2 at b
    target = math.pi / 2.0 if quad else math.pi / 3.0
    amin = min(min(a1, a2), min(b1, b2))
    if amin < (_QUAD_SPLIT_ANGLE if quad else (_TINY_ANGLE if relaxed else _MIN_SPLIT_ANGLE)):
        # exactly inside but nearly along an edge (a subdivided separator, its
        # points rounded off the line): slivers and coincident points
        return np.inf, 0
    c_ang = max(0.0, 1.0 - amin / target)
    c_len = t / min(m1, m2)
    if quad:
        # a flat vertex can only be a quad corner once a separator splits it
        if _flat(P, pa, a, na):
            c_len -= _FLAT_BONUS
        if _flat(P, pb, b, nb):
            c_len -= _FLAT_BONUS
    if strategy == ANGLE and reflex_angle > 0.0:
        return _rounded(abs(a1 - a2) / reflex_angle + 0.3 * c_len + _ANGLE_WEIGHT * c_ang), k
    return _rounded(c_len + _ANGLE_WEIGHT * c_ang), k


@njit(cache=True)
def _best_split(nfix, P, poly, n, H, grid, quad, strategy, full, relaxed, scratch):
    """Best valid separator (i, j, k) of the polygon, or (-1, -1, 0): among all pairs
    (``full``) or those of the sampled positions, angles as :func:`_score` ``relaxed``;
    the size map read once per vertex, not at both ends of every pair scored."""
    pos = np.arange(n) if full else _positions(n)
    hv = np.empty(n)
    for i in range(n):
        hv[i] = size_at(H, grid, P[poly[i], 0], P[poly[i], 1])
    reflex_at = -1
    reflex_angle = 0.0
    if strategy == ANGLE:
        for i in range(n):
            th = _angle(P, poly[i], poly[(i + 1) % n], poly[(i - 1) % n])
            if th > reflex_angle:
                reflex_angle = th
                reflex_at = i
        if reflex_angle <= math.pi:
            reflex_angle = 0.0
            reflex_at = -1
    m = len(pos)
    cap = m * m if reflex_at < 0 else n
    sc = np.empty(cap)
    ci = np.empty(cap, np.int64)
    cj = np.empty(cap, np.int64)
    ck = np.empty(cap, np.int64)
    c = 0
    if reflex_at >= 0:
        for q in range(n):
            i = min(reflex_at, q)
            j = max(reflex_at, q)
            if i == j:
                continue
            s, k = _score(
                nfix, P, poly, n, i, j, hv, quad, strategy, reflex_angle, scratch, relaxed
            )
            if s < np.inf:
                sc[c] = s
                ci[c] = i
                cj[c] = j
                ck[c] = k
                c += 1
    else:
        for u in range(m):
            for w in range(u + 1, m):
                i = pos[u]
                j = pos[w]
                s, k = _score(nfix, P, poly, n, i, j, hv, quad, strategy, 0.0, scratch, relaxed)
                if s < np.inf:
                    sc[c] = s
                    ci[c] = i
                    cj[c] = j
                    ck[c] = k
                    c += 1
    order = np.argsort(sc[:c], kind="mergesort")
    for r in order:
        if _valid(P, poly, n, ci[r], cj[r]):
            return ci[r], cj[r], ck[r]
    return -1, -1, 0


@njit(cache=True)
def _centre_pattern(nfix, P, c, poly, n):
    """Put the vertex average at P[c]; the rotation r (0 or 1) whose n/2 quads
    (c, poly[r + 2q], poly[r + 2q + 1], poly[r + 2q + 2]) are all strictly convex, or -1."""
    x = 0.0
    y = 0.0
    for q in range(n):
        x += P[poly[q], 0]
        y += P[poly[q], 1]
    P[c, 0] = x / n
    P[c, 1] = y / n
    for r in range(2):
        good = True
        for q in range(n // 2):
            a = poly[(r + 2 * q) % n]
            b = poly[(r + 2 * q + 1) % n]
            d = poly[(r + 2 * q + 2) % n]
            if not _convex4(P, c, a, b, d, nfix):
                good = False
                break
        if good:
            return r
    return -1


@njit(cache=True)
def _sep_point(P, a, b, q, k, ha, hb, out):
    """Point q of k pieces on segment ab, at equal steps of the integral of 1/h
    for h linear from ha to hb, written to P[out]."""
    f = q / k
    if abs(hb - ha) > 1e-9 * ha:
        f = (math.exp(f * math.log(hb / ha)) - 1.0) * ha / (hb - ha)
    P[out, 0] = P[a, 0] + f * (P[b, 0] - P[a, 0])
    P[out, 1] = P[a, 1] + f * (P[b, 1] - P[a, 1])


@njit(cache=True)
def _closable6(nfix, P, h, scratch):
    """Whether the hexagon h (6,) has a convex quad pattern: a diagonal into two
    strictly convex quads, or the centre pattern (the centre at P[scratch])."""
    for q in range(3):
        if _convex4(P, h[q], h[q + 1], h[q + 2], h[q + 3], nfix) and _convex4(
            P, h[q + 3], h[(q + 4) % 6], h[(q + 5) % 6], h[q], nfix
        ):
            return True
    return _centre_pattern(nfix, P, scratch, h, len(h)) >= 0


@njit(cache=True)
def _closable(nfix, P, h, scratch):
    """Whether the polygon h of 4, 6 or 8 vertices has a convex quad pattern
    (8: a valid diagonal leaving a convex quad and a closable hexagon, or the
    centre pattern)."""
    m = len(h)
    if m == 4:
        return _convex4(P, h[0], h[1], h[2], h[3], nfix)
    if m == 6:
        return _closable6(nfix, P, h, scratch)
    if m != 8:
        return False
    six = np.empty(6, np.int64)
    for q in range(8):
        if not _convex4(P, h[q], h[(q + 1) % 8], h[(q + 2) % 8], h[(q + 3) % 8], nfix):
            continue
        for t in range(6):
            six[t] = h[(q + 3 + t) % 8]
        if _closable6(nfix, P, six, scratch) and _valid(P, h, m, q, (q + 3) % 8):
            return True
    return _centre_pattern(nfix, P, scratch, h, m) >= 0


@njit(cache=True)
def recurse(
    nfix, P, npts, buf, st_start, st_len, st_depth, nst, H, grid, quad, strategy, cells, stats,
    stuck,
):  # fmt: skip
    """Split the polygons on the stack until only triangles (or convex quads) are left.

    ``P`` (cap, 2) holds ``npts`` points; new separator points are appended.
    ``buf`` holds the polygons, ``st_*`` the stack (``nst`` entries).
    ``cells`` (cap, 4) receives the cells (triangles use 3 columns).
    ``stats`` (int64): [0] cells, [1] points, [2] max depth, [3..6] separators
    by pieces 1, 2-3, 4-7, 8+, [7] quads met as leaves, [8] triangles met,
    [9] full enumerations needed, [10], [11] start and length
    in ``buf`` of the polygon that is stuck, [12] centre patterns used,
    [13] the length of ``stuck`` used.

    A polygon without a valid split is written to ``stuck`` (its length,
    then its vertices) and the others go on; when ``stuck`` has no room
    for it (a zero-length ``stuck``: never), the call returns STUCK.

    Returns OK, FULL or STUCK.
    """
    ncell = 0
    while nst > 0:
        nst -= 1
        s0 = st_start[nst]
        n = st_len[nst]
        depth = st_depth[nst]
        if depth > stats[2]:
            stats[2] = depth
        poly = buf[s0 : s0 + n].copy()
        leaf = (n == 3 and not quad) or (
            n == 4 and quad and _convex4(P, poly[0], poly[1], poly[2], poly[3], nfix)
        )
        if leaf:
            if ncell >= len(cells):
                return FULL
            for t in range(n):
                cells[ncell, t] = poly[t]
            ncell += 1
            stats[0] = ncell
            if quad:
                stats[7] += 1
            else:
                stats[8] += 1
            continue
        # the sampled candidates first, then (above 2 * _SAMPLE vertices) the same with
        # separators closer to an edge, then all pairs: along a finely sampled arc every
        # separator is that close, and all pairs of a polygon of m vertices are m**2
        # scores at each of its splits; ``full`` and ``relaxed`` are runtime bools (literal
        # ones would compile _best_split once per combination)
        for attempt in range(3):
            if attempt == 1 and n <= 2 * _SAMPLE:
                continue  # the sampled positions are all of them
            full = attempt == 2
            relaxed = attempt >= 1
            if full:
                stats[9] += 1
            i, j, k = _best_split(nfix, P, poly, n, H, grid, quad, strategy, full, relaxed, npts)
            if i >= 0:
                break
        if i < 0 and quad and n <= _CENTRE_MAX:
            # the centre pattern: n/2 quads around the vertex average
            if ncell + n // 2 > len(cells) or npts >= len(P):
                return FULL
            r = _centre_pattern(nfix, P, npts, poly, n)
            if r >= 0:
                for q in range(n // 2):
                    cells[ncell, 0] = npts
                    for t in range(3):
                        cells[ncell, t + 1] = poly[(r + 2 * q + t) % n]
                    ncell += 1
                npts += 1
                stats[0] = ncell
                stats[12] += 1
                continue
        if i < 0:
            stats[10] = s0
            stats[11] = n
            w = stats[13]
            if w + n + 1 > len(stuck):
                return STUCK
            stuck[w] = n
            for t in range(n):
                stuck[w + 1 + t] = poly[t]
            stats[13] = w + n + 1
            continue
        if npts + k - 1 > len(P) or s0 + n + 2 * k + 2 > len(buf) or nst + 2 > len(st_start):
            return FULL
        a = poly[i]
        b = poly[j]
        # separator points by the sizes at its ends (equal steps of the integral of 1/h)
        ha = size_at(H, grid, P[a, 0], P[a, 1])
        hb = size_at(H, grid, P[b, 0], P[b, 1])
        first = npts
        for q in range(1, k):
            _sep_point(P, a, b, q, k, ha, hb, npts)
            npts += 1
        if k == 1:
            stats[3] += 1
        elif k < 4:
            stats[4] += 1
        elif k < 8:
            stats[5] += 1
        else:
            stats[6] += 1
        # part 1: poly[i..j], then the separator points from b back to a
        w = s0
        for q in range(i, j + 1):
            buf[w] = poly[q]
            w += 1
        for q in range(k - 1, 0, -1):
            buf[w] = first + q - 1
            w += 1
        n1 = w - s0
        # part 2: poly[j..n-1], poly[0..i], then the separator points from a to b
        for q in range(j, n):
            buf[w] = poly[q]
            w += 1
        for q in range(0, i + 1):
            buf[w] = poly[q]
            w += 1
        for q in range(1, k):
            buf[w] = first + q - 1
            w += 1
        n2 = w - s0 - n1
        # the larger part deeper in the stack: the stack stays shallow
        if n1 >= n2:
            st_start[nst] = s0
            st_len[nst] = n1
            st_depth[nst] = depth + 1
            st_start[nst + 1] = s0 + n1
            st_len[nst + 1] = n2
            st_depth[nst + 1] = depth + 1
        else:
            # move part 2 first
            tmp = buf[s0 : s0 + n1].copy()
            for q in range(n2):
                buf[s0 + q] = buf[s0 + n1 + q]
            for q in range(n1):
                buf[s0 + n2 + q] = tmp[q]
            st_start[nst] = s0
            st_len[nst] = n2
            st_depth[nst] = depth + 1
            st_start[nst + 1] = s0 + n2
            st_len[nst + 1] = n1
            st_depth[nst + 1] = depth + 1
        nst += 2
    stats[1] = npts
    stats[0] = ncell
    return OK


@njit(cache=True)
def bridge_candidates_valid(P, a_ids, b_ids, prev_a, next_a, prev_b, next_b, ea, eb):
    """Index of the first valid bridge (a_ids[r], b_ids[r]) in order, or -1.

    The bridge must leave each end inside that vertex's interior angle and
    touch no edge (ea, eb) that does not end at one of its ends.
    """
    m = len(ea)
    for r in range(len(a_ids)):
        a = a_ids[r]
        b = b_ids[r]
        if not in_wedge(P, prev_a[r], a, next_a[r], b):
            continue
        if not in_wedge(P, prev_b[r], b, next_b[r], a):
            continue
        if crosses_any(P, a, b, ea, eb, m):
            continue
        return r
    return -1


@njit(cache=True)
def strictly_convex_rows(P, quads):
    """(m,) bool: each quad strictly convex."""
    out = np.ones(len(quads), np.bool_)
    for r in range(len(quads)):
        for c in range(4):
            if orient(P, quads[r, c], quads[r, (c + 1) % 4], quads[r, (c + 2) % 4]) <= 0:
                out[r] = False
                break
    return out
