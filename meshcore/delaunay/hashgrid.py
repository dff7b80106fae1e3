"""Hash tables and a ball grid for the 3D boundary recovery (compiled).

Open-addressing tables of integer keys (a Fibonacci hash, at most 3/8 full)
and :func:`ball_pairs`, the points inside balls found through a hash grid per
power of two of the radius. Split from :mod:`meshcore.delaunay.recovery3d`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from meshcore.delaunay.prefetch import prefetch
from meshcore.geometry.ordering import radix_argsort

_FIB = np.uint64(0x9E3779B97F4A7C15)
#: :func:`ball_pairs` tests every ball for this many points or fewer.
FEW_POINTS = 32


@njit(cache=True)
def _slot(key, shift):
    return np.int64((np.uint64(key) * _FIB) >> shift)


@njit(cache=True)
def _shift(size):
    bits = 0
    while (1 << bits) < size:
        bits += 1
    return np.uint64(64 - bits)


@njit(cache=True)
def _table(keys):
    """(slot keys, slot values) of the non-negative ``keys``; -1 marks an empty slot."""
    size = 16
    while size < 2 * keys.shape[0]:
        size *= 2
    tk = np.full(size, -1, np.int64)
    tv = np.full(size, -1, np.int64)
    mask = size - 1
    shift = _shift(size)
    for i in range(keys.shape[0]):
        if i + 16 < keys.shape[0]:  # the slot 16 keys ahead (a miss in a large table)
            h = _slot(keys[i + 16], shift)
            prefetch(tk, h)
            prefetch(tv, h)
        key = keys[i]
        h = _slot(key, shift)
        while tk[h] != -1 and tk[h] != key:
            h = (h + 1) & mask
        if tk[h] == -1:
            tk[h] = key
            tv[h] = i
    return tk, tv


@njit(cache=True)
def _find(tk, tv, key, shift):
    """Index of the first occurrence of ``key`` in the table's keys, or -1."""
    mask = tk.shape[0] - 1
    h = _slot(key, shift)
    while tk[h] != -1:
        if tk[h] == key:
            return tv[h]
        h = (h + 1) & mask
    return -1


@njit(cache=True)
def _find_all(tk, tv, keys):
    shift = _shift(tk.shape[0])
    out = np.empty(keys.shape[0], np.int64)
    for i in range(keys.shape[0]):
        if i + 16 < keys.shape[0]:
            prefetch(tk, _slot(keys[i + 16], shift))
        out[i] = _find(tk, tv, keys[i], shift)
    return out


def ball_pairs(X: np.ndarray, centres: np.ndarray, radii: np.ndarray):
    """All pairs (i, j) with ``|X[i] - centres[j]| < radii[j]`` (float), point by point
    (``i`` increasing), each point's by power of two of the radius, then ``j`` decreasing.

    A hash grid per power of two of the radius: a ball of radius below
    ``2**e`` is registered in the cells of side ``2**(e + 1)`` its bounding
    box meets (at most 8 but for rounding), so each point looks in one cell
    per radius scale. One compiled pass; the distance is numpy's
    ``norm(X[i] - centres[j])``. Up to ``FEW_POINTS`` points every ball is tested
    instead (no grid built). From 32,768 points and balls on, the points are looked
    up in the order of coarse cells (neighbours walk the same cells while
    they are in cache) and their pairs put back in point order: on the thin
    plate at 1M tetrahedra (156k subfaces, about 150 balls a cell) the
    subface queries took 3.2-3.8 CPU s in point order, 1.1 s so.
    """
    X = np.ascontiguousarray(X, dtype=np.float64).reshape(-1, 3)
    centres = np.ascontiguousarray(centres, dtype=np.float64).reshape(-1, 3)
    radii = np.ascontiguousarray(radii, dtype=np.float64)
    if len(X) <= FEW_POINTS:
        return _ball_pairs_few(X, centres, radii)
    if len(X) < 32768 or len(radii) < 32768 or not np.isfinite(radii).any():
        return _ball_pairs(X, centres, radii)
    # Coarse cells of the largest finite radius; the stable sort keeps each point's order.
    span = float(np.nanmax(np.where(np.isfinite(radii), radii, np.nan)))
    cell = np.floor(np.nan_to_num(X / max(span, 1e-300))).astype(np.int64)
    order = np.lexsort((cell[:, 2], cell[:, 1], cell[:, 0]))
    xi, ci = _ball_pairs(X[order], centres, radii)
    xi = order[xi]
    back = radix_argsort(xi)
    return xi[back], ci[back]


@njit(cache=True)
def _cell_slot(tab, e, ix, iy, iz, shift):
    """The slot of cell (e, ix, iy, iz) in ``tab`` (its own or the empty one ending its run)."""
    mask = tab.shape[0] - 1
    key = ((e * 1000003 + ix) * 1000003 + iy) * 1000003 + iz
    h = _slot(key & 0x7FFFFFFFFFFFFFFF, shift)
    while tab[h, 4] != 0:
        if tab[h, 0] == e and tab[h, 1] == ix and tab[h, 2] == iy and tab[h, 3] == iz:
            return h
        h = (h + 1) & mask
    return h


@njit(cache=True)
def _usable(centres, radii):
    """Which balls count (finite centre, finite positive radius), each one's power of
    two (``radius < 2**expo``) and their number."""
    nb = radii.shape[0]
    ok = np.zeros(nb, np.bool_)
    expo = np.zeros(nb, np.int64)
    n_ok = 0
    for j in range(nb):
        r = radii[j]
        if math.isfinite(r) and r > 0:
            c = centres[j]
            if math.isfinite(c[0]) and math.isfinite(c[1]) and math.isfinite(c[2]):
                ok[j] = True
                expo[j] = math.frexp(r)[1]  # r < 2**expo
                n_ok += 1
    return ok, expo, n_ok


@njit(cache=True)
def _ball_pairs_few(X, centres, radii):
    """:func:`_ball_pairs` for a few points: every ball tested, no grid built, the
    pairs in the same order. The grid does not absorb it: 32 points spread over the
    balls' box among 292k balls took 26.5 ms here against 246-264 ms through the grid,
    and still 246 ms with the balls missing the points' bounding box left out of the
    grid (2.6 ms against 25 ms only when the points cluster); CPU ms, medians of 15,
    load 5 (2026-12-05)."""
    ok, expo, _ = _usable(centres, radii)
    nb = radii.shape[0]
    xs = np.empty(0, np.int64)
    js = np.empty(0, np.int64)
    for i in range(X.shape[0]):
        x0, x1, x2 = X[i, 0], X[i, 1], X[i, 2]
        if not (math.isfinite(x0) and math.isfinite(x1) and math.isfinite(x2)):
            continue
        hit = []
        for j in range(nb - 1, -1, -1):
            if ok[j]:
                d0 = x0 - centres[j, 0]
                d1 = x1 - centres[j, 1]
                d2 = x2 - centres[j, 2]
                if math.sqrt((d0 * d0 + d1 * d1) + d2 * d2) < radii[j]:
                    hit.append(j)
        if len(hit) == 0:
            continue
        # by power of two of the radius, then j decreasing (a stable sort)
        h = np.array(hit)
        h = h[np.argsort(expo[h], kind="mergesort")]
        xs = np.concatenate((xs, np.full(h.shape[0], i, np.int64)))
        js = np.concatenate((js, h))
    return xs, js


@njit(cache=True)
def _ball_pairs(X, centres, radii):
    nb = radii.shape[0]
    ok, expo, n_ok = _usable(centres, radii)
    z = np.zeros(0, np.int64)
    if X.shape[0] == 0 or n_ok == 0:
        return z, z
    levels = np.unique(expo[ok])
    # Cells of each ball: its bounding box (padded for rounding) in the grid of its level.
    lo = np.empty((nb, 3), np.int64)
    hi = np.empty((nb, 3), np.int64)
    n_ent = 0
    for j in range(nb):
        if not ok[j]:
            continue
        h = 2.0 ** (expo[j] + 1)
        pad = radii[j] * (1.0 + 1e-9) + 1e-300
        count = 1
        for k in range(3):
            lo[j, k] = np.int64(math.floor((centres[j, k] - pad) / h))
            hi[j, k] = np.int64(math.floor((centres[j, k] + pad) / h))
            count *= hi[j, k] - lo[j, k] + 1
        n_ent += count
    # Distinct cells: at most the entries, and at most the cells of each level's box
    # (far fewer when many balls share cells: a table that stays in cache).
    cells = 0.0
    for e in levels:
        box_lo = np.full(3, np.iinfo(np.int64).max)
        box_hi = np.full(3, np.iinfo(np.int64).min)
        for j in range(nb):
            if ok[j] and expo[j] == e:
                for k in range(3):
                    box_lo[k] = min(box_lo[k], lo[j, k])
                    box_hi[k] = max(box_hi[k], hi[j, k])
        cells += (
            float(box_hi[0] - box_lo[0] + 1)
            * float(box_hi[1] - box_lo[1] + 1)
            * float(box_hi[2] - box_lo[2] + 1)
        )
    size = 16
    while size < 2 * min(float(n_ent), cells):
        size *= 2
    shift = _shift(size)
    tab = np.zeros((size, 6), np.int64)  # e, ix, iy, iz, used, head entry
    nxt = np.empty(n_ent, np.int64)
    ball = np.empty(n_ent, np.int64)
    k = 0
    for j in range(nb):
        if not ok[j]:
            continue
        for ix in range(lo[j, 0], hi[j, 0] + 1):
            for iy in range(lo[j, 1], hi[j, 1] + 1):
                for iz in range(lo[j, 2], hi[j, 2] + 1):
                    s = _cell_slot(tab, expo[j], ix, iy, iz, shift)
                    if tab[s, 4] == 0:
                        tab[s, 0], tab[s, 1], tab[s, 2], tab[s, 3] = expo[j], ix, iy, iz
                        tab[s, 4] = 1
                        tab[s, 5] = -1
                    ball[k] = j
                    nxt[k] = tab[s, 5]
                    tab[s, 5] = k
                    k += 1
    cap = 1024
    xs = np.empty(cap, np.int64)
    js = np.empty(cap, np.int64)
    n = 0
    for i in range(X.shape[0]):
        x0, x1, x2 = X[i, 0], X[i, 1], X[i, 2]
        if not (math.isfinite(x0) and math.isfinite(x1) and math.isfinite(x2)):
            continue
        for e in levels:
            h = 2.0 ** (e + 1)
            s = _cell_slot(
                tab, e, np.int64(math.floor(x0 / h)), np.int64(math.floor(x1 / h)),
                np.int64(math.floor(x2 / h)), shift,
            )  # fmt: skip
            if tab[s, 4] == 0:
                continue
            q = tab[s, 5]
            while q >= 0:
                j = ball[q]
                q = nxt[q]
                d0 = x0 - centres[j, 0]
                d1 = x1 - centres[j, 1]
                d2 = x2 - centres[j, 2]
                if math.sqrt((d0 * d0 + d1 * d1) + d2 * d2) < radii[j]:
                    if n == cap:
                        cap *= 2
                        xs2 = np.empty(cap, np.int64)
                        js2 = np.empty(cap, np.int64)
                        xs2[:n] = xs[:n]
                        js2[:n] = js[:n]
                        xs, js = xs2, js2
                    xs[n] = i
                    js[n] = j
                    n += 1
    return xs[:n].copy(), js[:n].copy()
