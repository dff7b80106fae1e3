"""Insertion order of the 3D Delaunay kernel: BRIO rounds, a 3D Hilbert curve in each.

Split from :mod:`meshcore.delaunay.kernel3d` (its step 2). A point's BRIO
round comes from a hash of its index (splitmix64: a reproducible fair coin
sequence), so that a run is reproducible; within a round the points follow
the Hilbert curve (Skilling's transform), alternately forwards and
backwards so that each round starts where the previous one ended. Methods
text §9.2-§9.3 (the kernel they stand on); N. Amenta, S. Choi and G. Rote,
"Incremental constructions con BRIO" (2003); J. Skilling, "Programming the
Hilbert curve" (2004).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from meshcore.delaunay.brio import brio_round, brio_rounds
from meshcore.geometry.ordering import radix_argsort

__all__ = ["insertion_order"]

# Most bits per axis of the Hilbert grid: 3 * 16 bits of curve index under
# the round number, all in a non-negative int64.
_HILBERT_BITS = 16


@njit(cache=True, inline="always")
def _invert_or_exchange(x0, xi, q, p):
    """One step of AxesToTranspose for axis i: invert x0's low bits (below
    ``q``) when xi has bit ``q``, else exchange those bits between x0 and xi."""
    if xi & q:
        return x0 ^ p, xi
    t = (x0 ^ xi) & p
    return x0 ^ t, xi ^ t


@njit(cache=True)
def _hilbert3(x, y, z, nbits):
    """Hilbert index of integer coordinates (Skilling's AxesToTranspose)."""
    X0, X1, X2 = x, y, z
    q = 1 << (nbits - 1)
    while q > 1:
        p = q - 1
        if X0 & q:
            X0 ^= p
        X0, X1 = _invert_or_exchange(X0, X1, q, p)
        X0, X2 = _invert_or_exchange(X0, X2, q, p)
        q >>= 1
    X1 ^= X0
    X2 ^= X1
    t = 0
    q = 1 << (nbits - 1)
    while q > 1:
        if X2 & q:
            t ^= q - 1
        q >>= 1
    X0 ^= t
    X1 ^= t
    X2 ^= t
    d = 0
    for lvl in range(nbits - 1, -1, -1):
        d = (d << 3) | (((X0 >> lvl) & 1) << 2) | (((X1 >> lvl) & 1) << 1) | ((X2 >> lvl) & 1)
    return d


@njit(cache=True)
def _brio_hilbert_keys(pts, nbits, salt):
    """Sort keys: BRIO round in the high bits, Hilbert index in the low bits."""
    n = pts.shape[0]
    lo = np.empty(3)
    hi = np.empty(3)
    for c in range(3):
        lo[c] = pts[0, c]
        hi[c] = pts[0, c]
    for i in range(n):
        for c in range(3):
            lo[c] = min(lo[c], pts[i, c])
            hi[c] = max(hi[c], pts[i, c])
    extent = max(hi[0] - lo[0], max(hi[1] - lo[1], hi[2] - lo[2]))
    if extent <= 0.0:
        extent = 1.0
    side = (1 << nbits) - 1
    scale = side / extent
    rounds = brio_rounds(n)
    keys = np.empty(n, np.int64)
    curve = np.empty(n, np.int64)
    for i in range(n):
        hx = min(max(int((pts[i, 0] - lo[0]) * scale), 0), side)
        hy = min(max(int((pts[i, 1] - lo[1]) * scale), 0), side)
        hz = min(max(int((pts[i, 2] - lo[2]) * scale), 0), side)
        d = _hilbert3(hx, hy, hz, nbits)
        r = brio_round(i + salt, rounds)
        curve[i] = d
        if r % 2 == 1:
            d = (1 << (3 * nbits)) - 1 - d
        keys[i] = (r << (3 * nbits)) | d
    return keys, curve


def insertion_order(pts: np.ndarray, salt: int) -> tuple[np.ndarray, np.ndarray]:
    """The BRIO / Hilbert insertion order of ``pts`` and each point's curve index.

    Returns ``(order, curve)``: ``order`` the int64 permutation (the stable
    sort of :func:`_brio_hilbert_keys`' keys: rounds in turn, each along the
    curve, one curve cell in index order), ``curve`` the Hilbert index of
    every point (input order). ``salt`` shifts the round hash (a batch
    inserted later gets other rounds than the initial points). The grid has
    about 16 cells per point, at most ``2**16`` a side.
    """
    keys, curve = _brio_hilbert_keys(pts, _grid_bits(len(pts)), salt)
    return radix_argsort(keys), curve


def _grid_bits(n: int) -> int:
    """Bits per axis of the Hilbert grid for n points: about 16 cells a point."""
    return min(_HILBERT_BITS, max(6, (n.bit_length() + 4) // 3 + 2))
