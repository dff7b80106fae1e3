r"""Compiled per-vertex loops of :mod:`meshcore.quads.optimization` (planar meshes).

The smoothing passes and the lift's pattern search of a planar mesh under
(8.4) without a metric, and the helpers they share: the vertex -> cell
incidence, the greedy colouring, each cell's quality (8.4) (or a triangle's
shape ratio) and its exact convexity. Each is a sequential loop over a few
cells per vertex, where a vectorized call costs more than the cells
(:mod:`meshcore.quads.optimization`, module docstring: the rules they apply).
And the tables and candidate loops of the operator sweeps (any mesh): the edge
table and the vertex neighbours, the swap pairs, a hexagon's splits with their
topological criterion and their scores, each one call where numpy took ten or
more small calls.

References
----------
Methods text §8.4.3 (smoothing), §8.4.4 ((8.4)).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from meshcore.geometry.ordering import radix_argsort
from meshcore.geometry.predicates import CONVEX_PROOF, WORK_SIZE, orient2d_filtered
from meshcore.partition.smoothing import boundary_points, quad_q

# :func:`_colors` gives colours 0 .. MOST_COLORS (a vertex whose neighbours hold all of
# 0 .. MOST_COLORS - 1 takes MOST_COLORS), so :func:`_smooth_order` counts MOST_COLORS + 1.
MOST_COLORS = 64


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
def _edge_table(C, alive, n):
    """The directed edges of the alive cells (a triangle being a row with -1 last), in
    row order: ``(a, b, sorted keys, their cells, unique keys, first edge of each)``.

    ``a[e] -> b[e]`` turns with its cell; the keys ``min * n + max`` sorted stably
    (:func:`~meshcore.geometry.ordering.radix_argsort`) with the cell of each, and the
    sorted unique keys with the index into ``a``/``b`` of each one's first edge (as
    :func:`~meshcore.mesh.topology.unique_ints`). One compiled call: rebuilt after
    every operator run that changes the cells."""
    m = 0
    for r in range(C.shape[0]):
        if alive[r]:
            m += 4 if C[r, 3] >= 0 else 3
    a = np.empty(m, np.int64)
    b = np.empty(m, np.int64)
    cell = np.empty(m, np.int64)
    key = np.empty(m, np.int64)
    e = 0
    for r in range(C.shape[0]):
        if not alive[r]:
            continue
        nv = 4 if C[r, 3] >= 0 else 3
        for s in range(nv):
            u, w = C[r, s], C[r, (s + 1) % nv]
            a[e], b[e], cell[e] = u, w, r
            key[e] = min(u, w) * n + max(u, w)
            e += 1
    order = radix_argsort(key)
    ks = key[order]
    nu = 0
    for i in range(m):
        if i == 0 or ks[i] != ks[i - 1]:
            nu += 1
    ukeys = np.empty(nu, np.int64)
    first = np.empty(nu, np.int64)
    nu = 0
    for i in range(m):
        if i == 0 or ks[i] != ks[i - 1]:
            ukeys[nu], first[nu] = ks[i], order[i]
            nu += 1
    return a, b, ks, cell[order], ukeys, first


@njit(cache=True)
def _neighbour_csr(a, b, first, n):
    """CSR vertex -> edge neighbours ``(nptr, nidx, degree)`` of the edges ``a[first]``,
    ``b[first]`` (each undirected edge once): the neighbours of a vertex in the order
    of the list of edges from it followed by that of the edges to it (a stable
    counting sort)."""
    deg = np.zeros(n, np.int64)
    for e in first:
        deg[a[e]] += 1
        deg[b[e]] += 1
    nptr = np.zeros(n + 1, np.int64)
    for v in range(n):
        nptr[v + 1] = nptr[v] + deg[v]
    fill = nptr[:-1].copy()
    nidx = np.empty(nptr[n], np.int64)
    for e in first:
        nidx[fill[a[e]]] = b[e]
        fill[a[e]] += 1
    for e in first:
        nidx[fill[b[e]]] = a[e]
        fill[b[e]] += 1
    return nptr, nidx, deg


@njit(cache=True)
def _angle_quality_rows(P, C):
    """:func:`_angle_quality` of every row (planar, no metric)."""
    q = np.empty(C.shape[0])
    for r in range(C.shape[0]):
        q[r] = _angle_quality(P, C, r)
    return q


@njit(cache=True)
def _checked_rows(P, C):
    """:func:`_angle_quality` of every row and whether it is strictly convex (a quality
    above ``CONVEX_PROOF`` proves it, else the exact signs of :func:`_row_valid`)."""
    k = C.shape[0]
    q = np.empty(k)
    ok = np.empty(k, np.bool_)
    work = np.empty(WORK_SIZE)
    for r in range(k):
        q[r] = _angle_quality(P, C, r)
        ok[r] = q[r] > CONVEX_PROOF or _row_valid(P, C, r, work)
    return q, ok


@njit(cache=True)
def _swap_pairs(C, alive, ks, cs, ptr, ideal, q, below, since, only_made):
    """The pairs of quads sharing an edge (``ks``, ``cs``: the sorted edge keys and
    their cells, :func:`_edge_table`) that :func:`meshcore.quads.optimization._op_swap`
    tries, in the order of the keys: those with a vertex whose valence (``ptr``) is not
    its ``ideal``, or whose least quality ``q`` is under ``below``. With ``since`` >= 0
    (a later sweep) a poor pair must hold a vertex of an alive cell from row ``since``
    on, and with ``only_made`` an irregular pair too."""
    dirty = np.zeros(ptr.shape[0] - 1, np.bool_)
    if since >= 0:
        for r in range(since, C.shape[0]):
            if alive[r]:
                for s in range(4):
                    if C[r, s] >= 0:
                        dirty[C[r, s]] = True
    out = np.empty((ks.shape[0], 2), np.int64)
    k = 0
    for i in range(ks.shape[0] - 1):
        c0, c1 = cs[i], cs[i + 1]
        if ks[i + 1] != ks[i] or C[c0, 3] < 0 or C[c1, 3] < 0 or c0 == c1:
            continue
        near = made = False
        for c in (c0, c1):
            for s in range(4):
                v = C[c, s]
                near |= ptr[v + 1] - ptr[v] != ideal[v]
                made |= dirty[v]
        poor = min(q[c0], q[c1]) < below
        if since >= 0:
            poor &= made
            if only_made:
                near &= made
        if near or poor:
            out[k, 0], out[k, 1] = c0, c1
            k += 1
    return out[:k]


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
    seen = np.full(MOST_COLORS, -1, np.int64)
    for v in range(n):
        if not movable[v]:
            continue
        for j in range(ptr[v], ptr[v + 1]):
            c = cells[j]
            for s in range(4):
                u = C[c, s]
                if u >= 0 and color[u] >= 0 and color[u] < MOST_COLORS:
                    seen[color[u]] = v
        k = 0
        while k < MOST_COLORS and seen[k] == v:
            k += 1
        color[v] = k
    return color


@njit(cache=True)
def _smooth_order(C, q, ptr, cells, interior, deg, below):
    """The vertices smoothing moves: ``(movable, colour, order)``. Movable: interior,
    with an edge (``deg``), and a cell of quality ``q`` under ``below``; coloured by
    :func:`_colors`; ``order``: the movable vertices by colour, increasing within each
    colour (a counting sort)."""
    n = ptr.shape[0] - 1
    movable = np.zeros(n, np.bool_)
    for v in range(n):
        if interior[v] and deg[v] > 0:
            for j in range(ptr[v], ptr[v + 1]):
                if q[cells[j]] < below:
                    movable[v] = True
                    break
    color = _colors(C, ptr, cells, movable)
    start = np.zeros(MOST_COLORS + 2, np.int64)
    for v in range(n):
        if color[v] >= 0:
            start[color[v] + 1] += 1
    for k in range(MOST_COLORS + 1):
        start[k + 1] += start[k]
    order = np.empty(start[MOST_COLORS + 1], np.int64)
    for v in range(n):
        if color[v] >= 0:
            order[start[color[v]]] = v
            start[color[v]] += 1
    return movable, color, order


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


@njit(cache=True, inline="always")
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


@njit(cache=True, inline="always")
def _checked_quality(P, C, c, work):
    """:func:`_angle_quality` of row c, -inf unless it is strictly convex (exact).

    Above ``CONVEX_PROOF`` the quality proves it; below, the predicate decides.
    """
    q = _angle_quality(P, C, c)
    if q > CONVEX_PROOF or _row_valid(P, C, c, work):
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
def _split_drops(C, sets, H, keys, n, ptr, ideal):
    """The three two-quad splits of each hexagon ``H`` (k, 6) (-1 rows: none) and the
    topological criterion of :func:`meshcore.quads.optimization._hex_splits` for each:
    ``(drop (k, 3), rows (6 k, 4))``, rows ``6 i + 2 s`` and ``6 i + 2 s + 1`` the split
    ``s`` of hexagon ``i`` along its diagonal from ``H[i, s]`` to ``H[i, s + 3]``.

    The drop of ``sum |valence - ideal|`` over the hexagon (the cell ``sets`` it
    replaces; its removed interior vertices counting 1 each), or -1 where the split is
    not allowed: no hexagon, its diagonal an edge already (``keys``: the mesh's sorted
    unique edge keys ``min * n + max``) or the sum would rise. ``ptr``: the vertex ->
    cell CSR (valences)."""
    k = H.shape[0]
    drop = np.full((k, 3), -1.0)
    rows = np.empty((6 * k, 4), np.int64)
    held = np.zeros(6, np.int64)
    nk = keys.shape[0]
    for i in range(k):
        for s in range(3):
            for j in range(4):
                rows[6 * i + 2 * s, j] = H[i, (s + j) % 6]
                rows[6 * i + 2 * s + 1, j] = H[i, (s + 3 + j) % 6]
        if H[i, 0] < 0:
            continue
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
        for s in range(3):
            d0, d1 = H[i, s], H[i, s + 3]
            key = min(d0, d1) * n + max(d0, d1)
            lo, hi = 0, nk  # the first key >= key (a binary search)
            while lo < hi:
                mid = (lo + hi) >> 1
                if keys[mid] < key:
                    lo = mid + 1
                else:
                    hi = mid
            if lo < nk and keys[lo] == key:
                continue
            dev_new = 0
            for j in range(6):
                v = H[i, j]
                newc = 2 if j == s or j == s + 3 else 1
                dev_new += abs(ptr[v + 1] - ptr[v] - held[j] + newc - ideal[v])
            if dev_old >= dev_new:
                drop[i, s] = float(dev_old - dev_new)
    return drop, rows


@njit(cache=True)
def _split_scores(sets, drop, q, valid, cq, floor):
    """The best split of each hexagon: (split index (k,), score (k,)).

    ``drop``: :func:`_split_drops`; ``q``, ``valid``: quality and validity of its rows
    (read only where the drop is at least 0); ``cq`` the cells'
    qualities, ``floor`` the least quality a split may leave
    (:func:`meshcore.quads.optimization._floor`). An allowed split is kept when it
    stays above ``min(floor, old least)`` and lowers the sum or raises the least
    quality; its score is the drop plus the rise of the least quality, -inf if not kept.
    """
    k = sets.shape[0]
    best = np.zeros(k, np.int64)
    gain = np.empty(k)
    for i in range(k):
        old = np.inf
        for a in range(sets.shape[1]):
            c = sets[i, a]
            if c >= 0:
                old = min(old, cq[c])
        low = min(old, floor)
        bs = -np.inf
        for s in range(3):
            r0, r1 = 6 * i + 2 * s, 6 * i + 2 * s + 1
            dev = drop[i, s]
            score = -np.inf
            if dev >= 0 and valid[r0] and valid[r1]:
                qs = min(q[r0], q[r1])
                if qs >= low and (dev > 0 or qs > old):
                    score = dev + (qs - old)
            if score > bs:
                bs = score
                best[i] = s
        gain[i] = bs
    return best, gain


# ----------------------------------------------------------------------------- the lift
#: Directions a free node tries in :func:`lift_corners`: at a corner where two angles
#: are the least, the moves raising both lie in a narrow cone that 8 directions missed.
LIFT_DIRECTIONS = 32
#: Sweeps of :func:`lift_corners` at most, and moves of one node in a sweep.
LIFT_SWEEPS = 8
#: Least rise of the least corner quality for a move (qualities are <= 1): far above
#: what a 1e6 translation does to a quality (~1e-9 at size 0.1).
LIFT_GAIN = 1e-6
#: Least fall of the summed squared shortfall for a move that keeps the least.
LIFT_SHORTFALL_GAIN = 1e-9
#: A corner quality within this of another is as high (qualities are <= 1): a node
#: sliding along a segment leaves its neighbour's corner there as it was, which rounding
#: put just under or over its floor, and the same move was made at the origin and not
#: at +1e6 (issue 20's star 9 with quad_medial at size 0.1: points 8.5e-3 of the extent
#: apart). Far above rounding at +1e6 (1e-9 of the normalized frame: ~1e-10).
LIFT_TIE = 1e-8


@njit(cache=True)
def _corner_at(P, C, c, k, v, x, y, work):
    """(8.3) of corner ``k`` of quad ``c`` with node ``v`` at ``(x, y)``; -1 unless it
    turns left (exact :func:`~meshcore.geometry.predicates.orient2d_filtered` where its
    sine is at most ``CONVEX_PROOF``, where the floating-point sign could be wrong)."""
    a, b, d = C[c, (k + 3) % 4], C[c, k], C[c, (k + 1) % 4]
    ax, ay = (x, y) if a == v else (P[a, 0], P[a, 1])
    bx, by = (x, y) if b == v else (P[b, 0], P[b, 1])
    dx, dy = (x, y) if d == v else (P[d, 0], P[d, 1])
    ux, uy, wx, wy = dx - bx, dy - by, ax - bx, ay - by
    cross = ux * wy - uy * wx
    norm = math.sqrt((ux * ux + uy * uy) * (wx * wx + wy * wy))
    if not norm > 0.0:
        return -1.0
    if cross <= CONVEX_PROOF * norm and (
        cross < -CONVEX_PROOF * norm or orient2d_filtered(bx, by, dx, dy, ax, ay, work) <= 0
    ):
        return -1.0
    t = math.atan2(max(cross, 0.0), ux * wx + uy * wy) / (0.5 * math.pi)
    return t if t <= 1.0 else 2.0 - t


@njit(cache=True)
def _quad_at(P, C, c, work):
    """(8.4) of quad ``c``: its least :func:`_corner_at`."""
    q = np.inf
    for k in range(4):
        q = min(q, _corner_at(P, C, c, k, -1, 0.0, 0.0, work))
    return q


@njit(cache=True)
def _slot(C, c, v):
    """The corner (0-3) of quad ``c`` at node ``v``."""
    k = 0
    while C[c, k] != v:
        k += 1
    return k


@njit(cache=True)
def _moved_at(P, C, ptr, cells, v, x, y, judged, floor, shortest, aim, work):
    """Node ``v`` at ``(x, y)``: the least (8.3) of the corners it moves in its judged
    quads (its own and its two neighbours' in each) and their summed squared shortfall
    under ``aim``; least -1 when a quad of ``v`` folds or falls under its ``floor``, or
    an edge at ``v`` is shorter than ``shortest``. (A quad's corner opposite ``v`` does
    not move and is at or above its floor, so its three moved corners decide.)"""
    worst = np.inf
    short = 0.0
    for j in range(ptr[v], ptr[v + 1]):
        c = cells[j]
        k = _slot(C, c, v)
        for s in (3, 1):
            w = C[c, (k + s) % 4]
            if math.hypot(P[w, 0] - x, P[w, 1] - y) < shortest:
                return -1.0, np.inf
        for s in (3, 0, 1):
            q = _corner_at(P, C, c, (k + s) % 4, v, x, y, work)
            if q < floor[c] - LIFT_TIE or q < 0.0:
                return -1.0, np.inf
            if judged[c]:
                worst = min(worst, q)
                short += max(aim - q, 0.0) ** 2
    return worst, short


@njit(cache=True)
def _lift_corners(P, C, mode, slide, judged, aim, keep):
    """The pattern search of :func:`lift_corners` on ``P`` in place, node by node
    (Gauss-Seidel); ``mode`` 0 fixed, 1 free (``LIFT_DIRECTIONS`` directions), 2 sliding
    along the unit vector ``slide[v]`` (2 directions). Returns the moves made."""
    n = P.shape[0]
    work = np.empty(WORK_SIZE)
    ptr, cells = _incidence(C, np.ones(C.shape[0], np.bool_), n)
    shortest = np.full(n, np.inf)
    mean = np.zeros(n)
    for v in range(n):
        for j in range(ptr[v], ptr[v + 1]):
            c = cells[j]
            k = _slot(C, c, v)
            for s in (3, 1):
                w = C[c, (k + s) % 4]
                e = math.hypot(P[w, 0] - P[v, 0], P[v, 1] - P[w, 1])
                shortest[v] = min(shortest[v], 0.5 * e)
                mean[v] += e
        mean[v] /= max(2 * (ptr[v + 1] - ptr[v]), 1)
    q = np.empty(C.shape[0])
    for c in range(C.shape[0]):
        q[c] = _quad_at(P, C, c, work)
    floor = np.where(judged, np.minimum(q, keep), q)
    dirs = np.empty((LIFT_DIRECTIONS, 2))
    for i in range(LIFT_DIRECTIONS):
        dirs[i, 0] = math.cos(2 * math.pi * i / LIFT_DIRECTIONS)
        dirs[i, 1] = math.sin(2 * math.pi * i / LIFT_DIRECTIONS)
    moves = 0
    for _ in range(LIFT_SWEEPS):
        moved = 0
        for v in range(n):
            if mode[v] == 0:
                continue
            cur, pen = _moved_at(
                P, C, ptr, cells, v, P[v, 0], P[v, 1], judged, floor, 0.0, aim, work
            )
            if pen == 0.0:
                continue
            for _step in range(LIFT_SWEEPS):  # as many moves of one node per sweep at most
                best, bpen, bx, by = cur, pen, P[v, 0], P[v, 1]
                step = 0.25 * mean[v]
                while step >= mean[v] / 64 and bx == P[v, 0] and by == P[v, 1]:
                    for i in range(LIFT_DIRECTIONS if mode[v] == 1 else 2):
                        ux = dirs[i, 0] if mode[v] == 1 else (1.0 - 2.0 * i) * slide[v, 0]
                        uy = dirs[i, 1] if mode[v] == 1 else (1.0 - 2.0 * i) * slide[v, 1]
                        x, y = P[v, 0] + step * ux, P[v, 1] + step * uy
                        got, gpen = _moved_at(
                            P, C, ptr, cells, v, x, y, judged, floor, shortest[v], aim, work
                        )
                        lower = gpen < bpen - LIFT_SHORTFALL_GAIN
                        if got > best + LIFT_GAIN or (got >= best - LIFT_TIE and lower):
                            best, bpen, bx, by = got, gpen, x, y
                    step *= 0.5
                if bx == P[v, 0] and by == P[v, 1]:
                    break
                P[v, 0], P[v, 1], cur, pen = bx, by, best, bpen
                for j in range(ptr[v], ptr[v + 1]):
                    c = cells[j]
                    qc = _quad_at(P, C, c, work)  # a floor falls by LIFT_TIE at most
                    floor[c] = max(floor[c], min(qc, keep) if judged[c] else qc)
                moved += 1
        moves += moved
        if moved == 0:
            break
    return moves


def lift_corners(
    points: np.ndarray,
    quads: np.ndarray,
    fixed: np.ndarray,
    slide: tuple[np.ndarray, np.ndarray, np.ndarray],
    judged: np.ndarray,
    below: float,
    keep: float = 0.0,
    border: np.ndarray | None = None,
) -> tuple[np.ndarray, int]:
    """The least corner quality (8.3) of the ``judged`` quads raised around those under
    ``below`` (§8.4.3: optimization-based smoothing of the worst corners).

    A pattern search, node by node: the nodes of the quads within two rings of the
    judged quads under ``below`` move, except the ``fixed`` ones; those in ``slide``
    (``node, a, b`` as :func:`meshcore.quads.optimization.sliding_nodes`) only along
    the line from ``a`` to ``b``, the other border nodes (``border``, the mesh's
    boundary nodes when the caller has them) not at all. A node tries
    steps of 1/4 down to 1/64 of its mean edge length (32 directions, or 2 along its
    line) and moves where the least quality of the corners it moves in judged quads
    rises (by :data:`LIFT_GAIN`), or stays and their summed squared shortfall under
    ``below`` falls (so that a neighbour of the worst corner makes room for it).

    Guarantees: every quad stays strictly convex (exact
    :func:`~meshcore.geometry.predicates.orient2d_filtered` wherever a corner's sine
    is under 1e-6); the least quality of the judged quads never falls; no other quad's
    quality (8.4) falls; no judged quad falls under ``min(its quality, keep)`` (each to
    :data:`LIFT_TIE`: a corner a move leaves as it was is taken as unchanged, not as
    rounding makes it, so that the moves do not change under a translation); no
    edge at a moved node gets shorter than half its shortest at the start. Run in a
    frame centred on the moving nodes and scaled by their mean edge length: the
    points that do not move are returned unchanged.

    Returns the points and the number of moves made.
    """
    P = np.asarray(points, np.float64)
    C = np.ascontiguousarray(quads, np.int64)
    judged = np.ascontiguousarray(judged, np.bool_)
    n = len(P)
    near = np.zeros(n, bool)
    near[C[judged & (_angle_quality_rows(P, C) < below)].ravel()] = True
    if not near.any():
        return P, 0
    for _ in range(2):  # two rings of quads around the poor ones
        near[C[near[C].any(axis=1)].ravel()] = True
    node, a, b = slide
    if border is None:
        border = boundary_points(P, C)
    mode = np.where(near & ~fixed & ~border, 1, 0).astype(np.int64)
    on = near[node] & ~fixed[node]
    node, a, b = node[on], a[on], b[on]
    mode[node] = 2
    if not mode.any():
        return P, 0
    moving = mode > 0
    centre = P[moving].mean(axis=0)
    e = P[np.roll(C, -1, axis=1)] - P[C]
    scale = float(np.hypot(e[..., 0], e[..., 1])[near[C]].mean()) or 1.0
    X = (P - centre) / scale
    unit = np.zeros((n, 2))
    d = P[b] - P[a]
    unit[node] = d / np.maximum(np.hypot(d[:, 0], d[:, 1]), np.finfo(float).tiny)[:, None]
    X0 = X.copy()
    moves = _lift_corners(X, C, mode, unit, judged, float(below), float(keep))
    go = (X != X0).any(axis=1)
    out = P.copy()
    out[go] = X[go] * scale + centre
    touched = go[C].any(axis=1)
    if not _valid_planar(out, C[touched]).all():  # mapped back: rounding may not fold
        return P, 0
    return out, int(moves)
