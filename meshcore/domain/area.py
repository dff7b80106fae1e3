"""The exact signed area of a domain's rings: the shoelace sum, rounded once.

Split from :mod:`meshcore.domain.planar` (whose :func:`parse_domain` reports
:attr:`Domain.area`); the names stay private to the package. The terms
``x_i y_{i+1} - x_{i+1} y_i`` are formed with their exact rounding errors
(Dekker's products, Knuth's two-sum); their rounded parts are summed
exactly in integer bins, one per binary exponent, and the errors in order,
then everything is added exactly and rounded once as :func:`math.fsum`
does (:func:`_shoelace`). A choice the methods text leaves open: the area
is that of the input polygons to within about an ulp, however far from the
origin they lie (DESIGN.md "Geometry robustness").
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from meshcore.geometry.expansions import two_product

__all__: list[str] = []


@njit(cache=True)
def _exact_shift(pts, scale):
    """Per axis, the first scaled coordinate if subtracting it from every other
    one is exact (two-sum error 0), else 0.0 (no shift); one pass."""
    rx = pts[0, 0] * scale
    ry = pts[0, 1] * scale
    fx = fy = True
    for i in range(len(pts)):
        v = pts[i, 0] * scale
        s = v - rx
        bv = s - v
        fx = fx and (v - (s - bv)) + (-rx - bv) == 0.0
        v = pts[i, 1] * scale
        s = v - ry
        bv = s - v
        fy = fy and (v - (s - bv)) + (-ry - bv) == 0.0
        if not (fx or fy):
            break
    return rx if fx else 0.0, ry if fy else 0.0


@njit(cache=True)
def _fsum_add(partials, n, x):
    """Add ``x`` to the non-overlapping ``partials[:n]`` exactly; their new count.

    The loop of CPython's :func:`math.fsum` (Shewchuk's algorithm), for finite
    terms, with Knuth's branch-free two-sum in place of the ordered fast
    two-sum: both give the same rounded sum and exact error.
    """
    i = 0
    for j in range(n):
        y = partials[j]
        hi = x + y
        bb = hi - x
        lo = (x - (hi - bb)) + (y - bb)
        partials[i] = lo
        i += lo != 0.0
        x = hi
    if x != 0.0:
        partials[i] = x
        i += 1
    return i


@njit(cache=True)
def _fsum_round(partials, n):
    """The correctly rounded value of ``partials[:n]``: the ending of CPython's
    :func:`math.fsum`, half-even rounding across partials included."""
    if n == 0:
        return 0.0
    n -= 1
    hi = partials[n]
    lo = 0.0
    while n > 0:
        x = hi
        n -= 1
        y = partials[n]
        hi = x + y
        lo = y - (hi - x)
        if lo != 0.0:
            break
    if n > 0 and ((lo < 0.0 and partials[n - 1] < 0.0) or (lo > 0.0 and partials[n - 1] > 0.0)):
        y = lo * 2.0
        x = hi + y
        if y == x - hi:
            hi = x
    return hi


#: Terms deposited in the integer bins of :func:`_shoelace` between carries
#: (53-bit significands: 512 of them cannot overflow an int64 bin).
_BLOCK = 512


@njit(cache=True)
def _deposit(bins, bits, count):
    """Add the float64 values whose bit patterns are ``bits[:count]`` exactly to
    ``bins`` (bin ``e`` counts units of ``2**(e - 1075)``), then carry the
    bits above 32 of the bins they touched into the bin 32 places up."""
    lo = bins.shape[0]
    hi = 0
    for k in range(count):
        b = bits[k]
        e = (b >> 52) & 0x7FF
        m = b & 0xFFFFFFFFFFFFF
        if e == 0:
            e = 1  # subnormal: same unit as the smallest normal exponent
        else:
            m |= 1 << 52
        bins[e] += -m if b < 0 else m
        lo = min(lo, e)
        hi = max(hi, e)
    # Upward, so that carries are carried on once more (the bins above hi + 32
    # get at most 2**31 a call: no overflow in any number of calls).
    for e in range(lo, min(hi + 33, bins.shape[0] - 32)):
        c = bins[e] >> 32
        if c != 0:
            bins[e] -= c << 32
            bins[e + 32] += c


@njit(cache=True)
def _term(xi, yi, xj, yj):
    """``xi * yj - xj * yi`` as its rounded value and the rest, rounded: each
    product split exactly (Dekker), their difference by two-sum."""
    h1, l1 = two_product(xi, yj)
    h2, l2 = two_product(xj, yi)
    s = h1 - h2
    bv = s - h1
    return s, ((h1 - (s - bv)) + (-h2 - bv)) + l1 - l2


@njit(cache=True)
def _shoelace(pts, scale, offsets, reversed_, sx, sy):
    """Twice the signed area of the rings (terms negated in reversed rings), on the
    coordinates times ``scale`` minus (``sx``, ``sy``).

    Each product is split exactly (Dekker); the rounded leading parts
    ``x_i y_{i+1} - x_{i+1} y_i`` are summed exactly in integer bins, one
    per binary exponent (:func:`_deposit`), together with the sum of their
    exact remainders (two-sum errors and product tails), accumulated in
    order; the bins and that sum are then added exactly and rounded once
    (:func:`_fsum_add`, :func:`_fsum_round`: :func:`math.fsum`'s algorithm,
    whose rounding is correct, so the result is that of ``math.fsum`` of
    the same terms). One compiled pass, in blocks of :data:`_BLOCK` terms.
    """
    buf = np.empty(_BLOCK)
    bits = buf.view(np.int64)
    rest = np.empty(_BLOCK)
    xs = np.empty(_BLOCK + 1)
    ys = np.empty(_BLOCK + 1)
    bins = np.zeros(2048 + 64, np.int64)
    small = 0.0
    for k in range(len(offsets) - 1):
        lo, hi = offsets[k], offsets[k + 1]
        sign = -1.0 if reversed_[k] else 1.0
        # Blocks of terms formed apart from the in-order sums, from contiguous
        # copies of the block's vertices (loops the compiler vectorizes), then
        # deposited and their remainders added in order.
        for first in range(lo, hi, _BLOCK):
            count = min(hi - first, _BLOCK)
            block = pts[first : first + count]
            for t in range(count):
                xs[t] = block[t, 0] * scale - sx
                ys[t] = block[t, 1] * scale - sy
            after = first + count if first + count < hi else lo  # the closing term's end
            xs[count] = pts[after, 0] * scale - sx
            ys[count] = pts[after, 1] * scale - sy
            for t in range(count):
                s, r = _term(xs[t], ys[t], xs[t + 1], ys[t + 1])
                buf[t] = s * sign
                rest[t] = r * sign
            _deposit(bins, bits, count)
            for t in range(count):
                small += rest[t]
    partials = np.empty(256)
    n = np.int64(0)
    for e in range(bins.shape[0]):
        if bins[e] != 0:  # two exact halves (a bin may exceed 53 bits only at the top)
            top = (bins[e] >> 26) << 26
            n = _fsum_add(partials, n, math.ldexp(float(top), e - 1075))
            n = _fsum_add(partials, n, math.ldexp(float(bins[e] - top), e - 1075))
    n = _fsum_add(partials, n, small)
    return _fsum_round(partials, n)


def _area(pts: np.ndarray, scale: float, offsets: np.ndarray, reversed_: np.ndarray) -> float:
    """Signed shoelace area of ``pts * scale``, the reversed rings' negated.

    Coordinates are shifted to the first vertex when that is exact (it keeps
    the terms small); each product is split exactly (Dekker), the leading
    parts ``x_i y_{i+1} - x_{i+1} y_i`` (rounded, with their exact rounding
    error kept) are summed exactly and rounded once, as :func:`math.fsum`
    does, and the small parts, each below an ulp of its term, in order. The
    error is that of the small parts' sum, orders of magnitude below an ulp
    of the area unless the terms cancel by some 1e16. All in compiled
    passes (:func:`_shoelace`).
    """
    sx, sy = _exact_shift(pts, scale)
    return 0.5 * _shoelace(pts, scale, offsets, reversed_, sx, sy)
