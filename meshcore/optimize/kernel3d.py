"""Compiled ball loop of the optimization-based method for tetrahedra (§8.3.4).

The state is a mesh topology of tetrahedra (faces in one or two cells):
rows ``T`` with an ``alive`` flag and per vertex a doubly linked list of its
corners (slot ``4 t + j``), as :mod:`.kernel2d` does for triangles. The loop
over vertices is inherently sequential (each replacement changes the next
ball): one numba function per pass.

Sub-topologies are the balls ℬ_P of free (interior, not fixed) vertices.
Candidates, compared by the rule of :mod:`.kernel2d` (positive first, then
Sur = the sum of unsigned volumes, then the worst quality):

* Op(G, δℬ_P), G the centroid of the vertices of δℬ_P other than P: P moves
  to G (no topology change). When that leaves a tetrahedron non-positive,
  also G', a point of the kernel of δℬ_P sought by relaxation (repeated
  projection past the plane of the face that sees it worst, Agmon-Motzkin),
  a choice the text leaves open ("G could be an arbitrary point").
* Op(Q, δℬ_P) for Q a vertex of δℬ_P: every tetrahedron of the ball not
  holding Q gets Q in place of P (the tets holding Q vanish), which removes P.
  Only where the ball is not positive and removal is allowed. The validity
  condition of §8.3.3 is checked: no new edge or face (holding Q) may exist
  outside the ball.

Edge shells and larger sets (named by §8.3.4) are not used.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from meshcore.geometry.predicates3d import orient3d_scalar

KMAX = 256
C_MOVE, C_KERNEL, C_COLLAPSE = range(3)
N_PTS, N_ROWS, N_FREE, STAMP = range(4)

_FACE = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]], np.int64)  # outward faces


@njit(cache=True, inline="always")
def _positive(P, a, b, c, d):
    """True when tet (a, b, c, d) has a positive volume det[b-a, c-a, d-a] (exact)."""
    return (
        orient3d_scalar(
            P[a, 0],
            P[a, 1],
            P[a, 2],
            P[b, 0],
            P[b, 1],
            P[b, 2],
            P[c, 0],
            P[c, 1],
            P[c, 2],
            P[d, 0],
            P[d, 1],
            P[d, 2],
        )
        < 0
    )


@njit(cache=True, inline="always")
def _vol_q(P, a, b, c, d, measure):
    """(unsigned volume, quality) of tet (a, b, c, d): shape or radius ratio 3r/R."""
    ux, uy, uz = P[b, 0] - P[a, 0], P[b, 1] - P[a, 1], P[b, 2] - P[a, 2]
    vx, vy, vz = P[c, 0] - P[a, 0], P[c, 1] - P[a, 1], P[c, 2] - P[a, 2]
    wx, wy, wz = P[d, 0] - P[a, 0], P[d, 1] - P[a, 1], P[d, 2] - P[a, 2]
    det = ux * (vy * wz - vz * wy) - uy * (vx * wz - vz * wx) + uz * (vx * wy - vy * wx)
    vol = abs(det) / 6.0
    if measure == 0:
        s = ux * ux + uy * uy + uz * uz + vx * vx + vy * vy + vz * vz + wx * wx + wy * wy + wz * wz
        s += (vx - ux) ** 2 + (vy - uy) ** 2 + (vz - uz) ** 2
        s += (wx - ux) ** 2 + (wy - uy) ** 2 + (wz - uz) ** 2
        s += (wx - vx) ** 2 + (wy - vy) ** 2 + (wz - vz) ** 2
        return vol, (12.0 * (3.0 * vol) ** (2.0 / 3.0) / s if s > 0.0 else 0.0)
    # 3 r / R with r = 3V / S and R = |num| / (12 V)
    bcx, bcy, bcz = vy * wz - vz * wy, vz * wx - vx * wz, vx * wy - vy * wx
    cax, cay, caz = wy * uz - wz * uy, wz * ux - wx * uz, wx * uy - wy * ux
    abx, aby, abz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    ex, ey, ez = vx - ux, vy - uy, vz - uz
    fx, fy, fz = wx - ux, wy - uy, wz - uz
    gx, gy, gz = ey * fz - ez * fy, ez * fx - ex * fz, ex * fy - ey * fx
    S2 = (
        math.sqrt(abx * abx + aby * aby + abz * abz)
        + math.sqrt(bcx * bcx + bcy * bcy + bcz * bcz)
        + math.sqrt(cax * cax + cay * cay + caz * caz)
        + math.sqrt(gx * gx + gy * gy + gz * gz)
    )
    uu, vv, ww = (
        ux * ux + uy * uy + uz * uz,
        vx * vx + vy * vy + vz * vz,
        wx * wx + wy * wy + wz * wz,
    )
    nx = bcx * uu + cax * vv + abx * ww
    ny = bcy * uu + cay * vv + aby * ww
    nz = bcz * uu + caz * vv + abz * ww
    den = S2 * math.sqrt(nx * nx + ny * ny + nz * nz)
    return vol, (6.0 * det * det / den if den > 0.0 else 0.0)


@njit(cache=True, inline="always")
def _better(pa, sa, qa, pb, sb, qb, tie, gain):
    if pa != pb:
        return pa
    if not pa:
        if sa < sb - tie:
            return True
        if sa > sb + tie:
            return False
    return qa > qb + gain


@njit(cache=True)
def _link_corner(head, nxt, prv, s, v):
    nxt[s] = head[v]
    prv[s] = -1
    if head[v] >= 0:
        prv[head[v]] = s
    head[v] = s


@njit(cache=True)
def _unlink_corner(head, nxt, prv, s, v):
    if prv[s] >= 0:
        nxt[prv[s]] = nxt[s]
    else:
        head[v] = nxt[s]
    if nxt[s] >= 0:
        prv[nxt[s]] = prv[s]


@njit(cache=True)
def build(T, m, n, head, nxt, prv):
    """Corner lists of the first ``m`` rows of ``T`` over ``n`` vertices."""
    head[:n] = -1
    for t in range(m):
        for j in range(4):
            _link_corner(head, nxt, prv, 4 * t + j, T[t, j])


@njit(cache=True)
def _evaluate(P, T, st, pos_of, k, v, x, y, z, skip_q, measure):
    """Ball tets with v at (x, y, z) (skip_q < 0) or replaced by vertex skip_q (collapse)."""
    ox, oy, oz = P[v, 0], P[v, 1], P[v, 2]
    if skip_q < 0:
        P[v, 0], P[v, 1], P[v, 2] = x, y, z
    pos = True
    sur = 0.0
    q = 2.0
    for i in range(k):
        t = st[i]
        a, b, c, d = T[t, 0], T[t, 1], T[t, 2], T[t, 3]
        if skip_q >= 0:
            if a == skip_q or b == skip_q or c == skip_q or d == skip_q:
                continue
            j = pos_of[i]
            if j == 0:
                a = skip_q
            elif j == 1:
                b = skip_q
            elif j == 2:
                c = skip_q
            else:
                d = skip_q
        if not _positive(P, a, b, c, d):
            pos = False
        vol, qq = _vol_q(P, a, b, c, d, measure)
        sur += vol
        q = min(q, qq)
    P[v, 0], P[v, 1], P[v, 2] = ox, oy, oz
    return pos, sur, q


@njit(cache=True)
def _relaxed_kernel_point(P, T, st, pos_of, k, v, x, y, z, h):
    """A point seeing every face of δℬ_v from inside, by relaxation from (x, y, z); NaN if none."""
    for _ in range(60):
        worst = np.inf
        wn0 = wn1 = wn2 = 0.0
        for i in range(k):
            t = st[i]
            f = _FACE[pos_of[i]]
            a, b, c = T[t, f[0]], T[t, f[1]], T[t, f[2]]
            ux, uy, uz = P[b, 0] - P[a, 0], P[b, 1] - P[a, 1], P[b, 2] - P[a, 2]
            vx, vy, vz = P[c, 0] - P[a, 0], P[c, 1] - P[a, 1], P[c, 2] - P[a, 2]
            # inward normal of the face (a, b, c) as seen from v's side
            n0, n1, n2 = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
            nn = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
            if nn == 0.0:
                return np.nan, np.nan, np.nan
            n0, n1, n2 = -n0 / nn, -n1 / nn, -n2 / nn
            d = (x - P[a, 0]) * n0 + (y - P[a, 1]) * n1 + (z - P[a, 2]) * n2
            if d < worst:
                worst = d
                wn0, wn1, wn2 = n0, n1, n2
        if worst >= 0.1 * h:
            return x, y, z
        step = 0.1 * h - worst
        x += step * wn0
        y += step * wn1
        z += step * wn2
    return np.nan, np.nan, np.nan


@njit(cache=True)
def _collapse_allowed(T, head, nxt, st, pos_of, k, v, q, tmark, stamp, vmark):
    """§8.3.3 for Op(q, δℬ_v): no edge (q, x) or face (q, x, y) it creates exists outside ℬ_v."""
    # vertices already joined to q inside the ball: vmark = stamp; other link vertices: -stamp
    for i in range(k):
        t = st[i]
        for j in range(4):
            w = T[t, j]
            if w != v and vmark[w] != stamp:
                vmark[w] = -stamp
    for i in range(k):
        t = st[i]
        if T[t, 0] == q or T[t, 1] == q or T[t, 2] == q or T[t, 3] == q:
            for j in range(4):
                if T[t, j] != v:
                    vmark[T[t, j]] = stamp
    s = head[q]
    while s >= 0:
        t = s // 4
        if tmark[t] != stamp:
            new_count = 0
            for j in range(4):
                w = T[t, j]
                if w != q and vmark[w] == -stamp:
                    return False  # a new edge (q, w) exists outside
                if w != q and vmark[w] == stamp:
                    new_count += 1
            if new_count >= 2:
                # a face (q, x, y) outside with x, y link vertices joined to q in the ball: the
                # new faces (q, x, y) come from ball faces (v, x, y) not holding q
                for i in range(k):
                    u = st[i]
                    if T[u, 0] == q or T[u, 1] == q or T[u, 2] == q or T[u, 3] == q:
                        continue
                    f = _FACE[pos_of[i]]
                    for e in range(3):
                        x, y = T[u, f[e]], T[u, f[(e + 1) % 3]]
                        hx = hy = False
                        for j in range(4):
                            hx = hx or T[t, j] == x
                            hy = hy or T[t, j] == y
                        if hx and hy:
                            return False
        s = nxt[s]
    return True


@njit(cache=True)
def sweep(
    P,
    T,
    alive,
    head,
    nxt,
    prv,
    cnt,
    fixed,
    todo,
    dirty,
    allow_remove,
    measure,
    tie_rel,
    gain,
    counters,
):
    """One pass over the balls of the free vertices marked in ``todo``; the replacements."""
    n = cnt[N_PTS]
    st = np.empty(KMAX, np.int64)
    pos_of = np.empty(KMAX, np.int64)
    tmark = np.zeros(T.shape[0], np.int64)
    vmark = np.zeros(P.shape[0], np.int64)
    changed = 0
    for v in range(n):
        if not todo[v] or fixed[v] or head[v] < 0:
            continue
        todo[v] = 0
        cnt[STAMP] += 1
        stamp = cnt[STAMP]
        k = 0
        s = head[v]
        while s >= 0 and k < KMAX:
            st[k] = s // 4
            pos_of[k] = s % 4
            tmark[s // 4] = stamp
            k += 1
            s = nxt[s]
        if s >= 0:
            continue
        cur_p, cur_s, cur_q = _evaluate(
            P, T, st, pos_of, k, v, P[v, 0], P[v, 1], P[v, 2], -1, measure
        )
        tie = tie_rel * cur_s
        gx = gy = gz = 0.0
        nl = 0
        h = 0.0
        for i in range(k):
            t = st[i]
            for j in range(4):
                w = T[t, j]
                if w != v and vmark[w] != stamp:
                    vmark[w] = stamp
                    gx += P[w, 0]
                    gy += P[w, 1]
                    gz += P[w, 2]
                    h += math.sqrt(
                        (P[w, 0] - P[v, 0]) ** 2
                        + (P[w, 1] - P[v, 1]) ** 2
                        + (P[w, 2] - P[v, 2]) ** 2
                    )
                    nl += 1
        gx /= nl
        gy /= nl
        gz /= nl
        h /= nl
        best = -3
        bp, bs, bq = cur_p, cur_s, cur_q
        p, s_, q = _evaluate(P, T, st, pos_of, k, v, gx, gy, gz, -1, measure)
        if _better(p, s_, q, bp, bs, bq, tie, gain):
            best, bp, bs, bq = -2, p, s_, q
        kx = ky = kz = np.nan
        if not p:
            kx, ky, kz = _relaxed_kernel_point(P, T, st, pos_of, k, v, gx, gy, gz, h)
            if kx == kx:
                p, s_, q = _evaluate(P, T, st, pos_of, k, v, kx, ky, kz, -1, measure)
                if _better(p, s_, q, bp, bs, bq, tie, gain):
                    best, bp, bs, bq = -1, p, s_, q
        if allow_remove and not cur_p and best == -3:
            for i in range(k):
                for j in range(4):
                    w = T[st[i], j]
                    if w == v:
                        continue
                    p, s_, q = _evaluate(P, T, st, pos_of, k, v, 0.0, 0.0, 0.0, w, measure)
                    if _better(p, s_, q, bp, bs, bq, tie, gain):
                        cnt[STAMP] += 1
                        # membership marks of the ball under the new stamp
                        for ii in range(k):
                            tmark[st[ii]] = cnt[STAMP]
                        if _collapse_allowed(
                            T, head, nxt, st, pos_of, k, v, w, tmark, cnt[STAMP], vmark
                        ):
                            best, bp, bs, bq = w, p, s_, q
        if best == -3:
            continue
        if best == -2 or best == -1:
            P[v, 0] = gx if best == -2 else kx
            P[v, 1] = gy if best == -2 else ky
            P[v, 2] = gz if best == -2 else kz
            counters[C_MOVE if best == -2 else C_KERNEL] += 1
        else:
            q_ = best
            for i in range(k):
                t = st[i]
                j = pos_of[i]
                holds = T[t, 0] == q_ or T[t, 1] == q_ or T[t, 2] == q_ or T[t, 3] == q_
                _unlink_corner(head, nxt, prv, 4 * t + j, v)
                if holds:
                    for jj in range(4):
                        if jj != j:
                            _unlink_corner(head, nxt, prv, 4 * t + jj, T[t, jj])
                    alive[t] = 0
                else:
                    T[t, j] = q_
                    _link_corner(head, nxt, prv, 4 * t + j, q_)
            counters[C_COLLAPSE] += 1
        for i in range(k):
            for j in range(4):
                dirty[T[st[i], j]] = 1
        dirty[v] = 1
        changed += 1
    return changed


@njit(cache=True)
def sur(P, T, alive, rows):
    """Sur(𝒯): the sum of the unsigned volumes of the live tets of ``T[:rows]``."""
    s = 0.0
    for t in range(rows):
        if alive[t]:
            s += _vol_q(P, T[t, 0], T[t, 1], T[t, 2], T[t, 3], 0)[0]
    return s
