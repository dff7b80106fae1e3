"""Where the segments of a planar straight-line graph cross: the search behind :func:`parse_domain`.

The ring segments are first cut into *pieces*: runs of consecutive segments
of one ring along which both coordinates are monotone (the monotone chains
of GEOS and of Bentley-Ottmann), each at most ``_PIECE_SEGMENTS`` segments
and ``_PIECE_EXTENT`` median segment extents long. Two non-consecutive
segments of such a run cannot meet (their bounding boxes are disjoint once
consecutive duplicate points are refused, which :func:`parse_domain` does
first), so only pairs of segments from different pieces need a test, and a
piece's bounding box is the box of its two end points. Constraint segments
are pieces of one segment.

The pieces are hashed into a uniform grid (a piece's cells walked in
compiled code, the grid coarsened when the pieces would fill more than
``_ENTRIES_PER_SEGMENT`` cells each): a piece of several segments, or a
short one, in the cells of its bounding box, a long single segment in the
cells its path crosses. Two pieces sharing a cell are compared in a
compiled loop: their boxes, then the segments of each whose boxes meet the
other piece's box, pair by pair, classified with exact
:func:`~meshcore.geometry.predicates.orient2d_scalar` signs (proper crossing,
touching, overlap). The cost follows the number of pieces and of nearby
pairs, not the square of the segment count: a sampled smooth boundary of a
million vertices becomes some 30,000 pieces whose boxes meet only their
neighbours'. Nothing is allocated per segment. Split from
:mod:`meshcore.domain.planar`, which turns what is found into located
errors; the names stay private to the package.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from meshcore.geometry.ordering import radix_argsort
from meshcore.geometry.predicates import orient2d_scalar

__all__: list[str] = []

# Candidate search: (piece, cell) entries allowed per piece before the grid coarsens.
_ENTRIES_PER_SEGMENT = 8
# A piece holds at most this many segments ...
_PIECE_SEGMENTS = 32
# ... and spans at most this many median segment extents.
_PIECE_EXTENT = 32.0
# Pieces of more segments than this are searched for the segments meeting a box
# (:func:`_meeting`); shorter ones have all their segments paired (the box test
# of each pair rejects the same ones).
_SEARCH_FROM = 4
# Segments sampled for the median extent.
_SAMPLE = 1 << 16
# The intersection search stops after finding this many bad pairs.
_MAX_FOUND = 1 << 16
# Kinds of a bad pair of segments.
_CROSS, _TOUCH, _OVERLAP = 1, 2, 3


def _floor_index(values: np.ndarray, origin: float, h: float) -> np.ndarray:
    return np.floor((values - origin) / h).astype(np.int64)


@njit(cache=True)
def _median_extent(pts, scale, offsets, cseg):
    """Median of ``max(|dx|, |dy|)`` over (a stride of at most ``_SAMPLE``) segments."""
    nb = offsets[-1]
    s = nb + len(cseg)
    step = max(1, s // _SAMPLE)
    m = (s + step - 1) // step
    ext = np.empty(m)
    ring = 0
    for t in range(m):
        g = t * step
        if g < nb:
            while offsets[ring + 1] <= g:
                ring += 1
            a = g
            b = g + 1 if g + 1 < offsets[ring + 1] else offsets[ring]
        else:
            a = cseg[g - nb, 0]
            b = cseg[g - nb, 1]
        ext[t] = max(abs(pts[b, 0] - pts[a, 0]), abs(pts[b, 1] - pts[a, 1])) * scale
    return np.median(ext)


@njit(cache=True)
def _pieces(pts, scale, offsets, cseg, cap, max_len):
    """Cut the segments into pieces (module documentation); a compiled pass.

    Returns
    -------
    start : (k + 1,) int64
        Piece ``q`` holds segments ``start[q]`` to ``start[q + 1] - 1``
        (ring segment ``g`` runs from point ``g``; constraint segment ``t``
        is segment ``nb + t``).
    first, last : (k,) int64
        The points at the ends of each piece (its bounding box's corners).
    box : (k, 4) float64
        Each piece's bounding box ``(min x, min y, max x, max y)``, scaled.
    """
    nb = offsets[-1]
    c = len(cseg)
    start = np.empty(nb + c + 1, np.int32)  # scratch (the results are copied out)
    first = np.empty(nb + c, np.int32)
    last = np.empty(nb + c, np.int32)
    m = 0
    for k in range(len(offsets) - 1):
        lo, hi = offsets[k], offsets[k + 1]
        sx = 0
        sy = 0
        fx = 0.0
        fy = 0.0
        grow = False
        # The current piece's first segment and last point, and segment i's first
        # point, carried along (each point is read once).
        head = lo
        tail = lo
        xa = pts[lo, 0] * scale
        ya = pts[lo, 1] * scale
        for i in range(lo, hi):
            b = i + 1 if i + 1 < hi else lo
            xb = pts[b, 0] * scale
            yb = pts[b, 1] * scale
            ddx = xb - xa
            ddy = yb - ya
            dx = (ddx > 0.0) - (ddx < 0.0)
            dy = (ddy > 0.0) - (ddy < 0.0)
            moves = (dx | dy) != 0
            # Without branches (signs are -1, 0, 1: sx * dx >= 0 means sx == 0,
            # dx == 0 or dx == sx): the loop runs at half the time.
            if (
                grow
                & moves
                & (sx * dx >= 0)
                & (sy * dy >= 0)
                & (i - head < max_len)
                & (max(abs(xb - fx), abs(yb - fy)) <= cap)
            ):
                sx = sx if sx != 0 else dx
                sy = sy if sy != 0 else dy
            else:
                if i > lo:  # the ring's previous piece ends
                    last[m - 1] = tail
                start[m] = i
                first[m] = i
                head = i
                m += 1
                fx, fy, sx, sy, grow = xa, ya, dx, dy, moves
            tail = b
            xa = xb
            ya = yb
        if hi > lo:
            last[m - 1] = tail
    for t in range(c):
        start[m] = nb + t
        first[m] = cseg[t, 0]
        last[m] = cseg[t, 1]
        m += 1
    start[m] = nb + c
    box = np.empty((m, 4))
    for q in range(m):
        xa = pts[first[q], 0] * scale
        ya = pts[first[q], 1] * scale
        xb = pts[last[q], 0] * scale
        yb = pts[last[q], 1] * scale
        box[q, 0] = min(xa, xb)
        box[q, 1] = min(ya, yb)
        box[q, 2] = max(xa, xb)
        box[q, 3] = max(ya, yb)
    return (
        start[: m + 1].astype(np.int64),
        first[:m].astype(np.int64),
        last[:m].astype(np.int64),
        box,
    )


@njit(cache=True)
def _grid_cells(pts, scale, start, first, last, box, ox, oy, h, pad, nx, ny, key, item, fill):
    """Count (``fill`` False) or write the (cell, piece) entries of a grid.

    A piece of several segments, or one whose bounding box spans at most
    2 x 2 cells, is entered in the cells of its box ("short"). A longer
    single segment is rasterized along its major axis u: its columns come
    from its endpoints, and in each column the rows its v-range over the
    column touches, padded by ``pad`` (far above the rounding of the
    interpolation) and clipped to its own v-range. Cell indices are
    ``floor((x - origin) / h)``, the same expression for every piece and
    monotone in x, so two pieces whose bounding boxes (or rasterized
    paths) share a point share a cell. A sequential compiled loop.

    Returns
    -------
    total : int
        Number of entries (written to ``key``, ``item`` when ``fill``).
    short : (k,) bool
        The pieces entered by bounding box.
    """
    k = len(first)
    short = np.zeros(k, dtype=np.bool_)
    total = 0
    for q in range(k):
        lx, ly, hx, hy = box[q, 0], box[q, 1], box[q, 2], box[q, 3]
        cx0 = np.int64(np.floor((lx - ox) / h))
        cx1 = np.int64(np.floor((hx - ox) / h))
        cy0 = np.int64(np.floor((ly - oy) / h))
        cy1 = np.int64(np.floor((hy - oy) / h))
        if start[q + 1] - start[q] > 1 or (cx1 - cx0 <= 1 and cy1 - cy0 <= 1):
            short[q] = True
            for cx in range(cx0, cx1 + 1):
                for cy in range(cy0, cy1 + 1):
                    if fill:
                        key[total] = cx * ny + cy
                        item[total] = q
                    total += 1
            continue
        xa = pts[first[q], 0] * scale
        ya = pts[first[q], 1] * scale
        xb = pts[last[q], 0] * scale
        yb = pts[last[q], 1] * scale
        xmajor = hx - lx >= hy - ly
        if xmajor:
            ou, ov, nv = ox, oy, ny
            if xa <= xb:
                ua, va, ub, vb = xa, ya, xb, yb
            else:
                ua, va, ub, vb = xb, yb, xa, ya
        else:
            ou, ov, nv = oy, ox, nx
            if ya <= yb:
                ua, va, ub, vb = ya, xa, yb, xb
            else:
                ua, va, ub, vb = yb, xb, ya, xa
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
                    item[total] = q
                total += 1
    return total, short


@njit(cache=True)
def _box_stats(box, step):
    """The pieces' bounds (min x, min y, max x, max y) and the median extent
    ``max(width, height)`` of every ``step``-th piece; one compiled pass."""
    lx, ly = box[0, 0], box[0, 1]
    hx, hy = box[0, 2], box[0, 3]
    for q in range(len(box)):
        lx = min(lx, box[q, 0])
        ly = min(ly, box[q, 1])
        hx = max(hx, box[q, 2])
        hy = max(hy, box[q, 3])
    sample = box[::step]
    extent = np.empty(len(sample))
    for q in range(len(sample)):
        extent[q] = max(sample[q, 2] - sample[q, 0], sample[q, 3] - sample[q, 1])
    return lx, ly, hx, hy, np.median(extent)


def _grid_entries(pts, scale, offsets, cseg):
    """The pieces, entered in the cells of a uniform grid, sorted by cell.

    Returns
    -------
    key, item : (e,) int64
        Cell key and piece of each entry, sorted by key.
    pieces : tuple
        ``(start, first, last, box)`` from :func:`_pieces`.
    grid : tuple
        ``(decodable, ny, ox, oy, h, short)``: whether ``key = cx * ny + cy``
        (else keys are hashed cell numbers), the grid's origin and cell size,
        and (k,) bool, the pieces entered in their bounding-box cells.

    Notes
    -----
    Cell size ``h`` is the median extent of (a sample of) the pieces,
    doubled while the entries would exceed ``_ENTRIES_PER_SEGMENT`` per
    piece; cells are filled by :func:`_grid_cells`.
    """
    seg_h = float(_median_extent(pts, scale, offsets, cseg))
    start, first, last, box = _pieces(
        pts, scale, offsets, cseg, _PIECE_EXTENT * seg_h, _PIECE_SEGMENTS
    )
    k = len(first)
    ox, oy, mx, my, median = (float(v) for v in _box_stats(box, np.int64(max(1, k // _SAMPLE))))
    span = max(mx - ox, my - oy)
    pad = 64.0 * float(np.spacing(max(abs(ox), abs(oy), abs(mx), abs(my))))
    h = max(median, span * 2.0**-30, pad)
    budget = _ENTRIES_PER_SEGMENT * k + (1 << 20)
    dummy = np.zeros(0, dtype=np.int64)
    while True:
        nx = int(np.floor((mx - ox) / h)) + 1
        ny = int(np.floor((my - oy) / h)) + 1
        total, short = _grid_cells(
            pts, scale, start, first, last, box, ox, oy, h, pad, nx, ny, dummy, dummy, False
        )
        if total <= budget or h >= span:
            break
        h *= 2.0
    key = np.empty(total, dtype=np.int64)
    item = np.empty(total, dtype=np.int64)
    _grid_cells(pts, scale, start, first, last, box, ox, oy, h, pad, nx, ny, key, item, True)
    # Packing (cell, piece) into one int64 lets numpy's fast value sort order
    # the entries; a cell number too wide to pack is hashed, which can only
    # merge cells (extra candidates, removed by the box test).
    bits = max(1, (k - 1).bit_length())
    room = 63 - bits
    decodable = nx * ny <= (1 << room)
    if not decodable:
        key *= np.int64(-7046029254386353131)  # 0x9E3779B97F4A7C15, wrapping
        key >>= np.int64(64 - room)
        key &= np.int64((1 << room) - 1)
    key <<= np.int64(bits)
    key |= item
    del item
    key = key[radix_argsort(key)]  # distinct keys: the sorted values
    item = key & ((1 << bits) - 1)
    key >>= np.int64(bits)
    return key, item, (start, first, last, box), (decodable, ny, ox, oy, h, short)


@njit(cache=True)
def _boxes_apart(pts, scale, a, b, c, d):
    """Whether the boxes of segments ab and cd (point indices, scaled) are disjoint (exact)."""
    return (
        min(pts[a, 0], pts[b, 0]) * scale > max(pts[c, 0], pts[d, 0]) * scale
        or min(pts[c, 0], pts[d, 0]) * scale > max(pts[a, 0], pts[b, 0]) * scale
        or min(pts[a, 1], pts[b, 1]) * scale > max(pts[c, 1], pts[d, 1]) * scale
        or min(pts[c, 1], pts[d, 1]) * scale > max(pts[a, 1], pts[b, 1]) * scale
    )


@njit(cache=True)
def _within_box(px, py, ax, ay, bx, by):
    return min(ax, bx) <= px <= max(ax, bx) and min(ay, by) <= py <= max(ay, by)


@njit(cache=True)
def _classify_pair(pts, scale, a, b, c, d):
    """How segments ab and cd (point indices) meet other than at a shared vertex: (kind, witness).

    kind is 0 (disjoint, or meeting only at a common vertex), ``_CROSS``
    (proper crossing), ``_TOUCH`` (an endpoint on the other segment) or
    ``_OVERLAP`` (collinear and sharing more than a point, or the same
    segment twice); witness is the index of a point on both segments (-1
    for a crossing). Signs come from
    :func:`~meshcore.geometry.predicates.orient2d_scalar` on the coordinates
    times ``scale`` (a power of two: exact), the rest from exact
    comparisons of coordinates and point indices.
    """
    ax, ay, bx, by = pts[a, 0] * scale, pts[a, 1] * scale, pts[b, 0] * scale, pts[b, 1] * scale
    cx, cy, dx, dy = pts[c, 0] * scale, pts[c, 1] * scale, pts[d, 0] * scale, pts[d, 1] * scale
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
def _segment_ends(g, q, nb, start, last, cseg):
    """Point indices (a, b) of segment ``g`` of piece ``q``."""
    if g >= nb:
        return cseg[g - nb, 0], cseg[g - nb, 1]
    return g, (g + 1 if g + 1 < start[q + 1] else last[q])


@njit(cache=True)
def _piece_point(q, t, start, first, last):
    """Point ``t`` of piece ``q`` (0 its first, ``start[q + 1] - start[q]`` its last)."""
    if t == 0:
        return first[q]
    if t == start[q + 1] - start[q]:
        return last[q]
    return start[q] + t


@njit(cache=True)
def _monotone_range(pts, scale, q, start, first, last, axis, lo, hi):
    """Segments ``t0 <= t < t1`` of piece ``q`` whose extent along ``axis`` meets [lo, hi].

    The piece's points are monotone along the axis, so these form a range,
    found by two binary searches (exact comparisons).
    """
    m = start[q + 1] - start[q]
    down = pts[first[q], axis] > pts[last[q], axis]
    # Segment t spans [min_t, max_t], both monotone in t like the points: it meets
    # [lo, hi] iff max_t >= lo and min_t <= hi. t0: the first segment meeting one
    # of the two conditions that turns true along the piece; t1: the first, from
    # t0 on, failing the other.
    a, b = 0, m
    while a < b:
        t = (a + b) // 2
        v = pts[_piece_point(q, t + 1, start, first, last), axis] * scale
        if (v <= hi) if down else (v >= lo):
            b = t
        else:
            a = t + 1
    t0 = a
    a, b = t0, m
    while a < b:
        t = (a + b) // 2
        v = pts[_piece_point(q, t, start, first, last), axis] * scale
        if (v >= lo) if down else (v <= hi):
            a = t + 1
        else:
            b = t
    return t0, a


@njit(cache=True)
def _meeting(pts, scale, q, start, first, last, lx, ly, hx, hy):
    """Segments ``start[q] + t`` for ``t0 <= t < t1``: those of piece ``q`` whose boxes meet
    the box [lx, hx] x [ly, hy] (a monotone piece: the intersection of two ranges)."""
    # The axes as int64, not literals (each literal would compile another copy).
    x0, x1 = _monotone_range(pts, scale, q, start, first, last, np.int64(0), lx, hx)
    y0, y1 = _monotone_range(pts, scale, q, start, first, last, np.int64(1), ly, hy)
    return start[q] + max(x0, y0), start[q] + min(x1, y1)


@njit(cache=True)
def _scan_cells(key, item, pts, scale, nb, start, first, last, box, cseg, short, grid, cap):
    """Test every pair of pieces sharing a grid cell; collect the bad segment pairs.

    A compiled loop over the pairs of each cell (no pair arrays are built).
    A pair of pieces is skipped when their bounding boxes are disjoint
    (exact comparisons) or, for two bounding-box-entered pieces, in every
    cell but the one holding the lower-left corner of their boxes'
    intersection (so such a pair is tested once), and when the boxes meet
    in a single point that is an end point of both pieces (a point index of
    each): only the end segments of monotone pieces, which have no zero
    length, reach their end point, so the pieces meet there only, at a
    common vertex. Then the segments of
    each piece whose boxes meet the other piece's box (found by
    :func:`_meeting` in a piece of more than ``_SEARCH_FROM`` segments, all
    of a shorter one) are paired; a pair
    is skipped when its boxes are disjoint or the segments are consecutive
    in a ring. Returns ``(out, count, full)``: rows ``(i, j, kind,
    witness)`` with i < j (a pair with a long segment may repeat), and
    whether ``cap`` rows were reached (the scan then stops).
    """
    decodable, ny, ox, oy, h = grid
    out = np.empty((cap, 4), dtype=np.int64)
    nout = 0
    n = len(key)
    begin = 0
    while begin < n:
        stop = begin + 1
        while stop < n and key[stop] == key[begin]:
            stop += 1
        if stop - begin >= 2:
            cx = key[begin] // ny
            cy = key[begin] % ny
            for p in range(begin, stop - 1):
                for r in range(p + 1, stop):
                    u = min(item[p], item[r])
                    v = max(item[p], item[r])
                    if u == v:
                        continue
                    lxu, lyu, hxu, hyu = box[u, 0], box[u, 1], box[u, 2], box[u, 3]
                    lxv, lyv, hxv, hyv = box[v, 0], box[v, 1], box[v, 2], box[v, 3]
                    if lxu > hxv or lxv > hxu or lyu > hyv or lyv > hyu:
                        continue
                    if decodable and short[u] and short[v]:
                        rx = np.int64(np.floor((max(lxu, lxv) - ox) / h))
                        ry = np.int64(np.floor((max(lyu, lyv) - oy) / h))
                        if rx != cx or ry != cy:
                            continue
                    if (
                        max(lxu, lxv) == min(hxu, hxv)
                        and max(lyu, lyv) == min(hyu, hyv)
                        and (
                            last[u] == first[v]
                            or first[u] == last[v]
                            or first[u] == first[v]
                            or last[u] == last[v]
                        )
                    ):
                        continue  # the boxes meet only at a common end point (docstring)
                    i0, i1 = start[u], start[u + 1]
                    if i1 - i0 > _SEARCH_FROM:
                        i0, i1 = _meeting(pts, scale, u, start, first, last, lxv, lyv, hxv, hyv)
                    j0, j1 = start[v], start[v + 1]
                    if j1 - j0 > _SEARCH_FROM:
                        j0, j1 = _meeting(pts, scale, v, start, first, last, lxu, lyu, hxu, hyu)
                    for i in range(i0, i1):
                        a, b = _segment_ends(i, u, nb, start, last, cseg)
                        for j in range(j0, j1):  # i < j: pieces hold increasing segment numbers
                            c, d = _segment_ends(j, v, nb, start, last, cseg)
                            if j < nb and (b == j or d == i):
                                continue  # consecutive in a ring
                            if _boxes_apart(pts, scale, a, b, c, d):
                                continue
                            kind, w = _classify_pair(pts, scale, a, b, c, d)
                            if kind != 0:
                                out[nout, 0] = i
                                out[nout, 1] = j
                                out[nout, 2] = kind
                                out[nout, 3] = w
                                nout += 1
                                if nout == cap:
                                    return out, nout, True
        begin = stop
    return out, nout, False


def _intersections(pts: np.ndarray, scale: float, offsets: np.ndarray, cseg: np.ndarray):
    """Every pair of segments meeting other than at a common vertex.

    Parameters
    ----------
    pts : (n, 2) float64
        Points: the ring vertices (rings one after the other), then the
        constraint points; the predicates see them times ``scale``, a power
        of two that brings every coordinate below 1 in magnitude.
    offsets : (R + 1,) int64
        Ring ``k`` owns points and segments ``offsets[k]`` to
        ``offsets[k + 1] - 1``; ring segment ``g`` joins point ``g`` to the
        next point of its ring. Consecutive ring segments share a vertex by
        construction and are not tested (their overlap, a spike, and
        consecutive duplicate points are refused before).
    cseg : (c, 2) int64
        Constraint segments as point indices, segments ``nb + t``.

    Returns
    -------
    rows : (k, 4) int64
        Unique rows ``(i, j, kind, witness)``, i < j, sorted.
    capped : bool
        Whether the search stopped at ``_MAX_FOUND`` pairs.
    """
    nb = int(offsets[-1])
    if nb + len(cseg) < 2:
        return np.zeros((0, 4), dtype=np.int64), False
    key, item, (start, first, last, box), (decodable, ny, ox, oy, h, short) = _grid_entries(
        pts, scale, offsets, cseg
    )
    out, count, capped = _scan_cells(
        key,
        item,
        pts,
        scale,
        nb,
        start,
        first,
        last,
        box,
        cseg,
        short,
        (decodable, ny, ox, oy, h),
        _MAX_FOUND,
    )
    rows = out[:count]
    if count:
        rows = np.unique(rows, axis=0)
        _, first_row = np.unique(rows[:, 0] * (nb + len(cseg)) + rows[:, 1], return_index=True)
        rows = rows[first_row]
    return rows, bool(capped)


def _crossing_point(a, b, c, d) -> tuple[float, float]:
    """Where segments ab and cd cross (a construction: rounded)."""
    r = (b[0] - a[0], b[1] - a[1])
    q = (d[0] - c[0], d[1] - c[1])
    den = r[0] * q[1] - r[1] * q[0]
    t = ((c[0] - a[0]) * q[1] - (c[1] - a[1]) * q[0]) / den
    return a[0] + t * r[0], a[1] + t * r[1]
