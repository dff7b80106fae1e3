"""Where the segments of a planar straight-line graph cross: the search behind :func:`parse_domain`.

The segments are hashed into a uniform grid (a segment's cells walked in
compiled code, the grid coarsened when a segment would fill more than
``_ENTRIES_PER_SEGMENT`` cells), and the pairs sharing a cell are classified
with exact :func:`~meshcore.geometry.predicates.orient2d` signs (proper
crossing, touching, overlap), so the cost follows the number of nearby
pairs, not the square of the segment count. Split from
:mod:`meshcore.domain.planar`, which turns what is found into located
errors; the names stay private to the package.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from meshcore.geometry.predicates import orient2d_scalar

__all__: list[str] = []

# Candidate search: (segment, cell) entries allowed per segment before the grid coarsens.
_ENTRIES_PER_SEGMENT = 8
# The intersection search stops after finding this many bad pairs.
_MAX_FOUND = 1 << 16
# Kinds of a bad pair of segments.
_CROSS, _TOUCH, _OVERLAP = 1, 2, 3


def _floor_index(values: np.ndarray, origin: float, h: float) -> np.ndarray:
    return np.floor((values - origin) / h).astype(np.int64)


@njit(cache=True)
def _grid_cells(x0, y0, x1, y1, ox, oy, h, pad, nx, ny, key, seg, fill):
    """Count (``fill`` False) or write the (cell, segment) entries of a grid.

    A segment whose bounding box spans at most 2 x 2 cells is entered in
    those cells ("short"). A longer one is rasterized along its major axis
    u: its columns come from its endpoints, and in each column the rows its
    v-range over the column touches, padded by ``pad`` (far above the
    rounding of the interpolation) and clipped to its own v-range. Cell
    indices are ``floor((x - origin) / h)``, the same expression for every
    segment and monotone in x, so two segments whose bounding boxes (or
    rasterized paths) share a point share a cell. A sequential compiled
    loop over segments.

    Returns
    -------
    total : int
        Number of entries (written to ``key``, ``seg`` when ``fill``).
    short : (s,) bool
        The segments entered by bounding box.
    """
    s = len(x0)
    short = np.zeros(s, dtype=np.bool_)
    total = 0
    for i in range(s):
        lx = min(x0[i], x1[i])
        hx = max(x0[i], x1[i])
        ly = min(y0[i], y1[i])
        hy = max(y0[i], y1[i])
        cx0 = np.int64(np.floor((lx - ox) / h))
        cx1 = np.int64(np.floor((hx - ox) / h))
        cy0 = np.int64(np.floor((ly - oy) / h))
        cy1 = np.int64(np.floor((hy - oy) / h))
        if cx1 - cx0 <= 1 and cy1 - cy0 <= 1:
            short[i] = True
            for cx in range(cx0, cx1 + 1):
                for cy in range(cy0, cy1 + 1):
                    if fill:
                        key[total] = cx * ny + cy
                        seg[total] = i
                    total += 1
            continue
        xmajor = hx - lx >= hy - ly
        if xmajor:
            ou, ov, nv = ox, oy, ny
            if x0[i] <= x1[i]:
                ua, va, ub, vb = x0[i], y0[i], x1[i], y1[i]
            else:
                ua, va, ub, vb = x1[i], y1[i], x0[i], y0[i]
        else:
            ou, ov, nv = oy, ox, nx
            if y0[i] <= y1[i]:
                ua, va, ub, vb = y0[i], x0[i], y1[i], x1[i]
            else:
                ua, va, ub, vb = y1[i], x1[i], y0[i], x0[i]
        vlo = min(va, vb)
        vhi = max(va, vb)
        slope = (vb - va) / (ub - ua)
        c0 = np.int64(np.floor((ua - ou) / h))
        c1 = np.int64(np.floor((ub - ou) / h))
        for c in range(c0, c1 + 1):
            ul = max(ua, ou + c * h)
            ur = min(ub, ou + (c + 1) * h)
            vl = va + (ul - ua) * slope
            vr = va + (ur - ua) * slope
            lo = max(min(vl, vr) - pad, vlo)
            hi = min(max(vl, vr) + pad, vhi)
            r0 = min(max(np.int64(np.floor((lo - ov) / h)), 0), nv - 1)
            r1 = min(max(np.int64(np.floor((hi - ov) / h)), 0), nv - 1)
            for r in range(r0, r1 + 1):
                if fill:
                    key[total] = c * ny + r if xmajor else r * ny + c
                    seg[total] = i
                total += 1
    return total, short


def _grid_entries(p0: np.ndarray, p1: np.ndarray):
    """Segments entered in the cells of a uniform grid, sorted by cell.

    Parameters
    ----------
    p0, p1 : (s, 2) float64
        Segment endpoints (scaled coordinates, |x| < 1).

    Returns
    -------
    key, seg : (e,) int64
        Cell key and segment of each entry, sorted by key.
    grid : tuple
        ``(decodable, ny, ox, oy, h, short)``: whether ``key = cx * ny + cy``
        (else keys are hashed cell numbers), the grid's origin and cell size,
        and (s,) bool, the segments entered in their bounding-box cells.

    Notes
    -----
    Cell size ``h`` is the median segment extent, doubled while the entries
    would exceed ``_ENTRIES_PER_SEGMENT`` per segment; cells are filled by
    :func:`_grid_cells`.
    """
    s = len(p0)
    x0 = np.ascontiguousarray(p0[:, 0])
    y0 = np.ascontiguousarray(p0[:, 1])
    x1 = np.ascontiguousarray(p1[:, 0])
    y1 = np.ascontiguousarray(p1[:, 1])
    ox = float(min(x0.min(), x1.min()))
    oy = float(min(y0.min(), y1.min()))
    mx = float(max(x0.max(), x1.max()))
    my = float(max(y0.max(), y1.max()))
    span = max(mx - ox, my - oy)
    big = max(abs(ox), abs(oy), abs(mx), abs(my))
    pad = 64.0 * float(np.spacing(big))
    extent = np.maximum(np.abs(x1 - x0), np.abs(y1 - y0))
    h = max(float(np.median(extent)), span * 2.0**-30, pad)
    budget = _ENTRIES_PER_SEGMENT * s + (1 << 20)
    dummy = np.zeros(0, dtype=np.int64)
    while True:
        nx = int(np.floor((mx - ox) / h)) + 1
        ny = int(np.floor((my - oy) / h)) + 1
        total, short = _grid_cells(x0, y0, x1, y1, ox, oy, h, pad, nx, ny, dummy, dummy, False)
        if total <= budget or h >= span:
            break
        h *= 2.0
    key = np.empty(total, dtype=np.int64)
    seg = np.empty(total, dtype=np.int64)
    _grid_cells(x0, y0, x1, y1, ox, oy, h, pad, nx, ny, key, seg, True)
    # Packing (cell, segment) into one int64 lets numpy's fast value sort order
    # the entries; a cell number too wide to pack is hashed, which can only
    # merge cells (extra candidates, removed by the box test).
    bits = max(1, (s - 1).bit_length())
    room = 63 - bits
    decodable = nx * ny <= (1 << room)
    if not decodable:
        mixed = key.astype(np.uint64) * np.uint64(0x9E3779B97F4A7C15)
        key = (mixed >> np.uint64(64 - room)).astype(np.int64)
    packed = np.sort((key << bits) | seg)
    return packed >> bits, packed & ((1 << bits) - 1), (decodable, ny, ox, oy, h, short)


@njit(cache=True)
def _within_box(px, py, ax, ay, bx, by):
    return min(ax, bx) <= px <= max(ax, bx) and min(ay, by) <= py <= max(ay, by)


@njit(cache=True)
def _classify_pair(P, ends, i, j):
    """How segments i and j meet other than at a shared vertex: (kind, witness).

    kind is 0 (disjoint, or meeting only at a common vertex), ``_CROSS``
    (proper crossing), ``_TOUCH`` (an endpoint on the other segment) or
    ``_OVERLAP`` (collinear and sharing more than a point, or the same
    segment twice); witness is the index of a point on both segments (-1
    for a crossing). Signs come from
    :func:`~meshcore.geometry.predicates.orient2d_scalar`, the rest from
    exact comparisons of coordinates and point indices.
    """
    a, b, c, d = ends[i, 0], ends[i, 1], ends[j, 0], ends[j, 1]
    ax, ay, bx, by = P[a, 0], P[a, 1], P[b, 0], P[b, 1]
    cx, cy, dx, dy = P[c, 0], P[c, 1], P[d, 0], P[d, 1]
    o1 = orient2d_scalar(ax, ay, bx, by, cx, cy)
    o2 = orient2d_scalar(ax, ay, bx, by, dx, dy)
    if o1 * o2 > 0:
        return 0, -1  # c and d strictly on one side of ab
    o3 = orient2d_scalar(cx, cy, dx, dy, ax, ay)
    o4 = orient2d_scalar(cx, cy, dx, dy, bx, by)
    if o3 * o4 > 0:
        return 0, -1
    sa = a == c or a == d
    sb = b == c or b == d
    sc = c == a or c == b
    sd = d == a or d == b
    if sa and sb:
        return _OVERLAP, a
    on_c = o1 == 0 and not sc and _within_box(cx, cy, ax, ay, bx, by)
    on_d = o2 == 0 and not sd and _within_box(dx, dy, ax, ay, bx, by)
    on_a = o3 == 0 and not sa and _within_box(ax, ay, cx, cy, dx, dy)
    on_b = o4 == 0 and not sb and _within_box(bx, by, cx, cy, dx, dy)
    if not (on_a or on_b or on_c or on_d):
        if o1 * o2 < 0 and o3 * o4 < 0:
            return _CROSS, -1
        return 0, -1
    w = c if on_c else (d if on_d else (a if on_a else b))
    if o1 == 0 and o2 == 0:
        # Collinear: do the extents along the line share more than a point?
        if ax != bx:
            lo = max(min(ax, bx), min(cx, dx))
            hi = min(max(ax, bx), max(cx, dx))
        else:
            lo = max(min(ay, by), min(cy, dy))
            hi = min(max(ay, by), max(cy, dy))
        if lo < hi:
            return _OVERLAP, w
    return _TOUCH, w


@njit(cache=True)
def _scan_cells(key, seg, P, ends, succ, short, decodable, ny, ox, oy, h, cap):
    """Test every pair of segments sharing a grid cell; collect the bad ones.

    A compiled loop over the pairs of each cell (no pair arrays are built).
    A pair is skipped when its bounding boxes are disjoint (exact
    comparisons), when the segments are consecutive in a ring, or, for two
    bounding-box-entered segments, in every cell but the one holding the
    lower-left corner of their boxes' intersection (so such a pair is
    tested once). Returns ``(out, count, full)``: rows ``(i, j, kind,
    witness)`` with i < j (a pair with a long segment may repeat), and
    whether ``cap`` rows were reached (the scan then stops).
    """
    out = np.empty((cap, 4), dtype=np.int64)
    nout = 0
    n = len(key)
    x0 = P[ends[:, 0], 0]
    x1 = P[ends[:, 1], 0]
    y0 = P[ends[:, 0], 1]
    y1 = P[ends[:, 1], 1]
    lox = np.minimum(x0, x1)
    hix = np.maximum(x0, x1)
    loy = np.minimum(y0, y1)
    hiy = np.maximum(y0, y1)
    start = 0
    while start < n:
        stop = start + 1
        while stop < n and key[stop] == key[start]:
            stop += 1
        if stop - start >= 2:
            cx = key[start] // ny
            cy = key[start] % ny
            for p in range(start, stop - 1):
                for q in range(p + 1, stop):
                    i = min(seg[p], seg[q])
                    j = max(seg[p], seg[q])
                    if i == j:
                        continue
                    if lox[i] > hix[j] or lox[j] > hix[i] or loy[i] > hiy[j] or loy[j] > hiy[i]:
                        continue
                    if succ[i] == j or succ[j] == i:
                        continue
                    if decodable and short[i] and short[j]:
                        rx = np.int64(np.floor((max(lox[i], lox[j]) - ox) / h))
                        ry = np.int64(np.floor((max(loy[i], loy[j]) - oy) / h))
                        if rx != cx or ry != cy:
                            continue
                    kind, w = _classify_pair(P, ends, i, j)
                    if kind != 0:
                        out[nout, 0] = i
                        out[nout, 1] = j
                        out[nout, 2] = kind
                        out[nout, 3] = w
                        nout += 1
                        if nout == cap:
                            return out, nout, True
        start = stop
    return out, nout, False


def _intersections(P: np.ndarray, ends: np.ndarray, succ: np.ndarray, p0, p1):
    """Every pair of segments meeting other than at a common vertex.

    Parameters
    ----------
    P : (n, 2) float64
        Points, scaled (|x| < 1).
    ends : (s, 2) int64
        Segments as point indices.
    succ : (s,) int64
        The next segment of the same ring, -1 for constraints: consecutive
        ring segments share a vertex by construction and are not tested
        (their overlap, a spike, is checked before).
    p0, p1 : (s, 2) float64
        ``P[ends[:, 0]]`` and ``P[ends[:, 1]]``.

    Returns
    -------
    rows : (k, 4) int64
        Unique rows ``(i, j, kind, witness)``, i < j, sorted.
    capped : bool
        Whether the search stopped at ``_MAX_FOUND`` pairs.
    """
    if len(ends) < 2:
        return np.zeros((0, 4), dtype=np.int64), False
    key, seg, (decodable, ny, ox, oy, h, short) = _grid_entries(p0, p1)
    out, count, capped = _scan_cells(
        key, seg, P, ends, succ, short, decodable, ny, ox, oy, h, _MAX_FOUND
    )
    rows = out[:count]
    if count:
        rows = np.unique(rows, axis=0)
        _, first = np.unique(rows[:, 0] * len(ends) + rows[:, 1], return_index=True)
        rows = rows[first]
    return rows, bool(capped)


def _crossing_point(a, b, c, d) -> tuple[float, float]:
    """Where segments ab and cd cross (a construction: rounded)."""
    r = (b[0] - a[0], b[1] - a[1])
    q = (d[0] - c[0], d[1] - c[1])
    den = r[0] * q[1] - r[1] * q[0]
    t = ((c[0] - a[0]) * q[1] - (c[1] - a[1]) * q[0]) / den
    return a[0] + t * r[0], a[1] + t * r[1]
