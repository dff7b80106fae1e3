"""Hash tables and a ball grid for the 3D boundary recovery (compiled).

Open-addressing tables of integer keys (a Fibonacci hash, at most 3/8 full)
and :func:`ball_pairs`, the points inside balls found through a hash grid per
power of two of the radius. Split from :mod:`meshcore.delaunay.recovery3d`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

_FIB = np.uint64(0x9E3779B97F4A7C15)


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
        out[i] = _find(tk, tv, keys[i], shift)
    return out


def ball_pairs(X: np.ndarray, centres: np.ndarray, radii: np.ndarray):
    """All pairs (i, j) with ``|X[i] - centres[j]| < radii[j]`` (float), point by point
    (``i`` increasing), each point's by power of two of the radius, then ``j`` decreasing.

    A hash grid per power of two of the radius: a ball of radius below
    ``2**e`` is registered in the one cell of side ``2**e`` that holds its
    centre, and each point looks in the cells within the largest radius of
    each scale (27 but for rounding). Registering each ball in the up to 8
    cells of side ``2**(e + 1)`` its bounding box met, a point looked at about
    150 balls on the thin plate's 156k subfaces at 1M tetrahedra (1.5 CPU s
    for 234k points, a 200 MB table; now 8x fewer entries). One compiled
    pass; the distance is numpy's ``norm(X[i] - centres[j])``.
    """
    X = np.ascontiguousarray(X, dtype=np.float64).reshape(-1, 3)
    centres = np.ascontiguousarray(centres, dtype=np.float64).reshape(-1, 3)
    radii = np.ascontiguousarray(radii, dtype=np.float64)
    if len(X) < 32768 or not np.isfinite(radii).any():
        return _ball_pairs(X, centres, radii)
    # The points in the order of coarse cells (neighbours look up the same cells while
    # they are in cache), their pairs then put back in point order.
    span = float(np.nanmax(np.where(np.isfinite(radii), radii, np.nan)))
    cell = np.floor(np.nan_to_num(X / max(span, 1e-300))).astype(np.int64)
    order = np.lexsort((cell[:, 2], cell[:, 1], cell[:, 0]))
    xi, ci = _ball_pairs(X[order], centres, radii)
    back = np.argsort(order[xi], kind="stable")
    return order[xi][back], ci[back]


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
def _ball_pairs(X, centres, radii):
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
    z = np.zeros(0, np.int64)
    if X.shape[0] == 0 or n_ok == 0:
        return z, z
    levels = np.unique(expo[ok])
    reach = np.zeros(levels.shape[0])  # the largest radius of each level
    for j in range(nb):
        if ok[j]:
            li = np.searchsorted(levels, expo[j])
            reach[li] = max(reach[li], radii[j])
    # Each ball in the cell of its centre, in the grid of side 2**level.
    size = 16
    while size < 2 * n_ok:
        size *= 2
    shift = _shift(size)
    tab = np.zeros((size, 6), np.int64)  # e, ix, iy, iz, used, head entry
    nxt = np.empty(n_ok, np.int64)
    ball = np.empty(n_ok, np.int64)
    k = 0
    for j in range(nb):
        if not ok[j]:
            continue
        h = 2.0 ** expo[j]
        ix = np.int64(math.floor(centres[j, 0] / h))
        iy = np.int64(math.floor(centres[j, 1] / h))
        iz = np.int64(math.floor(centres[j, 2] / h))
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
    found = np.empty(64, np.int64)
    n = 0
    for i in range(X.shape[0]):
        x0, x1, x2 = X[i, 0], X[i, 1], X[i, 2]
        if not (math.isfinite(x0) and math.isfinite(x1) and math.isfinite(x2)):
            continue
        for li in range(levels.shape[0]):
            e = levels[li]
            h = 2.0**e
            # The cells within the level's reach (padded for the rounding of x -/+ reach).
            pad = reach[li] * (1.0 + 1e-9) + 1e-15 * max(abs(x0), abs(x1), abs(x2)) + 1e-300
            m = 0
            for ix in range(
                np.int64(math.floor((x0 - pad) / h)), np.int64(math.floor((x0 + pad) / h)) + 1
            ):
                for iy in range(
                    np.int64(math.floor((x1 - pad) / h)), np.int64(math.floor((x1 + pad) / h)) + 1
                ):
                    for iz in range(
                        np.int64(math.floor((x2 - pad) / h)),
                        np.int64(math.floor((x2 + pad) / h)) + 1,
                    ):
                        s = _cell_slot(tab, e, ix, iy, iz, shift)
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
                                if m == found.shape[0]:
                                    grown = np.empty(2 * m, np.int64)
                                    grown[:m] = found
                                    found = grown
                                found[m] = j
                                m += 1
            # Per point and level, the balls in decreasing index order.
            for a in range(1, m):
                v = found[a]
                b = a - 1
                while b >= 0 and found[b] < v:
                    found[b + 1] = found[b]
                    b -= 1
                found[b + 1] = v
            if n + m > cap:
                while n + m > cap:
                    cap *= 2
                xs2 = np.empty(cap, np.int64)
                js2 = np.empty(cap, np.int64)
                xs2[:n] = xs[:n]
                js2[:n] = js[:n]
                xs, js = xs2, js2
            for a in range(m):
                xs[n] = i
                js[n] = found[a]
                n += 1
    return xs[:n].copy(), js[:n].copy()
