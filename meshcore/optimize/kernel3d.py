"""Compiled ball loop of the optimization-based method for tetrahedra (§8.3.4).

The state is a mesh topology of tetrahedra (faces in one or two cells):
rows ``T`` with an ``alive`` flag and per vertex a doubly linked list of its
corners (slot ``4 t + j``), as :mod:`.kernel2d` does for triangles. The loop
over vertices is inherently sequential (each replacement changes the next
ball): one numba function per pass.

Sub-topologies are the balls ℬ_P of free (interior, not fixed) vertices.
"Positive" is :func:`meshcore.mesh.tetstore.solid` throughout: the exact
orient3d, a tet flat to the rounding of where the input lies counting as
not positive (``flat``, :func:`meshcore.optimize.coupez.flatness`); Sur
values tie within that rounding too (:func:`_tie`).
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

:func:`fan_sweep` replaces any sub-topology 𝒮 (balls of all vertices,
boundary ones included; shells of edges; larger sets around a non-positive
tet, §8.3.4) by the best fan Op(Q, δ𝒮), Q a vertex of δ𝒮 or a new point G,
checked by :func:`_fan_valid` (the §8.3.3 condition on faces: each new
inner face in exactly two new tets and in no tet outside 𝒮, the new
boundary exactly δ𝒮). It needs free rows (``freeT``) as :mod:`.kernel2d`.
Its ``SLIVER`` kind is the optimization of a valid mesh (the third use):
around each tet of quality under ``SLIVER_Q``, its face pairs and star
cavities, replaced only when their worst quality rises.

Choices the text leaves open, in the larger sets:

* **Edge removal.** Around a non-positive tet (and a sliver), the shell of
  each of its edges is replaced by the best triangulation of its ring
  (:func:`_try_removal`): a composition of Op on face pairs of the shell
  (2-3 moves, each taking one ear of the ring) ending with Op on a 3-tet
  shell, judged as one replacement of the shell by (8.1)-(8.2). A fan
  Op(q, δ𝒮) of the shell is the fan triangulation of the ring from q;
  where the ring has the side of a planar surface quad, none may be
  positive while another triangulation is.
* **Vertex cavities.** Then, for up to ``VERTS`` existing vertices Z met
  around the tet, 𝒮 is the star cavity of Z (as for a new point, below):
  Op(Z, δ𝒮) is positive by construction, without a new point.

* **Star cavities.** With insertion, the last sets tried around a
  non-positive tet are built for a chosen new point G (:func:`star_point`:
  off each face of the tet to its positive side, or in a positive
  neighbour): from the tet, every tet across a face of δ𝒮 that G does not
  see positively joins 𝒮 (:func:`star_cavity`), so Op(G, δ𝒮) is positive
  by construction; it fails where such a face is on the boundary.
* **Pinched vertices.** Definition 8.1 asks nothing of vertices, so a
  tangled topology may hold a vertex whose ball has a closed part (a pocket
  around a surface vertex). A vertex of 𝒮 off δ𝒮 whose ball has tets
  outside 𝒮 stays with them; only one whose whole ball is 𝒮 vanishes (and
  only a free one may).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from meshcore.mesh.tetstore import (
    EDGES,
    FACE,
    N_PTS,
    N_ROWS,
    SMAX,
    STAMP,
    STARS,
    across,
    add_tet,
    boundary,
    det_edges,
    face_cross,
    gather,
    holds,
    link_corner,
    remove_cell,
    room,
    solid,
    star_cavity,
    star_point,
    unlink_corner,
)

KMAX = 256
#: int64 arguments, not literals (each literal compiles the callee again).
_NONE, _ZERO, _ONE, _SMAX = np.int64(-1), np.int64(0), np.int64(1), np.int64(SMAX)
C_MOVE, C_KERNEL, C_COLLAPSE = range(3)


@njit(cache=True, inline="always")
def _vol_q(P, a, b, c, d, measure):
    """(unsigned volume, quality) of tet (a, b, c, d): shape or radius ratio 3r/R."""
    det, s = det_edges(P, a, b, c, d)
    vol = abs(det) / 6.0
    if measure == 0:
        return vol, (12.0 * (3.0 * vol) ** (2.0 / 3.0) / s if s > 0.0 else 0.0)
    # 3 r / R with r = 3V / S and R = |num| / (12 V)
    ux, uy, uz = P[b, 0] - P[a, 0], P[b, 1] - P[a, 1], P[b, 2] - P[a, 2]
    vx, vy, vz = P[c, 0] - P[a, 0], P[c, 1] - P[a, 1], P[c, 2] - P[a, 2]
    wx, wy, wz = P[d, 0] - P[a, 0], P[d, 1] - P[a, 1], P[d, 2] - P[a, 2]
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
def _tie(P, T, st, k, tie_rel, cur_s, flat):
    """Sur values closer than this tie on (8.1): ``tie_rel`` of Sur(𝒮) plus the volume
    rounding of where the input lies (``flat`` / 6 times the squared edges of 𝒮)."""
    ss = 0.0
    for i in range(k):
        t = st[i]
        ss += det_edges(P, T[t, 0], T[t, 1], T[t, 2], T[t, 3])[1]
    return tie_rel * cur_s + flat * ss / 6.0


@njit(cache=True)
def _evaluate(P, T, st, pos_of, k, v, x, y, z, skip_q, measure, flat):
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
        if not solid(P, a, b, c, d, flat):
            pos = False
        vol, qq = _vol_q(P, a, b, c, d, measure)
        sur += vol
        q = min(q, qq)
    P[v, 0], P[v, 1], P[v, 2] = ox, oy, oz
    return pos, sur, q


@njit(cache=True)
def _relaxed_kernel_point(P, T, st, pos_of, k, v, x, y, z, h):
    """A point seeing every face of δℬ_v from inside, by relaxation from (x, y, z); NaN if none."""
    ox, oy, oz = P[v, 0], P[v, 1], P[v, 2]  # relative to v, as the G it starts from
    x, y, z = x - ox, y - oy, z - oz
    for _ in range(60):
        worst = np.inf
        wn0 = wn1 = wn2 = 0.0
        for i in range(k):
            t = st[i]
            f = FACE[pos_of[i]]
            a, b, c = T[t, f[0]], T[t, f[1]], T[t, f[2]]
            # inward normal of the face (a, b, c) as seen from v's side
            n0, n1, n2 = face_cross(P, a, b, c)
            nn = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
            if nn == 0.0:
                return np.nan, np.nan, np.nan
            n0, n1, n2 = -n0 / nn, -n1 / nn, -n2 / nn
            d = (x - (P[a, 0] - ox)) * n0 + (y - (P[a, 1] - oy)) * n1 + (z - (P[a, 2] - oz)) * n2
            if d < worst:
                worst = d
                wn0, wn1, wn2 = n0, n1, n2
        if worst >= 0.1 * h:
            return ox + x, oy + y, oz + z
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
                    f = FACE[pos_of[i]]
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
    flat,
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
            P, T, st, pos_of, k, v, P[v, 0], P[v, 1], P[v, 2], np.int64(-1), measure, flat
        )
        tie = _tie(P, T, st, k, tie_rel, cur_s, flat)
        gx = gy = gz = 0.0
        nl = 0
        h = 0.0
        for i in range(k):
            t = st[i]
            for j in range(4):
                w = T[t, j]
                if w != v and vmark[w] != stamp:
                    vmark[w] = stamp
                    # relative to P[v]: sums of coordinates far from the origin would
                    # round G by the placement's ulp times the count
                    gx += P[w, 0] - P[v, 0]
                    gy += P[w, 1] - P[v, 1]
                    gz += P[w, 2] - P[v, 2]
                    h += math.sqrt(
                        (P[w, 0] - P[v, 0]) ** 2
                        + (P[w, 1] - P[v, 1]) ** 2
                        + (P[w, 2] - P[v, 2]) ** 2
                    )
                    nl += 1
        gx = P[v, 0] + gx / nl
        gy = P[v, 1] + gy / nl
        gz = P[v, 2] + gz / nl
        h /= nl
        best = -3
        bp, bs, bq = cur_p, cur_s, cur_q
        p, s_, q = _evaluate(P, T, st, pos_of, k, v, gx, gy, gz, np.int64(-1), measure, flat)
        if _better(p, s_, q, bp, bs, bq, tie, gain):
            best, bp, bs, bq = -2, p, s_, q
        kx = ky = kz = np.nan
        if not p:
            kx, ky, kz = _relaxed_kernel_point(P, T, st, pos_of, k, v, gx, gy, gz, h)
            if kx == kx:
                p, s_, q = _evaluate(
                    P, T, st, pos_of, k, v, kx, ky, kz, np.int64(-1), measure, flat
                )
                if _better(p, s_, q, bp, bs, bq, tie, gain):
                    best, bp, bs, bq = -1, p, s_, q
        if allow_remove and not cur_p and best == -3:
            for i in range(k):
                for j in range(4):
                    w = T[st[i], j]
                    if w == v:
                        continue
                    p, s_, q = _evaluate(P, T, st, pos_of, k, v, 0.0, 0.0, 0.0, w, measure, flat)
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
                has_q = holds(T, t, q_)
                unlink_corner(head, nxt, prv, 4 * t + j, v)
                if has_q:
                    for jj in range(4):
                        if jj != j:
                            unlink_corner(head, nxt, prv, 4 * t + jj, T[t, jj])
                    alive[t] = 0
                else:
                    T[t, j] = q_
                    link_corner(head, nxt, prv, 4 * t + j, q_)
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


# ----------------------------------------------------------------------------- fans on any 𝒮

#: Sub-topology kinds of :func:`fan_sweep`.
BALL, SHELL, UNION, SLIVER = 0, 1, 2, 3
#: Tets of worse quality (the measure of (8.2)) are the items of the ``SLIVER`` kind.
SLIVER_Q = 0.5
#: Slivers of worse quality (nearly flat, though above the flat rule) also try the star
#: cavities of existing vertices.
FLAT_Q = 1e-3
#: Sizes of the face-adjacent sets grown around a non-positive tetrahedron (UNION).
GROW = (8, 16, 32, 64)
#: ``counters`` entries of :func:`fan_sweep` (after C_MOVE, C_KERNEL, C_COLLAPSE).
#: fans accepted on balls, shells and unions: ``C_BALL_FAN + kind``; edge removals
C_BALL_FAN, C_SHELL_FAN, C_UNION_FAN, C_SLIVER_FAN, C_INSERT, C_CLOSED, C_REMOVAL = range(3, 10)


@njit(cache=True)
def _remove_set(T, alive, head, nxt, prv, freeT, cnt, st, k, mark):
    """The tets st[:k] removed, their vertices marked (``mark[v] = 1``)."""
    for i in range(k):
        t = st[i]
        for j in range(4):
            mark[T[t, j]] = 1
        remove_cell(T, alive, head, nxt, prv, freeT, cnt, t)


@njit(cache=True)
def _fan_valid(T, head, nxt, bf, nb, q, n, tmark, stamp):
    """§8.3.3 for Op(q, δ𝒮): a mesh topology bounded by δ𝒮, no new face already outside 𝒮.

    The new faces (q, x, y) come from the edges (x, y) of the faces of δ𝒮
    not holding q: an edge met twice (once each way) makes an inner face,
    which must not be a face of δ𝒮 nor of a tet outside 𝒮; an edge met once
    must close a face of δ𝒮 holding q, and those must all be closed.
    """
    m = 0
    ek = np.empty(3 * nb, np.int64)
    ed = np.empty(3 * nb, np.int64)
    withq = 0
    for i in range(nb):
        a, b, c = bf[i, 0], bf[i, 1], bf[i, 2]
        if a == q or b == q or c == q:
            withq += 1
            continue
        for e in range(3):
            x = bf[i, e]
            y = bf[i, (e + 1) % 3]
            ek[m] = min(x, y) * n + max(x, y)
            ed[m] = 1 if x < y else -1
            m += 1
    order = np.argsort(ek[:m])
    once = 0
    i = 0
    while i < m:
        j = i
        while j + 1 < m and ek[order[j + 1]] == ek[order[i]]:
            j += 1
        key = ek[order[i]]
        x, y = key // n, key % n
        if j - i >= 2:
            return False
        if j == i:
            # must close a face (q, x, y) of δ𝒮
            found = False
            for f in range(nb):
                a, b, c = bf[f, 0], bf[f, 1], bf[f, 2]
                if (a == q or b == q or c == q) and (a == x or b == x or c == x):
                    if a == y or b == y or c == y:
                        found = True
                        break
            if not found:
                return False
            once += 1
        else:
            if ed[order[i]] == ed[order[j]]:
                return False
            for f in range(nb):
                a, b, c = bf[f, 0], bf[f, 1], bf[f, 2]
                if (a == q or b == q or c == q) and (a == x or b == x or c == x):
                    if a == y or b == y or c == y:
                        return False
            s = head[q]
            while s >= 0:
                t = s // 4
                if tmark[t] != stamp and holds(T, t, x) and holds(T, t, y):
                    return False
                s = nxt[s]
        i = j + 1
    return once == withq


@njit(cache=True, inline="always")
def _better_n(na, sa, qa, nb, sb, qb, tie, gain):
    """(8.1) then (8.2) with the count of non-positive tets: fewer first, then Sur, then quality."""
    if (na == 0) != (nb == 0):
        return na == 0
    if na > 0:
        if sa < sb - tie:
            return True
        if sa > sb + tie:
            return False
        if na != nb:
            return na < nb
    return qa > qb + gain


@njit(cache=True)
def _fan_measure(P, bf, nb, q, measure, flat):
    """(non-positive count, Sur, worst quality) of Op(q, δ𝒮)."""
    nn = 0
    s_ = 0.0
    qmin = 2.0
    for f in range(nb):
        a, b, c = bf[f, 0], bf[f, 1], bf[f, 2]
        if a == q or b == q or c == q:
            continue
        if not solid(P, q, a, b, c, flat):
            nn += 1
        vol, qq = _vol_q(P, q, a, b, c, measure)
        s_ += vol
        qmin = min(qmin, qq)
    return nn, s_, qmin


@njit(cache=True)
def _kernel_point(P, bf, nb, g):
    """Put in row g a point meant inside every face of δ𝒮 (outward), by relaxation.

    Each step pushes the point past the face that sees it worst, to 5 % of
    the mean radius inside (Agmon-Motzkin); after 100 steps the last point
    is kept and the exact signs of Op(G, δ𝒮) decide. False: a flat face.
    The point is worked out relative to a vertex o of δ𝒮 (its rounding is then
    that of the coordinates, wherever the input lies).
    """
    o = bf[0, 0]
    ox, oy, oz = P[o, 0], P[o, 1], P[o, 2]
    x = y = z = 0.0
    h = 0.0
    for f in range(nb):
        for e in range(3):
            x += P[bf[f, e], 0] - ox
            y += P[bf[f, e], 1] - oy
            z += P[bf[f, e], 2] - oz
    x /= 3 * nb
    y /= 3 * nb
    z /= 3 * nb
    for f in range(nb):
        a = bf[f, 0]
        h += math.sqrt((P[a, 0] - ox - x) ** 2 + (P[a, 1] - oy - y) ** 2 + (P[a, 2] - oz - z) ** 2)
    h /= nb
    for _ in range(100):
        worst = np.inf
        w0 = w1 = w2 = 0.0
        for f in range(nb):
            a, b, c = bf[f, 0], bf[f, 1], bf[f, 2]
            n0, n1, n2 = face_cross(P, a, b, c)
            nn = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
            if nn == 0.0:
                return False
            n0, n1, n2 = -n0 / nn, -n1 / nn, -n2 / nn
            d = (x - (P[a, 0] - ox)) * n0 + (y - (P[a, 1] - oy)) * n1 + (z - (P[a, 2] - oz)) * n2
            if d < worst:
                worst, w0, w1, w2 = d, n0, n1, n2
        if worst >= 0.05 * h:
            P[g, 0], P[g, 1], P[g, 2] = ox + x, oy + y, oz + z
            return True
        step = 0.05 * h - worst
        x += step * w0
        y += step * w1
        z += step * w2
    P[g, 0], P[g, 1], P[g, 2] = ox + x, oy + y, oz + z  # short of the margin: signs decide
    return True


@njit(cache=True)
def _try_fans(
    P,
    T,
    alive,
    head,
    nxt,
    prv,
    freeT,
    cnt,
    fixed,
    st,
    k,
    tmark,
    vmark,
    bf,
    allow_remove,
    insert,
    measure,
    tie_rel,
    gain,
    flat,
    dirty,
    counters,
):
    """Replace 𝒮 = st[:k] by its best Op(q, δ𝒮) when it beats 𝒮; 1, 0, or 2 (out of room).

    q runs over the vertices of δ𝒮 and, with ``insert`` while no fan is
    positive, a new point G in row ``cnt[N_PTS]``: ``insert`` 1, the kernel
    point found by relaxation from the centroid of δ𝒮's vertices; 2, the
    point already written there (𝒮 a star cavity of it, :func:`star_cavity`,
    whose free inner vertices may vanish: only inserted points are free in
    generation).
    """
    n = cnt[N_PTS]
    stamp = cnt[STAMP]
    nb = boundary(T, st, k, n, bf)
    if nb == 0:
        # 𝒮 is closed (a pillow of tets glued face to face, signed volume zero): Op(q, ∅) is
        # empty, Sur drops by Sur(𝒮) and the rest keeps its faces
        _remove_set(T, alive, head, nxt, prv, freeT, cnt, st, k, dirty)
        counters[C_CLOSED] += 1
        return 1
    if nb < 4:
        return 0
    # a vertex of 𝒮 off δ𝒮 whose whole ball is 𝒮 vanishes with a fan: only a free one may;
    # one with tets outside 𝒮 (a pinched vertex: a closed part of its ball is in 𝒮) stays
    cnt[STAMP] += 1
    vst = cnt[STAMP]
    for i in range(nb):
        for e in range(3):
            vmark[bf[i, e]] = vst
    for i in range(k):
        for j in range(4):
            w = T[st[i], j]
            if vmark[w] != vst:
                whole = True
                s = head[w]
                while s >= 0:
                    if tmark[s // 4] != stamp:
                        whole = False
                        break
                    s = nxt[s]
                if whole and (not (allow_remove or insert == 2) or fixed[w]):
                    return 0
    cur_n = 0
    cur_s = 0.0
    cur_q = 2.0
    for i in range(k):
        t = st[i]
        a, b, c, d = T[t, 0], T[t, 1], T[t, 2], T[t, 3]
        if not solid(P, a, b, c, d, flat):
            cur_n += 1
        vol, qq = _vol_q(P, a, b, c, d, measure)
        cur_s += vol
        cur_q = min(cur_q, qq)
    tie = _tie(P, T, st, k, tie_rel, cur_s, flat)
    best = _NONE
    bn, bs, bq = cur_n, cur_s, cur_q
    cnt[STAMP] += 1
    qst = cnt[STAMP]
    for i in range(nb):
        for e in range(3):
            q = bf[i, e]
            if vmark[q] == qst:
                continue
            vmark[q] = qst
            nn, s_, qmin = _fan_measure(P, bf, nb, q, measure, flat)
            if _better_n(nn, s_, qmin, bn, bs, bq, tie, gain) and _fan_valid(
                T, head, nxt, bf, nb, q, n + 1, tmark, stamp
            ):
                best, bn, bs, bq = q, nn, s_, qmin
    if insert == 2 or (insert and bn > 0):
        g = cnt[N_PTS]
        if g >= P.shape[0]:
            return 2
        if insert == 2 or _kernel_point(P, bf, nb, g):
            nn, s_, qmin = _fan_measure(P, bf, nb, g, measure, flat)
            if _better_n(nn, s_, qmin, bn, bs, bq, tie, gain) and _fan_valid(
                T, head, nxt, bf, nb, g, n + 1, tmark, stamp
            ):
                best, bn, bs, bq = g, nn, s_, qmin
    if best < 0:
        return 0
    if best == cnt[N_PTS]:
        cnt[N_PTS] += 1
        fixed[best] = 0
        counters[C_INSERT] += 1
    new = 0
    for f in range(nb):
        if not (bf[f, 0] == best or bf[f, 1] == best or bf[f, 2] == best):
            new += 1
    if not room(T, cnt, new - k):
        return 2
    _remove_set(T, alive, head, nxt, prv, freeT, cnt, st, k, dirty)
    for f in range(nb):
        a, b, c = bf[f, 0], bf[f, 1], bf[f, 2]
        if not (a == best or b == best or c == best):
            add_tet(T, alive, head, nxt, prv, freeT, cnt, best, a, b, c)
    dirty[best] = 1
    return 1


@njit(cache=True)
def _grow_tets(T, head, nxt, st, k, tmark, stamp, size):
    """Grow st[:k] across faces (breadth first) to ``size`` tets; the new count."""
    i = 0
    while i < k and k < size:
        t = st[i]
        for j in range(4):
            f = FACE[j]
            a, b, c = T[t, f[0]], T[t, f[1]], T[t, f[2]]
            s = head[a]
            while s >= 0 and k < size:
                u = s // 4
                if tmark[u] != stamp and holds(T, u, b) and holds(T, u, c):
                    tmark[u] = stamp
                    st[k] = u
                    k += 1
                s = nxt[s]
        i += 1
    return k


#: Vertices Z tried around a non-positive tet for Op(Z, δ𝒮), 𝒮 the star cavity of Z
#: (:func:`_nearby_vertices`): without insertion, the existing points that may see it.
VERTS = 128


@njit(cache=True)
def _nearby_vertices(T, head, nxt, t, st, tmark, vmark, cnt, cand):
    """The first ``VERTS`` vertices (not of tet t) met growing t's face-connected set to
    ``SMAX`` tets, breadth first, in ``cand``; their count."""
    cnt[STAMP] += 1
    k = _grow_tets(T, head, nxt, st, _ONE, tmark, cnt[STAMP], _SMAX)
    cnt[STAMP] += 1
    vst = cnt[STAMP]
    for j in range(4):
        vmark[T[t, j]] = vst
    nc = 0
    for i in range(1, k):
        for j in range(4):
            w = T[st[i], j]
            if vmark[w] != vst and nc < VERTS:
                vmark[w] = vst
                cand[nc] = w
                nc += 1
    return nc


#: Longest ring of an edge removal (:func:`_try_removal`); longer shells are skipped.
RING_MAX = 32


@njit(cache=True)
def _parity(T, t, a, b, x, y):
    """True when (a, b, x, y) is an even permutation of the row T[t]."""
    p = np.empty(4, np.int64)
    for j in range(4):
        w = T[t, j]
        p[j] = 0 if w == a else (1 if w == b else (2 if w == x else 3))
    inv = 0
    for i in range(4):
        for j in range(i + 1, 4):
            if p[i] > p[j]:
                inv += 1
    return inv % 2 == 0


@njit(cache=True)
def _ring(T, st, k, a, b, ring):
    """The ring of the shell st[:k] of edge (a, b) in ``ring``: every (a, b, r_i, r_i+1) an
    even permutation of its tet; its length, or -1 when it is not one simple closed cycle
    (an edge on the boundary, a pinched shell) or is longer than ``RING_MAX``."""
    if k < 3 or k > RING_MAX:
        return -1
    ex = np.empty(k, np.int64)
    ey = np.empty(k, np.int64)
    for i in range(k):
        t = st[i]
        x = y = -1
        for j in range(4):
            w = T[t, j]
            if w != a and w != b:
                if x < 0:
                    x = w
                else:
                    y = w
        if _parity(T, t, a, b, x, y):
            ex[i], ey[i] = x, y
        else:
            ex[i], ey[i] = y, x
    ring[0] = ex[0]
    for m in range(1, k + 1):
        nxt_v = -1
        for i in range(k):
            if ex[i] == ring[m - 1]:
                if nxt_v >= 0:
                    return -1
                nxt_v = ey[i]
        if nxt_v < 0:
            return -1
        if m == k:
            return k if nxt_v == ring[0] else -1
        for i in range(m):
            if ring[i] == nxt_v:
                return -1
        ring[m] = nxt_v
    return -1


@njit(cache=True)
def _try_removal(
    P, T, alive, head, nxt, prv, freeT, cnt, st, k, a, b, measure, gain, flat, dirty, counters
):
    """Edge removal: the shell st[:k] of edge (a, b) replaced by its best triangulated ring.

    Each triangle (r_i, r_k, r_j) of a triangulation of the ring makes the tets
    (a, r_i, r_k, r_j) and (b, r_j, r_k, r_i): the composition of Op on face
    pairs of the shell (each a 2-3 move taking one ear of the ring) ending with
    Op on a 3-tet shell, the sub-topologies §8.3.4 names. Among the
    triangulations (dynamic programming over the ring, Klincsek's) whose tets
    are all positive (exact) and create no edge or face already in the mesh
    (§8.3.3), the one of best worst quality (8.2); taken when the shell holds a
    non-positive tet (Sur cannot rise: all positive is the least) or its worst
    quality rises by ``gain``. 1 replaced, 0 not, 2 out of rows.
    """
    ring = np.empty(RING_MAX, np.int64)
    m = _ring(T, st, k, a, b, ring)
    if m < 0:
        return 0
    cur_n = 0
    cur_q = 2.0
    for i in range(k):
        t = st[i]
        if not solid(P, T[t, 0], T[t, 1], T[t, 2], T[t, 3], flat):
            cur_n += 1
        cur_q = min(cur_q, _vol_q(P, T[t, 0], T[t, 1], T[t, 2], T[t, 3], measure)[1])
    # edges among ring vertices already in the mesh (a diagonal must be new)
    edge = np.zeros((m, m), np.uint8)
    for i in range(m):
        s = head[ring[i]]
        while s >= 0:
            t = s // 4
            for j in range(4):
                w = T[t, j]
                for r in range(m):
                    if ring[r] == w:
                        edge[i, r] = 1
            s = nxt[s]
    best = np.full((m, m), -1.0)
    pick = np.full((m, m), -1, np.int64)
    for i in range(m - 1):
        best[i, i + 1] = 2.0
    for gap in range(2, m):
        for i in range(m - gap):
            j = i + gap
            if not (i == 0 and j == m - 1) and edge[i, j]:
                continue
            for c in range(i + 1, j):
                q = min(best[i, c], best[c, j])
                if q <= best[i, j]:
                    continue
                if gap == m - 1 and m == 3:
                    # the 3-2 move: the face (r0, r1, r2) must not exist outside
                    s = head[ring[0]]
                    found = False
                    while s >= 0:
                        t = s // 4
                        if holds(T, t, ring[1]) and holds(T, t, ring[2]):
                            found = True
                        s = nxt[s]
                    if found:
                        continue
                ri, rc, rj = ring[i], ring[c], ring[j]
                if not solid(P, a, ri, rc, rj, flat) or not solid(P, b, rj, rc, ri, flat):
                    continue
                q = min(q, _vol_q(P, a, ri, rc, rj, measure)[1])
                q = min(q, _vol_q(P, b, rj, rc, ri, measure)[1])
                if q > best[i, j]:
                    best[i, j] = q
                    pick[i, j] = c
    q = best[0, m - 1]
    if q < 0.0 or (cur_n == 0 and q <= cur_q + gain):
        return 0
    new = 2 * (m - 2)
    if not room(T, cnt, new - k):
        return 2
    _remove_set(T, alive, head, nxt, prv, freeT, cnt, st, k, dirty)
    stack = np.empty((m, 2), np.int64)
    stack[0, 0], stack[0, 1] = 0, m - 1
    top = 1
    while top > 0:
        top -= 1
        i, j = stack[top, 0], stack[top, 1]
        if j - i < 2:
            continue
        c = pick[i, j]
        add_tet(T, alive, head, nxt, prv, freeT, cnt, a, ring[i], ring[c], ring[j])
        add_tet(T, alive, head, nxt, prv, freeT, cnt, b, ring[j], ring[c], ring[i])
        stack[top, 0], stack[top, 1] = i, c
        stack[top + 1, 0], stack[top + 1, 1] = c, j
        top += 2
    counters[C_REMOVAL] += 1
    return 1


@njit(cache=True)
def _subtopology(T, head, nxt, kind, i, j, st, tmark, stamp):
    """The j-th sub-topology of item i in st; its size, or -1 (none, or past SMAX).

    ``BALL``: the ball of vertex i (j = 0); ``SHELL``: the shell of edge j of
    tet i; ``UNION``: tet i and its neighbour across face j (j < 4), the
    balls of the ends of edge j - 4 (j < 10), of its four vertices (j = 10),
    then a face-connected set of ``GROW[j - 11]`` tets. (:func:`fan_sweep`
    puts the edge removals of tet i's six edges after the face pairs.)
    """
    if kind == BALL:
        return gather(head, nxt, i, _NONE, T, st, tmark, stamp, _ZERO)
    if kind == SHELL:
        return gather(head, nxt, T[i, EDGES[j, 0]], T[i, EDGES[j, 1]], T, st, tmark, stamp, _ZERO)
    st[0] = i
    tmark[i] = stamp
    k = 1
    if j < 4:
        u = across(T, head, nxt, i, j)
        if u < 0:
            return -1
        tmark[u] = stamp
        st[1] = u
        return 2
    if j < 10:
        k = gather(head, nxt, T[i, EDGES[j - 4, 0]], _NONE, T, st, tmark, stamp, k)
        if k >= 0:
            k = gather(head, nxt, T[i, EDGES[j - 4, 1]], _NONE, T, st, tmark, stamp, k)
        return k
    if j == 10:
        for c in range(4):
            if k >= 0:
                k = gather(head, nxt, T[i, c], _NONE, T, st, tmark, stamp, k)
        return k
    return _grow_tets(T, head, nxt, st, _ONE, tmark, stamp, GROW[j - 11])


@njit(cache=True)
def fan_sweep(
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
    insert,
    measure,
    tie_rel,
    gain,
    flat,
    counters,
):
    """One pass of fans Op(q, δ𝒮) over sub-topologies of ``kind``; (replacements, status).

    ``BALL``: the ball of every vertex marked in ``todo`` (boundary vertices
    included); ``SHELL``: the shell of every edge of a tet with a marked
    vertex; ``UNION``: around every non-positive tet, sets of growing size
    (:func:`_subtopology`) until one is replaced; ``SLIVER``: the same sets
    around every positive tet of quality under ``SLIVER_Q`` (the third use,
    optimization: a set is replaced only when its worst quality rises).
    Status 2: out of rows (grow them and call again).
    """
    st = np.empty(SMAX, np.int64)
    tmark = np.zeros(T.shape[0], np.int64)
    vmark = np.zeros(P.shape[0], np.int64)
    bf = np.empty((4 * SMAX, 3), np.int64)
    cand = np.empty(VERTS, np.int64)
    nc = 0
    changed = 0
    items = cnt[N_PTS] if kind == BALL else cnt[N_ROWS]
    # UNION items: face pairs, edge removals, sets of _subtopology, vertex cavities, stars
    j_sets, j_verts = 10, 17 + len(GROW)
    j_stars = j_verts + VERTS
    per_item = 1 if kind == BALL else (6 if kind == SHELL else j_stars + STARS)
    if kind == SLIVER:
        kind_sets = UNION
    else:
        kind_sets = kind
    mode = 1 if insert else 0
    for i in range(items):
        a, b, c = -1, -1, -1
        if kind == BALL:
            if not todo[i] or head[i] < 0:
                continue
            todo[i] = 0
        elif not alive[i]:
            continue
        elif kind == SHELL:
            if not (todo[T[i, 0]] or todo[T[i, 1]] or todo[T[i, 2]] or todo[T[i, 3]]):
                continue
        else:
            a, b, c = T[i, 0], T[i, 1], T[i, 2]
            if solid(P, a, b, c, T[i, 3], flat) != (kind == SLIVER):
                continue
            qi = _vol_q(P, a, b, c, T[i, 3], measure)[1] if kind == SLIVER else 0.0
            if qi >= SLIVER_Q:
                continue
        for j in range(per_item):
            if kind != BALL and not alive[i]:
                break
            if kind >= UNION and (T[i, 0] != a or T[i, 1] != b or T[i, 2] != c):
                break
            if kind == SLIVER and j_sets <= j < (j_stars if qi >= FLAT_Q else j_verts):
                continue  # around a sliver: face pairs, edge removals, (vertex) star cavities
            cnt[STAMP] += 1
            m = mode
            if kind >= UNION and 4 <= j < 10:
                # edge removal on the shell of tet i's edge j - 4
                ea, eb = T[i, EDGES[j - 4, 0]], T[i, EDGES[j - 4, 1]]
                k = gather(head, nxt, ea, eb, T, st, tmark, cnt[STAMP], _ZERO)
                if k < 0:
                    continue
                r = _try_removal(
                    P, T, alive, head, nxt, prv, freeT, cnt, st, k, ea, eb, measure, gain,
                    flat, dirty, counters,
                )  # fmt: skip
            else:
                if kind >= UNION and j >= j_stars:
                    # star cavities of a new point G: tet i's centroid, or a positive
                    # neighbour's
                    if not insert:
                        break
                    g = cnt[N_PTS]
                    if g >= P.shape[0]:
                        return changed, 2
                    if not star_point(P, T, head, nxt, i, j - j_stars, g):
                        continue
                    k = star_cavity(P, T, head, nxt, i, g, st, tmark, cnt[STAMP], flat)
                    m = 2
                elif kind >= UNION and j >= j_verts:
                    # the star cavity of an existing vertex Z near tet i: Op(Z, δ𝒮) positive
                    if j == j_verts:
                        nc = _nearby_vertices(T, head, nxt, i, st, tmark, vmark, cnt, cand)
                    if j - j_verts >= nc:
                        continue
                    cnt[STAMP] += 1
                    k = star_cavity(
                        P, T, head, nxt, i, cand[j - j_verts], st, tmark, cnt[STAMP], flat
                    )
                else:
                    jj = j if kind < UNION or j < 4 else j - 6
                    k = _subtopology(T, head, nxt, kind_sets, i, jj, st, tmark, cnt[STAMP])
                if k < 0:
                    continue
                r = _try_fans(
                    P, T, alive, head, nxt, prv, freeT, cnt, fixed, st, k, tmark, vmark, bf,
                    allow_remove, m, measure, tie_rel, gain, flat, dirty, counters,
                )  # fmt: skip
            if r == 2:
                if kind == BALL:
                    todo[i] = 1
                return changed, 2
            if r == 1:
                if not (kind >= UNION and 4 <= j < 10):
                    counters[C_BALL_FAN + kind] += 1
                changed += 1
                if kind >= UNION:
                    break
    return changed, 0


@njit(cache=True)
def insert_midpoints(P, T, alive, head, nxt, prv, freeT, cnt, fixed, edges, flat):
    """Op(M, δ𝒮) for 𝒮 the shell of each interior edge ``edges[i]``, M its midpoint.

    In order, skipping an edge with a vertex touched in this call, one on the
    boundary (a face of δ𝒮 holds both ends) and one whose new tets would not
    all be positive (exact). Returns the points added; -1 when out of rows
    or points before the first.
    """
    touched = np.zeros(P.shape[0], np.uint8)
    st = np.empty(SMAX, np.int64)
    tmark = np.zeros(T.shape[0], np.int64)
    bf = np.empty((4 * SMAX, 3), np.int64)
    added = 0
    for i in range(edges.shape[0]):
        a, b = edges[i, 0], edges[i, 1]
        if touched[a] or touched[b]:
            continue
        cnt[STAMP] += 1
        k = gather(head, nxt, a, b, T, st, tmark, cnt[STAMP], _ZERO)
        if k <= 0:
            continue
        n = cnt[N_PTS]
        nb = boundary(T, st, k, n + 1, bf)
        if nb < 4:
            continue
        inner = True
        for f in range(nb):
            ha = bf[f, 0] == a or bf[f, 1] == a or bf[f, 2] == a
            hb = bf[f, 0] == b or bf[f, 1] == b or bf[f, 2] == b
            if ha and hb:
                inner = False
        if not inner:
            continue
        if not room(T, cnt, nb - k) or n >= P.shape[0]:
            return -1 if added == 0 else added
        for x in range(3):
            P[n, x] = 0.5 * (P[a, x] + P[b, x])
        ok = True
        for f in range(nb):
            if not solid(P, n, bf[f, 0], bf[f, 1], bf[f, 2], flat):
                ok = False
                break
        if not ok:
            continue
        cnt[N_PTS] += 1
        fixed[n] = 0
        _remove_set(T, alive, head, nxt, prv, freeT, cnt, st, k, touched)
        for f in range(nb):
            add_tet(T, alive, head, nxt, prv, freeT, cnt, n, bf[f, 0], bf[f, 1], bf[f, 2])
        added += 1
    return added
