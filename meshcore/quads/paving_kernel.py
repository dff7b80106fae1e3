"""Compiled checks of the paving rows (§8.5.1): exact front-front intersection tests.

Every sign is :func:`~meshcore.geometry.predicates.orient2d_scalar` (through
:func:`meshcore.partition.kernel.touch` and
:func:`meshcore.partition.kernel.orient`). The fixed-radius neighbour pairs
the checks start from (:func:`near_pairs`) come from a uniform grid of
cells at least ``r`` wide, built on each call (a row's fronts change every
call, so a tree would be rebuilt anyway).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from meshcore.partition.kernel import orient, strictly_convex_rows, touch
from meshcore.partition.smoothing import quad_q

__all__ = [
    "cycles",
    "fresh_edges_touch",
    "fresh_touch_quads",
    "front_near",
    "near_pairs",
    "pairs_touch",
    "quads_too_close",
    "points_in_quads",
    "strictly_convex_rows",
]


@njit(cache=True)
def pairs_touch(P, ea, eb, pairs):
    """(k,) bool: whether the pair (s, t) of segments shares a point other than a
    shared endpoint (or lies on one line overlapping). Segment s is (ea[s], eb[s])."""
    out = np.zeros(len(pairs), np.bool_)
    for r in range(len(pairs)):
        s = pairs[r, 0]
        t = pairs[r, 1]
        a = ea[s]
        b = eb[s]
        c = ea[t]
        d = eb[t]
        if a == c or a == d or b == c or b == d:
            # adjacent segments: they may only meet at the shared end
            if (a == c and b == d) or (a == d and b == c):
                out[r] = True
                continue
            if a == c:
                o, p, q = a, b, d
            elif a == d:
                o, p, q = a, b, c
            elif b == c:
                o, p, q = b, a, d
            else:
                o, p, q = b, a, c
            if orient(P, o, p, q) == 0:
                # collinear: overlapping when both leave o on the same side
                dx1 = P[p, 0] - P[o, 0]
                dy1 = P[p, 1] - P[o, 1]
                dx2 = P[q, 0] - P[o, 0]
                dy2 = P[q, 1] - P[o, 1]
                if dx1 * dx2 + dy1 * dy2 > 0:
                    out[r] = True
            continue
        if touch(P, a, b, c, d):
            out[r] = True
    return out


@njit(cache=True)
def points_in_quads(P, quads, pts, cand):
    """(k,) bool: whether point pts[cand[r, 1]] lies in the closed quad
    quads[cand[r, 0]] without being one of its corners (the quads are convex)."""
    out = np.zeros(len(cand), np.bool_)
    for r in range(len(cand)):
        q = cand[r, 0]
        p = pts[cand[r, 1]]
        corner = False
        for c in range(4):
            if quads[q, c] == p:
                corner = True
        if corner:
            continue
        inside = True
        for c in range(4):
            if orient(P, quads[q, c], quads[q, (c + 1) % 4], p) < 0:
                inside = False
                break
        out[r] = inside
    return out


@njit(cache=True)
def near_pairs(A, B, r):
    """Every pair (i, j) with ``|A[i] - B[j]| <= r``: (i, j, distance) arrays.

    The same pairs as ``cKDTree(A).sparse_distance_matrix(cKDTree(B), r)``;
    B is binned (a counting sort) in a grid of cells at least r wide (and at
    most about 4 len(B) cells), each point of A scans its 3 x 3 block of
    cells, once to count the pairs and once to fill them.
    """
    if len(A) == 0 or len(B) == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    lo_x = B[:, 0].min()
    lo_y = B[:, 1].min()
    wx = B[:, 0].max() - lo_x
    wy = B[:, 1].max() - lo_y
    cell = max(r, np.sqrt(wx * wy / (4.0 * len(B))), max(wx, wy) / (4.0 * len(B)), 1e-300)
    nx = int(wx / cell) + 1
    ny = int(wy / cell) + 1
    key = np.empty(len(B), np.int64)
    start = np.zeros(nx * ny + 1, np.int64)
    for j in range(len(B)):
        gx = min(int((B[j, 0] - lo_x) / cell), nx - 1)
        gy = min(int((B[j, 1] - lo_y) / cell), ny - 1)
        key[j] = gx * ny + gy
        start[key[j] + 1] += 1
    for g in range(nx * ny):
        start[g + 1] += start[g]
    order = np.empty(len(B), np.int64)
    fill = start[:-1].copy()
    for j in range(len(B)):
        order[fill[key[j]]] = j
        fill[key[j]] += 1
    r2 = r * r
    out_i = np.zeros(0, np.int64)
    out_j = np.zeros(0, np.int64)
    out_d = np.zeros(0)
    for fill_in in range(2):
        k = 0
        for i in range(len(A)):
            cx = int(np.floor((A[i, 0] - lo_x) / cell))
            cy = int(np.floor((A[i, 1] - lo_y) / cell))
            for gx in range(max(cx - 1, 0), min(cx + 2, nx)):
                for gy in range(max(cy - 1, 0), min(cy + 2, ny)):
                    g = gx * ny + gy
                    for s in range(start[g], start[g + 1]):
                        j = order[s]
                        dx = A[i, 0] - B[j, 0]
                        dy = A[i, 1] - B[j, 1]
                        d2 = dx * dx + dy * dy
                        if d2 <= r2:
                            if fill_in:
                                out_i[k] = i
                                out_j[k] = j
                                out_d[k] = np.sqrt(d2)
                            k += 1
        if fill_in == 0:
            if k == 0:
                break
            out_i = np.empty(k, np.int64)
            out_j = np.empty(k, np.int64)
            out_d = np.empty(k)
    return out_i, out_j, out_d


@njit(cache=True)
def convex_and_good(P, quads, q_min):
    """(m,) bool: each quad strictly convex (exact) and of quality (8.4) at least q_min.

    One compiled call for the strips' quad-by-quad growth (numpy's quality
    report per quad cost more than the strip itself).
    """
    out = strictly_convex_rows(P, quads)
    for r in range(len(quads)):
        if out[r] and quad_q(P, quads, r) < q_min:
            out[r] = False
    return out


@njit(cache=True)
def front_near(P, fa, fb, lo, hi):
    """(k,) bool: whether each front edge's (fa[k], fb[k]) bounding box meets the box
    ``[lo, hi]`` (closed): every edge that can touch a segment inside that box."""
    near = np.zeros(len(fa), np.bool_)
    for k in range(len(fa)):
        ax = P[fa[k], 0]
        ay = P[fa[k], 1]
        bx = P[fb[k], 0]
        by = P[fb[k], 1]
        near[k] = (
            min(ax, bx) <= hi[0]
            and min(ay, by) <= hi[1]
            and max(ax, bx) >= lo[0]
            and max(ay, by) >= lo[1]
        )
    return near


@njit(cache=True)
def fresh_edges_touch(P, seg_a, seg_b, n_new):
    """(n_new,) bool: whether each of the first ``n_new`` segments (seg_a[s], seg_b[s])
    touches another of the segments (:func:`pairs_touch`).

    Segments that share a point have midpoints at most half the sum of their lengths
    apart: only such pairs (with a margin far above rounding) are tested exactly.
    """
    n = len(seg_a)
    mid = np.empty((n, 2))
    half = np.empty(n)
    longest = 0.0
    for s in range(n):
        mid[s, 0] = (P[seg_a[s], 0] + P[seg_b[s], 0]) / 2
        mid[s, 1] = (P[seg_a[s], 1] + P[seg_b[s], 1]) / 2
        half[s] = math.hypot(P[seg_b[s], 0] - P[seg_a[s], 0], P[seg_b[s], 1] - P[seg_a[s], 1]) / 2
        longest = max(longest, 2 * half[s])
    slack = 1e-9 * longest
    pi, pj, d = near_pairs(mid[:n_new].copy(), mid, 1.0001 * longest + slack)
    keep = (pi != pj) & (d <= 1.0001 * (half[pi] + half[pj]) + slack)
    pairs = np.empty((keep.sum(), 2), np.int64)
    pairs[:, 0] = pi[keep]
    pairs[:, 1] = pj[keep]
    hit = pairs_touch(P, seg_a, seg_b, pairs)
    bad = np.zeros(n_new, np.bool_)
    for k in range(len(pairs)):
        if hit[k]:
            bad[pairs[k, 0]] = True
            if pairs[k, 1] < n_new:
                bad[pairs[k, 1]] = True
    return bad


@njit(cache=True)
def quads_too_close(P, quads, new_nodes, nodes, hx, other, gap, clearance):
    """(m,) bool: the quads with a new node x too close to a node y of ``nodes``.

    Too close: ``|x - y| < lim * hx`` (``hx`` the size at x), ``lim`` being
    ``clearance`` when y is not on another front (``other[y]`` false) or x is a
    corner of a quad that has a node on one (a merge), ``gap`` otherwise; y may
    be x or a corner of a quad of x (the quads of x found by a binary search in the
    corners sorted by node: linear in the row, not in the row times the close pairs).
    """
    m = len(quads)
    joined = np.zeros(len(P), np.bool_)
    for q in range(m):
        if other[quads[q, 0]] or other[quads[q, 1]] or other[quads[q, 2]] or other[quads[q, 3]]:
            for c in range(4):
                joined[quads[q, c]] = True
    i, t, dist = near_pairs(P[new_nodes], P[nodes], max(gap, clearance) * hx.max())
    # the quads' corners sorted by node: a node's quads are a run of ``by_node``
    corner = quads.ravel()
    by_node = np.argsort(corner, kind="mergesort")
    sorted_corner = corner[by_node]
    bad = np.zeros(len(P), np.bool_)
    for k in range(len(i)):
        x = new_nodes[i[k]]
        y = nodes[t[k]]
        lim = clearance if joined[x] or not other[y] else gap
        if not (dist[k] < lim * hx[i[k]]) or x == y:
            continue
        mine = False
        lo = np.searchsorted(sorted_corner, x, side="left")
        hi = np.searchsorted(sorted_corner, x, side="right")
        for r in range(lo, hi):
            q = by_node[r] // 4
            for c in range(4):
                mine = mine or quads[q, c] == y
        if not mine:
            bad[x] = True
    out = np.zeros(m, np.bool_)
    for q in range(m):
        for c in range(4):
            if bad[quads[q, c]]:
                out[q] = True
    return out


@njit(cache=True)
def cycles(succ):
    """``(order, cuts)``: the cycles of the permutation ``succ`` (i -> succ[i]), each
    from its largest index along succ, the cycles by their largest index descending;
    ``np.split(order, cuts)`` lists them."""
    k = len(succ)
    order = np.empty(k, np.int64)
    cuts = np.empty(k, np.int64)
    seen = np.zeros(k, np.bool_)
    n = 0
    c = 0
    for i in range(k - 1, -1, -1):  # i unseen: the largest index of its cycle
        if seen[i]:
            continue
        cuts[c] = n
        c += 1
        j = i
        while not seen[j]:
            seen[j] = True
            order[n] = j
            n += 1
            j = succ[j]
    return order, cuts[1:c].copy()


@njit(cache=True)
def fresh_touch_quads(P, quads, fa, fb):
    """(m,) bool: the quads with an edge that is not a front edge (fa[k], fb[k]) and
    touches a front edge or another such edge (:func:`fresh_edges_touch`, each
    edge once)."""
    m = len(quads)
    n = len(P)
    front = np.empty(len(fa), np.int64)
    for k in range(len(fa)):
        front[k] = min(fa[k], fb[k]) * n + max(fa[k], fb[k])
    front.sort()
    seg = np.full(4 * m, -1, np.int64)  # each quad edge's fresh segment, -1 on a front edge
    edge = np.empty(4 * m, np.int64)  # the quad edges not on a front, and their keys
    keys = np.empty(4 * m, np.int64)
    k = 0
    for e in range(4 * m):
        a = quads[e // 4, e % 4]
        b = quads[e // 4, (e % 4 + 1) % 4]
        key = min(a, b) * n + max(a, b)
        at = np.searchsorted(front, key)
        if at < len(front) and front[at] == key:
            continue
        edge[k] = e
        keys[k] = key
        k += 1
    seg_a = np.empty(k + len(fa), np.int64)
    seg_b = np.empty(k + len(fa), np.int64)
    n_new = 0
    order = np.argsort(keys[:k], kind="mergesort")  # stable: each key's first edge first
    for i in range(k):
        e = edge[order[i]]
        if i == 0 or keys[order[i]] != keys[order[i - 1]]:
            seg_a[n_new] = quads[e // 4, e % 4]
            seg_b[n_new] = quads[e // 4, (e % 4 + 1) % 4]
            n_new += 1
        seg[e] = n_new - 1
    seg_a[n_new : n_new + len(fa)] = fa
    seg_b[n_new : n_new + len(fa)] = fb
    bad = fresh_edges_touch(P, seg_a[: n_new + len(fa)], seg_b[: n_new + len(fa)], n_new)
    out = np.zeros(m, np.bool_)
    for e in range(4 * m):
        if seg[e] >= 0 and bad[seg[e]]:
            out[e // 4] = True
    return out
