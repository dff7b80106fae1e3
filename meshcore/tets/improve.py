"""Mesh improvement of tetrahedra: flips and smoothing that raise the least dihedral angle.

Compiled kernels of :func:`meshcore.tets.slivers.improve` (Klingner and
Shewchuk, "Aggressive tetrahedral mesh improvement", IMR 2007, in a reduced
form). The state is :mod:`meshcore.mesh.tetstore`'s: rows ``T`` of
positively oriented tetrahedra (``det[b - a, c - a, d - a] > 0``) with an
``alive`` flag and per vertex the linked list of its corners, built and
edited with that module's helpers. Every operation replaces a set of
tetrahedra by another filling the same polyhedron, each new one positive
by the exact ``orient3d``, and is applied only when the least dihedral
angle of the new set beats the old set's by ``EPS`` degrees (hill
climbing: the least angle never drops, and the passes end):

* **Edge removal** (3-2, 4-4, 5-6, 6-8, 7-10 flips): the shell of an edge
  of at most ``RING_MAX`` tetrahedra, none of its faces through the edge
  constrained, replaced by the fan of its boundary from one ring vertex
  (every triangulation of the ring for rings of up to 5).
* **Face removal** (2-3 flip) across an unconstrained face.
* **Smoothing** of a free vertex: the non-smooth maximization of the least
  dihedral angle of its star, by the steepest ascent direction of the
  near-active tetrahedra (the point of least norm of the convex hull of
  their gradients, by finite differences) and a halving line search.

Constrained faces (the surface and the faces between regions) are never
removed, so the boundary faces stay exactly what they were; a radius-edge
bound ``mre`` is kept: no new tetrahedron exceeds ``max(mre, the worst of
the set it replaces)``.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from meshcore.mesh import tetstore as ts

#: Largest edge shell removed (tetrahedra around the edge).
RING_MAX = 7
#: Degrees an operation must gain on the least dihedral angle of its set.
EPS = 1e-6
#: Tetrahedra within this many degrees of a star's least angle are active in smoothing.
ACTIVE = 0.5
#: Ascent steps per smoothed vertex, and halvings per line search.
SMOOTH_STEPS = 8
HALVINGS = 12
#: A smoothing step's ascent direction shorter than this times its longest gradient is
#: rounding (the gradients' hull holds 0: a stationary point), and smoothing stops there.
STATIONARY = 1e-6
#: Most active gradients kept per smoothing step.
GMAX = 16
#: Status of :func:`improve_passes` when the rows or the spare points run out (grow them and
#: call again).
OUT_OF_ROWS, OUT_OF_POINTS = 2, 3
#: ``counters`` entries.
C_EDGE, C_FACE, C_SMOOTH, C_INSERT = range(4)
#: Base of the face keys (vertex numbers below it): keys stay valid as points are added.
NK = np.int64(1 << 21)  # int64 in kernels, not a literal (one compiled copy of callees)
#: ``gather``'s "no second vertex" and empty start, int64 for the same reason.
_NONE, _ZERO = np.int64(-1), np.int64(0)

_FACE = ts.FACE


@njit(cache=True)
def tet_quality(P, a, b, c, d):
    """(least dihedral angle in degrees, radius-edge ratio) of tetrahedron (a, b, c, d), float.

    Either orientation; a flat tetrahedron gives (0, inf).
    """
    n0x, n0y, n0z = ts.face_cross(P, b, c, d)
    n1x, n1y, n1z = ts.face_cross(P, a, d, c)
    n2x, n2y, n2z = ts.face_cross(P, a, b, d)
    n3x, n3y, n3z = ts.face_cross(P, a, c, b)
    l0 = math.sqrt(n0x * n0x + n0y * n0y + n0z * n0z)
    l1 = math.sqrt(n1x * n1x + n1y * n1y + n1z * n1z)
    l2 = math.sqrt(n2x * n2x + n2y * n2y + n2z * n2z)
    l3 = math.sqrt(n3x * n3x + n3y * n3y + n3z * n3z)
    if l0 == 0.0 or l1 == 0.0 or l2 == 0.0 or l3 == 0.0:
        return 0.0, np.inf
    # the dihedral angle at an edge: between the two faces holding it (outward normals)
    c01 = -(n0x * n1x + n0y * n1y + n0z * n1z) / (l0 * l1)
    c02 = -(n0x * n2x + n0y * n2y + n0z * n2z) / (l0 * l2)
    c03 = -(n0x * n3x + n0y * n3y + n0z * n3z) / (l0 * l3)
    c12 = -(n1x * n2x + n1y * n2y + n1z * n2z) / (l1 * l2)
    c13 = -(n1x * n3x + n1y * n3y + n1z * n3z) / (l1 * l3)
    c23 = -(n2x * n3x + n2y * n3y + n2z * n3z) / (l2 * l3)
    cm = max(max(max(c01, c02), max(c03, c12)), max(c13, c23))
    dih = math.degrees(math.acos(min(1.0, max(-1.0, cm))))
    ux, uy, uz = P[b, 0] - P[a, 0], P[b, 1] - P[a, 1], P[b, 2] - P[a, 2]
    vx, vy, vz = P[c, 0] - P[a, 0], P[c, 1] - P[a, 1], P[c, 2] - P[a, 2]
    wx, wy, wz = P[d, 0] - P[a, 0], P[d, 1] - P[a, 1], P[d, 2] - P[a, 2]
    vwx, vwy, vwz = vy * wz - vz * wy, vz * wx - vx * wz, vx * wy - vy * wx
    wux, wuy, wuz = wy * uz - wz * uy, wz * ux - wx * uz, wx * uy - wy * ux
    uvx, uvy, uvz = uy * vz - uz * vy, uz * vx - ux * vz, ux * vy - uy * vx
    det = ux * vwx + uy * vwy + uz * vwz
    uu = ux * ux + uy * uy + uz * uz
    vv = vx * vx + vy * vy + vz * vz
    ww = wx * wx + wy * wy + wz * wz
    nx = uu * vwx + vv * wux + ww * uvx
    ny = uu * vwy + vv * wuy + ww * uvy
    nz = uu * vwz + vv * wuz + ww * uvz
    e12 = (vx - ux) ** 2 + (vy - uy) ** 2 + (vz - uz) ** 2
    e13 = (wx - ux) ** 2 + (wy - uy) ** 2 + (wz - uz) ** 2
    e23 = (wx - vx) ** 2 + (wy - vy) ** 2 + (wz - vz) ** 2
    short = min(min(min(uu, vv), min(ww, e12)), min(e13, e23))
    if det == 0.0 or short == 0.0:
        return dih, np.inf
    R = math.sqrt(nx * nx + ny * ny + nz * nz) / (2.0 * abs(det))
    return dih, R / math.sqrt(short)


@njit(cache=True, inline="always")
def _constrained(subk, key):
    i = np.searchsorted(subk, key)
    return i < subk.shape[0] and subk[i] == key


@njit(cache=True)
def _set_quality(P, T, st, k):
    q = np.inf
    r = 0.0
    for i in range(k):
        t = st[i]
        dq, rr = tet_quality(P, T[t, 0], T[t, 1], T[t, 2], T[t, 3])
        q = min(q, dq)
        r = max(r, rr)
    return q, r


@njit(cache=True)
def _replace(T, alive, head, nxt, prv, freeT, cnt, reg, st, k, bf, nb, apex):
    """Tetrahedra st[:k] replaced by the fan from ``apex`` of the faces bf[:nb] not holding it."""
    r = reg[st[0]]
    for i in range(k):
        ts.remove_cell(T, alive, head, nxt, prv, freeT, cnt, st[i])
    for f in range(nb):
        a, b, c = bf[f, 0], bf[f, 1], bf[f, 2]
        if a != apex and b != apex and c != apex:
            t = ts.add_tet(T, alive, head, nxt, prv, freeT, cnt, apex, a, b, c)
            reg[t] = r


@njit(cache=True)
def _fan_quality(P, bf, nb, q, floor):
    """Least angle and largest ratio of the fan from q over bf[:nb]; (-1, inf) when a
    tetrahedron is not positive (exact) or the angle does not beat ``floor``."""
    mq = np.inf
    mr = 0.0
    for f in range(nb):
        a, b, c = bf[f, 0], bf[f, 1], bf[f, 2]
        if a == q or b == q or c == q:
            continue
        dq, rr = tet_quality(P, q, a, b, c)
        if dq <= floor or not ts.positive(P, q, a, b, c):
            return -1.0, np.inf
        mq = min(mq, dq)
        mr = max(mr, rr)
    return mq, mr


@njit(cache=True)
def _remove_edge(
    P, T, alive, head, nxt, prv, freeT, cnt, reg, subk, a, b, st, tmark, vmark, bf, mre
):
    """Edge removal of (a, b) when it raises its shell's least angle: 1, 0, or -1 (no room)."""
    cnt[ts.STAMP] += 1
    stamp = cnt[ts.STAMP]
    k = ts.gather(head, nxt, a, b, T, st, tmark, stamp, _ZERO)
    if k < 3 or k > RING_MAX:
        return 0
    for i in range(k):
        t = st[i]
        for j in range(4):
            x = T[t, j]
            if x != a and x != b and _constrained(subk, ts.face_key(a, b, x, NK)):
                return 0
    nb = ts.boundary(T, st, k, NK, bf)
    if nb != 2 * k:
        return 0  # the edge is on the boundary
    old_q, old_r = _set_quality(P, T, st, k)
    cap = max(mre, old_r)
    best = np.int64(-1)  # not a literal: _replace and add_tet compiled once
    best_q = old_q + EPS
    for i in range(k):
        t = st[i]
        for j in range(4):
            q = T[t, j]
            if q == a or q == b or vmark[q] == stamp:
                continue
            vmark[q] = stamp
            mq, mr = _fan_quality(P, bf, nb, q, best_q)
            if mq > best_q and mr <= cap:
                best, best_q = q, mq
    if best < 0:
        return 0
    if not ts.room(T, cnt, 2 * (k - 2) - k):
        return -1
    _replace(T, alive, head, nxt, prv, freeT, cnt, reg, st, k, bf, nb, best)
    return 1


@njit(cache=True)
def _remove_face(P, T, alive, head, nxt, prv, freeT, cnt, reg, subk, t, j, st, bf, mre):
    """2-3 flip of face j of tetrahedron t when it raises the least angle: 1, 0, or -1."""
    f = _FACE[j]
    x, y, z = T[t, f[0]], T[t, f[1]], T[t, f[2]]
    if _constrained(subk, ts.face_key(x, y, z, NK)):
        return 0
    u = ts.across(T, head, nxt, t, j)
    if u < 0:
        return 0
    st[0], st[1] = t, u
    two = np.int64(2)  # int64 counts, not literals: each literal compiles the callee again
    old_q, old_r = _set_quality(P, T, st, two)
    e = T[u, 0] + T[u, 1] + T[u, 2] + T[u, 3] - x - y - z
    # the faces of the pair, outward: the fan from the apex e over them is the 2-3 flip
    nb = np.int64(0)
    for i in range(2):
        w = st[i]
        for jj in range(4):
            g = _FACE[jj]
            a, b, c = T[w, g[0]], T[w, g[1]], T[w, g[2]]
            if (a == x or a == y or a == z) and (b == x or b == y or b == z):
                if c == x or c == y or c == z:
                    continue  # the shared face
            bf[nb, 0], bf[nb, 1], bf[nb, 2] = a, b, c
            nb += 1
    mq, mr = _fan_quality(P, bf, nb, e, old_q + EPS)
    if mq < 0 or mr > max(mre, old_r):
        return 0
    if not ts.room(T, cnt, 1):
        return -1
    _replace(T, alive, head, nxt, prv, freeT, cnt, reg, st, two, bf, nb, e)
    return 1


@njit(cache=True)
def _star_positive(P, T, st, k):
    for i in range(k):
        t = st[i]
        if not ts.positive(P, T[t, 0], T[t, 1], T[t, 2], T[t, 3]):
            return False
    return True


@njit(cache=True)
def _min_norm(G, m):
    """The point of least norm of the convex hull of G[:m] (Gilbert's iteration)."""
    x = G[0].copy()
    for _ in range(50):
        best = 0
        bd = np.inf
        for i in range(m):
            d = x[0] * G[i, 0] + x[1] * G[i, 1] + x[2] * G[i, 2]
            if d < bd:
                bd, best = d, i
        xx = x[0] * x[0] + x[1] * x[1] + x[2] * x[2]
        if xx - bd <= 1e-12 * xx:
            break
        dx = G[best] - x
        den = dx[0] * dx[0] + dx[1] * dx[1] + dx[2] * dx[2]
        lam = min(1.0, max(0.0, (xx - bd) / den)) if den > 0.0 else 0.0
        x += lam * dx
    return x


@njit(cache=True)
def _smooth(P, T, head, nxt, cnt, v, st, tmark, G, N, mre):
    """Move free vertex v up the least dihedral angle of its star, within the plane of unit
    normal N[v] when it is not zero (a point inside a facet); True if it moved."""
    cnt[ts.STAMP] += 1
    k = ts.gather(head, nxt, v, _NONE, T, st, tmark, cnt[ts.STAMP], _ZERO)
    if k <= 0:
        return False
    f0, r0 = _set_quality(P, T, st, k)
    cap = max(mre, r0)
    L = np.inf
    for i in range(k):
        t = st[i]
        for j in range(4):
            w = T[t, j]
            if w != v:
                L = min(
                    L,
                    math.sqrt(
                        (P[w, 0] - P[v, 0]) ** 2
                        + (P[w, 1] - P[v, 1]) ** 2
                        + (P[w, 2] - P[v, 2]) ** 2
                    ),
                )
    h = 1e-7 * L
    moved = False
    x0 = np.empty(3)
    for _ in range(SMOOTH_STEPS):
        x0[0], x0[1], x0[2] = P[v, 0], P[v, 1], P[v, 2]
        m = np.int64(0)
        for i in range(k):
            t = st[i]
            a, b, c, d = T[t, 0], T[t, 1], T[t, 2], T[t, 3]
            q, _ = tet_quality(P, a, b, c, d)
            if q > f0 + ACTIVE or m == GMAX:
                continue
            for x in range(3):
                P[v, x] = x0[x] + h
                qh, _ = tet_quality(P, a, b, c, d)
                P[v, x] = x0[x]
                G[m, x] = (qh - q) / h
            gn = G[m, 0] * N[v, 0] + G[m, 1] * N[v, 1] + G[m, 2] * N[v, 2]
            for x in range(3):
                G[m, x] -= gn * N[v, x]
            m += 1
        if m == 0:
            break
        g = _min_norm(G, m)
        # In the plane again: the gradients are, but only to rounding, and where their hull
        # holds 0 (no ascent) the least-norm point is that rounding alone, along N[v]: the
        # step then left the facet by up to half an edge. Twice, as in Gram-Schmidt.
        for _ in range(2):
            gn = g[0] * N[v, 0] + g[1] * N[v, 1] + g[2] * N[v, 2]
            for x in range(3):
                g[x] -= gn * N[v, x]
        gn = math.sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2])
        gmax = 0.0
        for i in range(m):
            gmax = max(gmax, math.sqrt(G[i, 0] ** 2 + G[i, 1] ** 2 + G[i, 2] ** 2))
        if not gn > STATIONARY * gmax:
            break  # a stationary point: what is left of g is rounding, of no direction
        s = min(0.5 * L, 10.0 / gn)
        ok = False
        for _ in range(HALVINGS):
            for x in range(3):
                P[v, x] = x0[x] + s * g[x] / gn
            f1, r1 = _set_quality(P, T, st, k)
            if f1 > f0 + EPS and r1 <= cap and _star_positive(P, T, st, k):
                ok = True
                break
            s *= 0.5
        if not ok:
            for x in range(3):
                P[v, x] = x0[x]
            break
        f0 = f1
        moved = True
    return moved


@njit(cache=True)
def _cavity_allowed(T, head, nxt, reg, subk, t, st, k, tmark, vmark, bf, nb):
    """The cavity st[:k] (marked ``tmark == cnt[STAMP]``) is in t's region, holds no
    constrained face inside, and every vertex of it is on its boundary bf[:nb]."""
    stamp = tmark[t]
    for i in range(k):
        u = st[i]
        if reg[u] != reg[t]:
            return False
        for j in range(4):
            f = _FACE[j]
            if _constrained(subk, ts.face_key(T[u, f[0]], T[u, f[1]], T[u, f[2]], NK)):
                w = ts.across(T, head, nxt, u, j)
                if w >= 0 and tmark[w] == stamp:
                    return False
    for f in range(nb):
        for e in range(3):
            vmark[bf[f, e]] = stamp
    for i in range(k):
        for j in range(4):
            if vmark[T[st[i], j]] != stamp:
                return False
    return True


@njit(cache=True)
def _insert(
    P,
    T,
    alive,
    head,
    nxt,
    prv,
    freeT,
    cnt,
    reg,
    subk,
    fixed,
    t,
    st,
    tmark,
    vmark,
    bf,
    G,
    N,
    old,
    mre,
):
    """A new free point in a star cavity around t, smoothed, kept when its star's least
    angle beats the cavity's (candidates :func:`meshcore.mesh.tetstore.star_point`, the
    first that gains); 1, 0, or -1 (no room: rows), -2 (no spare point)."""
    g = cnt[ts.N_PTS]
    if g >= P.shape[0]:
        return -2
    r = reg[t]
    for c in range(ts.STARS):
        if not ts.star_point(P, T, head, nxt, t, c, g):
            continue
        cnt[ts.STAMP] += 1
        k = ts.star_cavity(P, T, head, nxt, t, g, st, tmark, cnt[ts.STAMP])
        if k < 0:
            continue
        nb = ts.boundary(T, st, k, NK, bf)
        if nb < 4 or not _cavity_allowed(T, head, nxt, reg, subk, t, st, k, tmark, vmark, bf, nb):
            continue
        old_q, old_r = _set_quality(P, T, st, k)
        mq, _ = _fan_quality(P, bf, nb, g, -1.0)
        if mq < 0:
            continue
        if not ts.room(T, cnt, nb):
            return -1
        for i in range(k):
            old[i] = T[st[i]]
        cnt[ts.N_PTS] += 1
        fixed[g] = 0
        _replace(T, alive, head, nxt, prv, freeT, cnt, reg, st, k, bf, nb, g)
        _smooth(P, T, head, nxt, cnt, g, st, tmark, G, N, mre)
        cnt[ts.STAMP] += 1
        m = ts.gather(head, nxt, g, _NONE, T, st, tmark, cnt[ts.STAMP], _ZERO)
        new_q, new_r = _set_quality(P, T, st, m)
        if new_q > old_q + EPS and new_r <= max(mre, old_r):
            return 1
        # undo: the cavity's tetrahedra back
        for i in range(m):
            ts.remove_cell(T, alive, head, nxt, prv, freeT, cnt, st[i])
        for i in range(k):
            u = ts.add_tet(
                T, alive, head, nxt, prv, freeT, cnt, old[i, 0], old[i, 1], old[i, 2], old[i, 3]
            )
            reg[u] = r
            if i == 0:
                t = u  # the star cavity starts at t: its row may have changed
        cnt[ts.N_PTS] -= 1
        fixed[g] = 1
    return 0


@njit(cache=True)
def improve_passes(
    P, T, alive, head, nxt, prv, freeT, cnt, reg, subk, fixed, N, goal, mre, passes, counters
):
    """Passes over the tetrahedra under ``goal`` degrees: edge removal on their edges, face
    removal on their faces, smoothing of their free vertices, insertion of a new point (the
    first that gains, in that order). Returns (passes run, status): status ``OUT_OF_ROWS``
    or ``OUT_OF_POINTS`` asks for more."""
    st = np.empty(ts.SMAX, np.int64)
    tmark = np.zeros(T.shape[0], np.int64)
    vmark = np.zeros(P.shape[0], np.int64)
    bf = np.empty((4 * ts.SMAX, 3), np.int64)
    G = np.empty((GMAX, 3))
    old = np.empty((ts.SMAX, 4), np.int64)
    done = 0
    for done in range(1, passes + 1):
        changed = 0
        t = np.int64(0)  # not a literal 0: the callees would be compiled for it too
        while t < cnt[ts.N_ROWS]:
            if not alive[t]:
                t += 1
                continue
            q, _ = tet_quality(P, T[t, 0], T[t, 1], T[t, 2], T[t, 3])
            if q >= goal:
                t += 1
                continue
            r = 0
            for e in range(6):
                a, b = T[t, ts.EDGES[e, 0]], T[t, ts.EDGES[e, 1]]
                r = _remove_edge(
                    P, T, alive, head, nxt, prv, freeT, cnt, reg, subk, a, b, st, tmark, vmark,
                    bf, mre,
                )  # fmt: skip
                if r != 0:
                    break
            if r == 1:
                counters[C_EDGE] += 1
            if r == 0:
                for j in range(4):
                    r = _remove_face(
                        P, T, alive, head, nxt, prv, freeT, cnt, reg, subk, t, j, st, bf, mre
                    )
                    if r != 0:
                        break
                if r == 1:
                    counters[C_FACE] += 1
            if r == -1:
                return done, OUT_OF_ROWS
            if r == 0:
                for j in range(4):
                    v = T[t, j]
                    if not fixed[v] and _smooth(P, T, head, nxt, cnt, v, st, tmark, G, N, mre):
                        r = 1
                        counters[C_SMOOTH] += 1
            if r == 0:
                r = _insert(
                    P, T, alive, head, nxt, prv, freeT, cnt, reg, subk, fixed, t, st, tmark,
                    vmark, bf, G, N, old, mre,
                )  # fmt: skip
                if r == -1:
                    return done, OUT_OF_ROWS
                if r == -2:
                    return done, OUT_OF_POINTS
                counters[C_INSERT] += r
            changed += r
            t += 1
        if changed == 0:
            break
    return done, 0
