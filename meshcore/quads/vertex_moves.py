r"""Compiled per-vertex loops of :mod:`meshcore.quads.optimization` (planar meshes).

The smoothing passes and the lift's pattern search of a planar mesh under
(8.4) without a metric, and the helpers they share: the vertex -> cell
incidence, the greedy colouring, each cell's quality (8.4) (or a triangle's
shape ratio) and its exact convexity. Each is a sequential loop over a few
cells per vertex, where a vectorized call costs more than the cells
(:mod:`meshcore.quads.optimization`, module docstring: the rules they apply).

References
----------
Methods text §8.4.3 (smoothing), §8.4.4 ((8.4)).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from meshcore.geometry.predicates import WORK_SIZE, orient2d_filtered
from meshcore.partition.smoothing import quad_q


@njit(cache=True)
def _incidence(C, alive, n):
    """CSR vertex -> alive cells: ``(ptr (n + 1,), cells)``, each vertex's cells in
    increasing order (a counting sort, compiled)."""
    ptr = np.zeros(n + 1, np.int64)
    for r in range(C.shape[0]):
        if alive[r]:
            for s in range(4):
                if C[r, s] >= 0:
                    ptr[C[r, s] + 1] += 1
    for v in range(n):
        ptr[v + 1] += ptr[v]
    fill = ptr[:-1].copy()
    cells = np.empty(ptr[n], np.int64)
    for r in range(C.shape[0]):
        if alive[r]:
            for s in range(4):
                v = C[r, s]
                if v >= 0:
                    cells[fill[v]] = r
                    fill[v] += 1
    return ptr, cells


@njit(cache=True)
def _angle_quality_rows(P, C):
    """:func:`_angle_quality` of every row (planar, no metric)."""
    q = np.empty(C.shape[0])
    for r in range(C.shape[0]):
        q[r] = _angle_quality(P, C, r)
    return q


@njit(cache=True)
def _valid_planar(P, C):
    """Rows of C (planar) whose every corner turns counter-clockwise, by the exact orient2d.

    A compiled loop over the rows: the vectorized predicate's per-call
    checks and gathers cost more than the signs at the sizes smoothing asks.
    """
    k = C.shape[0]
    ok = np.ones(k, np.bool_)
    work = np.empty(WORK_SIZE)
    for r in range(k):
        ok[r] = _row_valid(P, C, r, work)
    return ok


@njit(cache=True)
def _colors(C, ptr, cells, movable):
    """Greedy colouring of the movable vertices: two vertices of one cell never share a colour.

    A sequential loop (each colour depends on those of the neighbours before).
    """
    n = ptr.shape[0] - 1
    color = np.full(n, -1, np.int64)
    seen = np.full(64, -1, np.int64)
    for v in range(n):
        if not movable[v]:
            continue
        for j in range(ptr[v], ptr[v + 1]):
            c = cells[j]
            for s in range(4):
                u = C[c, s]
                if u >= 0 and color[u] >= 0 and color[u] < 64:
                    seen[color[u]] = v
        k = 0
        while k < 64 and seen[k] == v:
            k += 1
        color[v] = k
    return color


@njit(cache=True)
def _lift_round(P, C, q, order, ptr, cells, dirs, steps, gain, moved, dirty):
    """One round of :func:`_op_lift` over ``order`` (sorted by colour), planar, (8.4).

    Sequential: a vertex's cells hold no other vertex of its colour, so this
    is the colour-at-once search of the vectorized path. Only ``dirty``
    vertices are searched: a vertex searched without a move stays where it is
    until a vertex of its cells moves (the search would find the same), so a
    move marks the vertices of the mover's cells. Returns whether a vertex moved.
    """
    work = np.empty(WORK_SIZE)
    any_move = False
    for i in range(order.shape[0]):
        v = order[i]
        if not dirty[v]:
            continue
        dirty[v] = False
        hx, hy = P[v, 0], P[v, 1]
        cur = np.inf
        dist = 0.0
        cnt = 0
        for j in range(ptr[v], ptr[v + 1]):
            c = cells[j]
            cur = min(cur, q[c])
            nv = 4 if C[c, 3] >= 0 else 3
            d = 0.0
            for s in range(nv):
                u = C[c, s]
                d += math.sqrt((P[u, 0] - hx) ** 2 + (P[u, 1] - hy) ** 2)
            dist += d
            cnt += nv - 1
        h = dist / max(cnt, 1)
        best, bx, by = cur, hx, hy
        for t in range(steps.shape[0]):  # in order: the first clear best wins
            P[v, 0] = hx + steps[t] * h * dirs[t, 0]
            P[v, 1] = hy + steps[t] * h * dirs[t, 1]
            least = np.inf
            for j in range(ptr[v], ptr[v + 1]):  # stops at the first cell that rules it out
                least = min(least, _checked_quality(P, C, cells[j], work))
                if not least > best + gain:
                    break
            if least > best + gain:
                best, bx, by = least, P[v, 0], P[v, 1]
        if best > cur + gain:
            P[v, 0], P[v, 1] = bx, by
            for j in range(ptr[v], ptr[v + 1]):
                c = cells[j]
                q[c] = _angle_quality(P, C, c)
                for s in range(4):
                    if C[c, s] >= 0:
                        dirty[C[c, s]] = True
            moved[v] = True
            any_move = True
        else:
            P[v, 0], P[v, 1] = hx, hy
    return any_move


@njit(cache=True)
def _angle_quality(P, C, c):
    """(8.4) of a quad row, or the shape ratio of a triangle row, as :mod:`meshcore.mesh.quality`.

    The same operations as ``quality.quad_quality`` and
    ``quality.triangle_shape`` (no metric), for one planar cell: the
    compiled smoothing asks for a few cells at a time.
    """
    if C[c, 3] < 0:
        a, b, d = C[c, 0], C[c, 1], C[c, 2]
        e0x, e0y = P[b, 0] - P[a, 0], P[b, 1] - P[a, 1]
        e1x, e1y = P[d, 0] - P[b, 0], P[d, 1] - P[b, 1]
        e2x, e2y = P[a, 0] - P[d, 0], P[a, 1] - P[d, 1]
        den = (e0x * e0x + e0y * e0y) + (e1x * e1x + e1y * e1y) + (e2x * e2x + e2y * e2y)
        area = 0.5 * (e2x * e0y - e2y * e0x)
        return (4 * math.sqrt(3.0)) * area / den if den > 0 else 0.0
    return quad_q(P, C, c)


@njit(cache=True)
def _smooth_pass(P, C, q, order, active, nptr, nidx, ptr, cells, floor, still, kept, moved_now):
    """One smoothing pass (colour by colour, ``order`` sorted by colour), planar, (8.4).

    A sequential loop over the vertices: within a colour no two share a
    cell nor an edge, so the result is that of moving the colour at once.
    A vertex moves to the mean of its edge neighbours unless one of its
    cells turns invalid (exact orient2d) or drops below
    ``min(floor, its cells' least quality)``.
    """
    work = np.empty(WORK_SIZE)
    newq = np.empty(64)
    for i in range(order.shape[0]):
        v = order[i]
        nc = ptr[v + 1] - ptr[v]
        if not active[v] or nc > 64:
            continue
        k0, k1 = nptr[v], nptr[v + 1]
        tx = 0.0
        ty = 0.0
        for j in range(k0, k1):
            tx += P[nidx[j], 0]
            ty += P[nidx[j], 1]
        tx /= k1 - k0
        ty /= k1 - k0
        omin = np.inf
        for j in range(nc):
            omin = min(omin, q[cells[ptr[v] + j]])
        need = min(omin, floor)
        hx, hy = P[v, 0], P[v, 1]
        P[v, 0] = tx
        P[v, 1] = ty
        ok = True
        for j in range(nc):  # stops at the first cell that refuses the move
            newq[j] = _checked_quality(P, C, cells[ptr[v] + j], work)
            if not newq[j] >= need:
                ok = False
                break
        if not ok:
            P[v, 0] = hx
            P[v, 1] = hy
            continue
        for j in range(nc):
            q[cells[ptr[v] + j]] = newq[j]
        kept[v] = True
        u = nidx[k0]
        step = math.sqrt((tx - hx) ** 2 + (ty - hy) ** 2)
        far = math.sqrt((P[u, 0] - hx) ** 2 + (P[u, 1] - hy) ** 2)
        if step > still * far:
            moved_now[v] = True


@njit(cache=True)
def _smooth_passes(P, C, q, live, order, movable, csr, passes, tol, moved):
    """Up to ``passes`` of :func:`_smooth_pass` as :func:`_op_smooth` runs them: a pass
    is undone and ends the smoothing unless the mean quality of the ``live`` cells
    rises; then only the vertices that moved and their neighbours are tried. ``tol``:
    ``smooth_floor``, ``smooth_still``, ``smooth_gain``."""
    nptr, nidx, ptr, cells = csr
    floor0, still, gain = tol
    n = P.shape[0]
    active = movable.copy()
    kept = np.zeros(n, np.bool_)
    moved_now = np.zeros(n, np.bool_)
    for _ in range(passes):
        P0, q0 = P.copy(), q.copy()
        mean0 = q[live].mean()
        floor = max(q[live].min(), floor0)
        kept[:] = False
        moved_now[:] = False
        _smooth_pass(P, C, q, order, active, nptr, nidx, ptr, cells, floor, still, kept, moved_now)
        if not q[live].mean() > mean0 + gain:
            P[:] = P0
            q[:] = q0
            return
        moved |= kept
        if not moved_now.any():
            return
        active[:] = moved_now
        for v in np.flatnonzero(moved_now):
            for j in range(nptr[v], nptr[v + 1]):
                active[nidx[j]] = True
        active &= movable


@njit(cache=True)
def _checked_quality(P, C, c, work):
    """:func:`_angle_quality` of row c, -inf unless it is strictly convex (exact).

    Above 1e-6 the quality proves it: every corner's sine is then above 1e-6,
    so each corner's floating-point determinant exceeds the error bound of
    ``orient2d_filtered`` many times over, and the predicate would return its
    sign unchanged; below, the predicate decides.
    """
    q = _angle_quality(P, C, c)
    if q > 1e-6 or _row_valid(P, C, c, work):
        return q
    return -np.inf


@njit(cache=True)
def _row_valid(P, C, r, work):
    nv = 4 if C[r, 3] >= 0 else 3
    for i in range(nv if nv == 4 else 1):
        a = C[r, (i + nv - 1) % nv]
        b = C[r, i]
        c = C[r, (i + 1) % nv]
        if orient2d_filtered(P[a, 0], P[a, 1], P[b, 0], P[b, 1], P[c, 0], P[c, 1], work) <= 0:
            return False
    return True


@njit(cache=True)
def _split_rows(H):
    """The three two-quad splits of each hexagon ``H`` (k, 6): rows ``6 i + 2 s`` and
    ``6 i + 2 s + 1`` are split ``s`` of hexagon ``i``, along its diagonal from ``H[i, s]``
    to ``H[i, s + 3]``."""
    k = H.shape[0]
    rows = np.empty((6 * k, 4), np.int64)
    for i in range(k):
        for s in range(3):
            for j in range(4):
                rows[6 * i + 2 * s, j] = H[i, (s + j) % 6]
                rows[6 * i + 2 * s + 1, j] = H[i, (s + 3 + j) % 6]
    return rows


@njit(cache=True)
def _split_scores(C, sets, H, q, valid, keys, n, ptr, ideal, cq, floor):
    """The best split of each hexagon by the topological criterion of
    :func:`meshcore.quads.optimization._hex_splits`: (split index (k,), score (k,)).

    ``q``, ``valid``: quality and validity of the rows of :func:`_split_rows`; ``keys``
    the mesh's sorted unique edge keys ``min * n + max`` (a split whose diagonal is an
    edge already is not valid); ``ptr`` the vertex -> cell CSR (valences), ``ideal``
    the ideal valences, ``cq`` the cells' qualities, ``floor`` the least quality a split
    may leave (:func:`meshcore.quads.optimization._floor`). A split is kept when it does
    not raise ``sum |valence - ideal|`` over the hexagon (its removed interior vertices
    counting 1 each), stays above ``min(floor, old least)``, and lowers that sum or
    raises the least quality; its score is the drop of the sum plus the rise of the
    least quality, -inf if not kept.
    """
    k = H.shape[0]
    best = np.zeros(k, np.int64)
    gain = np.empty(k)
    held = np.zeros(6, np.int64)
    nk = keys.shape[0]
    for i in range(k):
        old = np.inf
        for a in range(sets.shape[1]):
            c = sets[i, a]
            if c >= 0:
                old = min(old, cq[c])
        # how many of the set's cells hold each hexagon vertex
        total = 0
        dev_old = 0
        for j in range(6):
            v = H[i, j]
            held[j] = 0
            for a in range(sets.shape[1]):
                c = sets[i, a]
                for s in range(4 if c >= 0 else 0):
                    if C[c, s] == v:
                        held[j] += 1
                        break
            total += held[j]
            dev_old += abs(ptr[v + 1] - ptr[v] - ideal[v])
        # interior vertices of the set (not on the hexagon) disappear with it, each
        # held by 3 of the cells: |3 - 4| each
        dev_old += max(4 * sets.shape[1] - total, 0) // 3
        low = min(old, floor)
        bs = -np.inf
        for s in range(3):
            r0, r1 = 6 * i + 2 * s, 6 * i + 2 * s + 1
            d0, d1 = H[i, s], H[i, s + 3]
            key = min(d0, d1) * n + max(d0, d1)
            at = np.searchsorted(keys, key)
            exists = nk > 0 and keys[min(at, nk - 1)] == key
            qs = min(q[r0], q[r1])
            dev_new = 0
            for j in range(6):
                v = H[i, j]
                newc = 2 if j == s or j == s + 3 else 1
                dev_new += abs(ptr[v + 1] - ptr[v] - held[j] + newc - ideal[v])
            dev = float(dev_old - dev_new)
            score = -np.inf
            if valid[r0] and valid[r1] and not exists and dev >= 0 and qs >= low:
                if dev > 0 or qs > old:
                    score = dev + (qs - old)
            if score > bs:
                bs = score
                best[i] = s
        gain[i] = bs
    return best, gain
