"""Compiled sub-topology loop of the optimization-based method in the plane (§8.3.2).

The state is a mesh topology (Definition 8.1) of triangles: ``T`` rows with
an ``alive`` flag, a free list of dead rows, and per vertex a doubly linked
list of its corners (slot ``3 t + j`` is corner ``j`` of triangle ``t``), so
that the ball of a vertex is a walk and replacing a sub-topology costs its
size. The loop over vertices, edges or inverted triangles is inherently
sequential (each replacement changes the next ball), so it is one numba
function per pass (``cache=True``); Python runs the passes.

A pass visits sub-topologies 𝒮 of one kind:

* ``BALL``: the ball ℬ_P of every vertex marked dirty;
* ``PAIR``: the two triangles sharing an edge, for every edge of a triangle
  with a dirty vertex (the text's "pairs of adjacent triangles");
* ``UNION``: the union of the balls of the two ends of each edge of an
  inverted or flat triangle, then of its three vertices, then of every
  vertex of those, then sets of 6, 12 and 24 triangles grown across
  edges from it (the text's "larger connected sets"), up to ``KMAX``
  triangles.

For each 𝒮 the boundary δ𝒮 must be one simple cycle (else 𝒮 is skipped).
The candidates are Op(Q, δ𝒮) for every Q of the cycle (a fan; it removes the
vertices interior to 𝒮, so it is a candidate only where they may be removed
or there are none) and, for the ball of a free interior vertex P, Op(G, δℬ_P)
with G the centroid of the cycle's vertices, which moves P to G, and, when
that leaves an element non-positive, G' the centroid of the kernel of δℬ_P
(the region from which the whole cycle is seen: the positions minimizing
Sur(Op(G, δℬ_P)), a choice the text leaves open by allowing any G). A fan is
refused when one of its new edges already joins two vertices outside 𝒮: that
is the validity condition (𝒯 − 𝒮) ∩ Op(Q, δ𝒮) = δ𝒮 of §8.3.3 (Figure 8.9),
which keeps every edge in at most two triangles.

Criteria (8.1)-(8.2): a candidate is *positive* when every new triangle has
orient2d > 0 (exact); a positive configuration has the least Sur possible
(the signed area of δ𝒮), so two positive configurations tie on Sur exactly
and the quality decides; otherwise the smaller float Sur wins, ties (within
``sur_tie`` relative) going to the better worst quality. The best candidate
replaces 𝒮 only when it beats the current configuration by the same rule,
with a quality gain of at least ``quality_gain``: Sur never increases and the
least quality of a positive region never decreases.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from meshcore.geometry.predicates import WORK_SIZE, orient2d_filtered, orient2d_scalar
from meshcore.mesh.tetstore import N_PTS, N_ROWS, STAMP, link_row, remove_cell, room, take_row

BALL, PAIR, UNION = 0, 1, 2
#: Largest sub-topology considered (triangles); larger balls are skipped.
KMAX = 96
#: Sizes of the edge-adjacent sets grown around a non-positive triangle (UNION).
GROW = (6, 12, 24)
#: ``counters`` entries: accepted replacements by operator.
C_FAN, C_MOVE, C_KERNEL, C_FLIP, C_UNION, C_REMOVED = range(6)

_SQ3x4 = 4.0 * math.sqrt(3.0)


@njit(cache=True, inline="always")
def _quality(ax, ay, bx, by, cx, cy, measure):
    """Quality from the unsigned area (§8.3.1): shape 4√3|A|/Σl², or radius ratio 2r/R."""
    area = 0.5 * abs((bx - ax) * (cy - ay) - (by - ay) * (cx - ax))
    l0 = (bx - cx) ** 2 + (by - cy) ** 2
    l1 = (cx - ax) ** 2 + (cy - ay) ** 2
    l2 = (ax - bx) ** 2 + (ay - by) ** 2
    if measure == 0:
        s = l0 + l1 + l2
        return _SQ3x4 * area / s if s > 0.0 else 0.0
    a, b, c = math.sqrt(l0), math.sqrt(l1), math.sqrt(l2)
    den = 0.5 * (a + b + c) * a * b * c
    return 8.0 * area * area / den if den > 0.0 else 0.0


@njit(cache=True, inline="always")
def _better(pa, sa, qa, pb, sb, qb, tie, gain):
    """Configuration a beats b by (8.1) then (8.2): positive first, then Sur, then quality."""
    if pa != pb:
        return pa
    if not pa:
        if sa < sb - tie:
            return True
        if sa > sb + tie:
            return False
    return qa > qb + gain


@njit(cache=True)
def _add(T, alive, head, nxt, prv, freeT, cnt, a, b, c):
    t = take_row(alive, freeT, cnt)
    T[t, 0] = a
    T[t, 1] = b
    T[t, 2] = c
    link_row(T, head, nxt, prv, t)
    return t


@njit(cache=True)
def _ball(head, nxt, v, st, tmark, stamp, k):
    """Append the triangles of v's ball not yet in st[:k]; -1 past KMAX."""
    s = head[v]
    while s >= 0:
        t = s // 3
        if tmark[t] != stamp:
            if k >= KMAX:
                return -1
            tmark[t] = stamp
            st[k] = t
            k += 1
        s = nxt[s]
    return k


@njit(cache=True)
def _cycle(T, st, k, cyc, ea, eb):
    """The boundary of st[:k] as one simple cycle in cyc; its length, or -1."""
    ne = 0
    for i in range(k):
        t = st[i]
        for j in range(3):
            ea[ne] = T[t, j]
            eb[ne] = T[t, (j + 1) % 3]
            ne += 1
    nb = 0  # boundary edges go to ea[ne:], eb[ne:]
    for e in range(ne):
        a, b = ea[e], eb[e]
        inner = False
        for f in range(ne):
            if ea[f] == b and eb[f] == a:
                inner = True
                break
        if not inner:
            ea[ne + nb] = a
            eb[ne + nb] = b
            nb += 1
    if nb < 3:
        return -1
    first = ea[ne]
    cur = first
    for i in range(nb):
        cyc[i] = cur
        nxt_v = -1
        for e in range(ne, ne + nb):
            if ea[e] == cur:
                if nxt_v >= 0:
                    return -1
                nxt_v = eb[e]
        if nxt_v < 0:
            return -1
        cur = nxt_v
        if cur == first and i < nb - 1:
            return -1
    if cur != first:
        return -1
    return nb


@njit(cache=True)
def _evaluate_current(P, T, st, k, measure):
    pos = True
    sur = 0.0
    q = 2.0
    for i in range(k):
        a, b, c = T[st[i], 0], T[st[i], 1], T[st[i], 2]
        ax, ay, bx, by, cx, cy = P[a, 0], P[a, 1], P[b, 0], P[b, 1], P[c, 0], P[c, 1]
        if orient2d_scalar(ax, ay, bx, by, cx, cy) <= 0:
            pos = False
        sur += 0.5 * abs((bx - ax) * (cy - ay) - (by - ay) * (cx - ax))
        q = min(q, _quality(ax, ay, bx, by, cx, cy, measure))
    return pos, sur, q


@njit(cache=True)
def _evaluate_apex(P, cyc, L, skip, gx, gy, measure):
    """Triangles (c_j, c_j+1, apex) for j not in {skip - 1, skip} (skip < 0: all)."""
    pos = True
    sur = 0.0
    q = 2.0
    for j in range(L):
        if skip >= 0 and (j == skip or (j + 1) % L == skip):
            continue
        a, b = cyc[j], cyc[(j + 1) % L]
        ax, ay, bx, by = P[a, 0], P[a, 1], P[b, 0], P[b, 1]
        if orient2d_scalar(ax, ay, bx, by, gx, gy) <= 0:
            pos = False
        sur += 0.5 * abs((bx - ax) * (gy - ay) - (by - ay) * (gx - ax))
        q = min(q, _quality(ax, ay, bx, by, gx, gy, measure))
    return pos, sur, q


@njit(cache=True)
def _fan_allowed(T, head, nxt, cyc, L, i, tmark, stamp, vmark, vpos):
    """Validity condition of §8.3.3 for Op(c_i, δ𝒮): no new edge exists outside 𝒮."""
    q = cyc[i]
    for j in range(L):
        vmark[cyc[j]] = stamp
        vpos[cyc[j]] = j
    s = head[q]
    while s >= 0:
        t = s // 3
        if tmark[t] != stamp:
            for jj in range(3):
                w = T[t, jj]
                if w != q and vmark[w] == stamp:
                    d = (vpos[w] - i) % L
                    if d != 1 and d != L - 1:
                        return False
        s = nxt[s]
    return True


@njit(cache=True)
def _kernel_centroid(P, cyc, L, px, py, qx, qy):
    """Centroid of the kernel of the cycle (float clipping of its bounding box), or NaN."""
    x0, y0, x1, y1 = np.inf, np.inf, -np.inf, -np.inf
    for j in range(L):
        x0 = min(x0, P[cyc[j], 0])
        y0 = min(y0, P[cyc[j], 1])
        x1 = max(x1, P[cyc[j], 0])
        y1 = max(y1, P[cyc[j], 1])
    px[0], py[0], px[1], py[1] = x0, y0, x1, y0
    px[2], py[2], px[3], py[3] = x1, y1, x0, y1
    m = 4
    for j in range(L):
        a, b = cyc[j], cyc[(j + 1) % L]
        ax, ay = P[a, 0], P[a, 1]
        dx, dy = P[b, 0] - ax, P[b, 1] - ay
        r = 0
        for i in range(m):
            ux, uy = px[i], py[i]
            vx, vy = px[(i + 1) % m], py[(i + 1) % m]
            su = dx * (uy - ay) - dy * (ux - ax)
            sv = dx * (vy - ay) - dy * (vx - ax)
            if su >= 0.0:
                qx[r] = ux
                qy[r] = uy
                r += 1
            if (su >= 0.0) != (sv >= 0.0):
                f = su / (su - sv)
                qx[r] = ux + f * (vx - ux)
                qy[r] = uy + f * (vy - uy)
                r += 1
        m = r
        if m < 3:
            return np.nan, np.nan
        for i in range(m):
            px[i] = qx[i]
            py[i] = qy[i]
    area = 0.0
    cx = 0.0
    cy = 0.0
    for i in range(m):
        ux, uy = px[i], py[i]
        vx, vy = px[(i + 1) % m], py[(i + 1) % m]
        w = ux * vy - vx * uy
        area += w
        cx += (ux + vx) * w
        cy += (uy + vy) * w
    if not area > 0.0:
        return np.nan, np.nan
    return cx / (3.0 * area), cy / (3.0 * area)


@njit(cache=True)
def _try(
    P,
    T,
    alive,
    head,
    nxt,
    prv,
    freeT,
    cnt,
    fixed,
    dirty,
    st,
    k,
    center,
    allow_remove,
    measure,
    tie_rel,
    gain,
    cyc,
    ea,
    eb,
    tmark,
    vmark,
    vpos,
    px,
    py,
    qx,
    qy,
    counters,
    kind,
):
    """Replace the sub-topology st[:k] by its best candidate; 1 if replaced, 2 if out of rows."""
    stamp = cnt[STAMP]
    L = _cycle(T, st, k, cyc, ea, eb)
    if L < 3:
        return 0
    # vertices interior to 𝒮: in st but not on the cycle (marked -stamp, apart
    # from the +stamp marks of _fan_allowed)
    for j in range(L):
        vmark[cyc[j]] = -stamp
    n_inner = 0
    inner_free = True
    center_inner = False
    for i in range(k):
        for jj in range(3):
            w = T[st[i], jj]
            if vmark[w] != -stamp:
                vmark[w] = -stamp
                n_inner += 1
                center_inner = center_inner or w == center
                if fixed[w]:
                    inner_free = False
    cur_p, cur_s, cur_q = _evaluate_current(P, T, st, k, measure)
    tie = tie_rel * cur_s
    best_p, best_s, best_q = cur_p, cur_s, cur_q
    best = -3  # -3: keep, -2: move to G, -1: move to kernel centroid, i >= 0: fan from cyc[i]
    gx, gy, hx, hy = 0.0, 0.0, np.nan, np.nan
    if center_inner and n_inner == 1 and not fixed[center]:
        for j in range(L):
            gx += P[cyc[j], 0]
            gy += P[cyc[j], 1]
        gx /= L
        gy /= L
        p, s, q = _evaluate_apex(P, cyc, L, np.int64(-1), gx, gy, measure)
        if _better(p, s, q, best_p, best_s, best_q, tie, gain):
            best_p, best_s, best_q, best = p, s, q, -2
        if not p:
            hx, hy = _kernel_centroid(P, cyc, L, px, py, qx, qy)
            if hx == hx:
                p, s, q = _evaluate_apex(P, cyc, L, np.int64(-1), hx, hy, measure)
                if _better(p, s, q, best_p, best_s, best_q, tie, gain):
                    best_p, best_s, best_q, best = p, s, q, -1
    removes = n_inner > 0
    # a fan removing free vertices only where the ball is not positive and no move helps
    if not removes or (allow_remove and inner_free and not cur_p and best == -3):
        for i in range(L):
            q_ = cyc[i]
            p, s, q = _evaluate_apex(P, cyc, L, i, P[q_, 0], P[q_, 1], measure)
            if _better(p, s, q, best_p, best_s, best_q, tie, gain):
                if _fan_allowed(T, head, nxt, cyc, L, i, tmark, stamp, vmark, vpos):
                    best_p, best_s, best_q, best = p, s, q, i
    if best == -3:
        return 0
    if best == -2 or best == -1:
        P[center, 0] = gx if best == -2 else hx
        P[center, 1] = gy if best == -2 else hy
        counters[C_MOVE if best == -2 else C_KERNEL] += 1
    else:
        if not room(T, cnt, L - 2 + k):
            return 2
        for i in range(k):
            remove_cell(T, alive, head, nxt, prv, freeT, cnt, st[i])
        q_ = cyc[best]
        for j in range(L):
            if j == best or (j + 1) % L == best:
                continue
            _add(T, alive, head, nxt, prv, freeT, cnt, cyc[j], cyc[(j + 1) % L], q_)
        counters[C_REMOVED] += n_inner
        if kind == BALL:
            counters[C_FAN] += 1
        elif kind == PAIR:
            counters[C_FLIP] += 1
        else:
            counters[C_UNION] += 1
    for j in range(L):
        dirty[cyc[j]] = 1
    if center >= 0:
        dirty[center] = 1
    return 1


@njit(cache=True)
def _grow(T, head, nxt, t, st, tmark, stamp, size):
    """Up to ``size`` triangles reached from t across edges, breadth first, in st."""
    st[0] = t
    tmark[t] = stamp
    k = 1
    i = 0
    while i < k and k < size:
        u = st[i]
        for j in range(3):
            w = _neighbour(T, head, nxt, T[u, j], T[u, (j + 1) % 3])
            if w >= 0 and tmark[w] != stamp and k < size:
                tmark[w] = stamp
                st[k] = w
                k += 1
        i += 1
    return k


@njit(cache=True)
def _neighbour(T, head, nxt, a, b):
    """The triangle holding the oriented edge b -> a, or -1."""
    s = head[b]
    while s >= 0:
        t = s // 3
        j = s % 3
        if T[t, (j + 1) % 3] == a:
            return t
        s = nxt[s]
    return -1


@njit(cache=True)
def sweep(
    P,
    T,
    alive,
    head,
    nxt,
    prv,
    freeT,
    cnt,
    fixed,
    todo,
    dirty,
    kind,
    allow_remove,
    measure,
    tie_rel,
    gain,
    counters,
):
    """One pass over sub-topologies of ``kind``; returns (replacements, status).

    ``todo`` marks the vertices whose balls (BALL), or the triangles touching
    them (PAIR), are visited; UNION visits the non-positive triangles.
    ``dirty`` receives the vertices of every replaced sub-topology. Status 0:
    done; 2: out of triangle rows (the caller grows the arrays and repeats).
    """
    n = cnt[N_PTS]
    mcap = T.shape[0]
    st = np.empty(3 * KMAX, np.int64)
    cyc = np.empty(3 * KMAX + 3, np.int64)
    ea = np.empty(9 * KMAX, np.int64)
    eb = np.empty(9 * KMAX, np.int64)
    px = np.empty(3 * KMAX + 8)
    py = np.empty(3 * KMAX + 8)
    qx = np.empty(3 * KMAX + 8)
    qy = np.empty(3 * KMAX + 8)
    tmark = np.zeros(mcap, np.int64)
    vmark = np.zeros(P.shape[0], np.int64)
    vpos = np.zeros(P.shape[0], np.int64)
    changed = 0
    if kind == BALL:
        for v in range(n):
            if not todo[v] or head[v] < 0:
                continue
            todo[v] = 0
            cnt[STAMP] += 1
            k = _ball(head, nxt, v, st, tmark, cnt[STAMP], 0)
            if k <= 0:
                continue
            r = _try(
                P,
                T,
                alive,
                head,
                nxt,
                prv,
                freeT,
                cnt,
                fixed,
                dirty,
                st,
                k,
                v,
                allow_remove,
                measure,
                tie_rel,
                gain,
                cyc,
                ea,
                eb,
                tmark,
                vmark,
                vpos,
                px,
                py,
                qx,
                qy,
                counters,
                kind,
            )
            if r == 2:
                todo[v] = 1
                return changed, 2
            changed += r
    elif kind == PAIR:
        rows = cnt[N_ROWS]
        for t in range(rows):
            if not alive[t] or not (todo[T[t, 0]] or todo[T[t, 1]] or todo[T[t, 2]]):
                continue
            for j in range(3):
                if not alive[t]:
                    break
                a, b = T[t, j], T[t, (j + 1) % 3]
                u = _neighbour(T, head, nxt, a, b)
                if u < 0 or u == t:
                    continue
                st[0] = t
                st[1] = u
                cnt[STAMP] += 1
                tmark[t] = cnt[STAMP]
                tmark[u] = cnt[STAMP]
                r = _try(
                    P,
                    T,
                    alive,
                    head,
                    nxt,
                    prv,
                    freeT,
                    cnt,
                    fixed,
                    dirty,
                    st,
                    np.int64(2),
                    np.int64(-1),
                    allow_remove,
                    measure,
                    tie_rel,
                    gain,
                    cyc,
                    ea,
                    eb,
                    tmark,
                    vmark,
                    vpos,
                    px,
                    py,
                    qx,
                    qy,
                    counters,
                    kind,
                )
                if r == 2:
                    return changed, 2
                changed += r
        for v in range(n):
            todo[v] = 0
    else:
        rows = cnt[N_ROWS]
        for t in range(rows):
            if not alive[t]:
                continue
            a0, a1, a2 = T[t, 0], T[t, 1], T[t, 2]
            if orient2d_scalar(P[a0, 0], P[a0, 1], P[a1, 0], P[a1, 1], P[a2, 0], P[a2, 1]) > 0:
                continue
            for g in range(5 + len(GROW)):
                if not alive[t]:
                    break
                cnt[STAMP] += 1
                if g >= 5:
                    # triangles reached from t across edges, breadth first: a disk that
                    # does not depend on vertex degrees
                    k = _grow(T, head, nxt, t, st, tmark, cnt[STAMP], GROW[g - 5])
                elif g < 3:
                    k = _ball(head, nxt, T[t, g], st, tmark, cnt[STAMP], 0)
                    if k > 0:
                        k = _ball(head, nxt, T[t, (g + 1) % 3], st, tmark, cnt[STAMP], k)
                else:
                    k = _ball(head, nxt, a0, st, tmark, cnt[STAMP], 0)
                    for w in (a1, a2):
                        if k > 0:
                            k = _ball(head, nxt, w, st, tmark, cnt[STAMP], k)
                    if g == 4:
                        # the second ring: the balls of every vertex of the three balls
                        k1 = k
                        for i in range(k1):
                            for jj in range(3):
                                if k > 0:
                                    k = _ball(head, nxt, T[st[i], jj], st, tmark, cnt[STAMP], k)
                if k <= 0:
                    continue
                r = _try(
                    P,
                    T,
                    alive,
                    head,
                    nxt,
                    prv,
                    freeT,
                    cnt,
                    fixed,
                    dirty,
                    st,
                    k,
                    np.int64(-1),
                    allow_remove,
                    measure,
                    tie_rel,
                    gain,
                    cyc,
                    ea,
                    eb,
                    tmark,
                    vmark,
                    vpos,
                    px,
                    py,
                    qx,
                    qy,
                    counters,
                    kind,
                )
                if r == 2:
                    return changed, 2
                changed += r
    return changed, 0


@njit(cache=True)
def sur(P, T, alive, rows):
    """Sur(𝒯): the sum of the unsigned areas of the live triangles of ``T[:rows]``."""
    s = 0.0
    for t in range(rows):
        if alive[t]:
            a, b, c = T[t, 0], T[t, 1], T[t, 2]
            s += 0.5 * abs(
                (P[b, 0] - P[a, 0]) * (P[c, 1] - P[a, 1])
                - (P[b, 1] - P[a, 1]) * (P[c, 0] - P[a, 0])
            )
    return s


@njit(cache=True)
def edge_index(T, alive, rows, n):
    """The oriented edges a -> b of the live rows of ``T[:rows]`` grouped by a, sorted by b.

    Returns ``start`` (n + 1), ``dst`` and ``slot``: the edges from a are
    ``dst[start[a]:start[a + 1]]`` in increasing order, edge ``slot`` = 3 t + j
    running from corner j of row t to corner j + 1. A counting sort by a,
    then each group sorted: the cost does not depend on vertex degrees
    beyond a log (the initial fan has a vertex in every triangle).
    """
    start = np.zeros(n + 1, np.int64)
    for t in range(rows):
        if alive[t]:
            for j in range(3):
                start[T[t, j] + 1] += 1
    for v in range(n):
        start[v + 1] += start[v]
    fill = start[:n].copy()
    dst = np.empty(start[n], np.int64)
    slot = np.empty(start[n], np.int64)
    for t in range(rows):
        if alive[t]:
            for j in range(3):
                a = T[t, j]
                dst[fill[a]] = T[t, (j + 1) % 3]
                slot[fill[a]] = 3 * t + j
                fill[a] += 1
    for v in range(n):
        lo, hi = start[v], start[v + 1]
        if hi - lo > 32:
            order = np.argsort(dst[lo:hi]) + lo
            dst[lo:hi] = dst[order]
            slot[lo:hi] = slot[order]
        else:  # insertion sort of a vertex's few edges
            for i in range(lo + 1, hi):
                d, s = dst[i], slot[i]
                k = i - 1
                while k >= lo and dst[k] > d:
                    dst[k + 1] = dst[k]
                    slot[k + 1] = slot[k]
                    k -= 1
                dst[k + 1] = d
                slot[k + 1] = s
    return start, dst, slot


@njit(cache=True)
def find_edge(start, dst, a, b):
    """Index of the edge a -> b in :func:`edge_index`'s arrays (the first if repeated), or -1."""
    lo, hi = start[a], start[a + 1]
    i = lo + np.searchsorted(dst[lo:hi], b)
    return i if i < hi and dst[i] == b else -1


@njit(cache=True)
def check_mesh(P, T, bnd):
    """True when ``T`` is a valid mesh bounded by exactly the edges ``bnd`` (Definition 8.1).

    Every triangle positive (exact orient2d), every oriented edge in exactly
    one triangle and its reverse in at most one (a consistently oriented
    mesh topology), and the edges without a reverse exactly the rows of
    ``bnd`` (oriented as in the triangles). From the edges grouped by vertex
    (:func:`edge_index`): the cost does not depend on vertex degrees beyond
    a log.
    """
    work = np.empty(WORK_SIZE)
    m = T.shape[0]
    n = np.int64(0)
    for t in range(m):
        a, b, c = T[t, 0], T[t, 1], T[t, 2]
        n = max(n, a + 1, b + 1, c + 1)
        if orient2d_filtered(P[a, 0], P[a, 1], P[b, 0], P[b, 1], P[c, 0], P[c, 1], work) <= 0:
            return False
    for i in range(bnd.shape[0]):
        n = max(n, bnd[i, 0] + 1, bnd[i, 1] + 1)
    start, dst, _ = edge_index(T, np.ones(m, np.uint8), m, n)  # uint8: as the loops' alive
    lone = 0
    for a in range(n):
        for i in range(start[a], start[a + 1]):
            if i > start[a] and dst[i] == dst[i - 1]:
                return False  # an oriented edge in two triangles
            if find_edge(start, dst, dst[i], a) < 0:
                lone += 1
    if lone != bnd.shape[0]:
        return False
    for i in range(bnd.shape[0]):
        a, b = bnd[i, 0], bnd[i, 1]
        if find_edge(start, dst, a, b) < 0 or find_edge(start, dst, b, a) >= 0:
            return False
    return True


@njit(cache=True)
def qualities(P, T, measure):
    """The (8.2) measure of every triangle of ``T`` (:func:`_quality`, as the loop sees it)."""
    q = np.empty(T.shape[0])
    for t in range(T.shape[0]):
        a, b, c = T[t, 0], T[t, 1], T[t, 2]
        q[t] = _quality(P[a, 0], P[a, 1], P[b, 0], P[b, 1], P[c, 0], P[c, 1], measure)
    return q
