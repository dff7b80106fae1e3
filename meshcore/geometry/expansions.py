"""Exact floating-point arithmetic under the predicates: expansions and double-doubles.

Error-free transformations (``two_sum``, ``two_product`` with Dekker's
splitting; Knuth, Dekker, Shewchuk [1]_), zero-eliminating expansion sums,
scalings and products, and double-double operations. They compute no sign
of their own: :mod:`meshcore.geometry.predicates` (2D) and
:mod:`meshcore.geometry.predicates3d` (3D) build their exact stages on them.
:data:`WORK_SIZE` is the scratch length every ``*_exact`` and
``*_filtered`` predicate needs.

References
----------
.. [1] J. R. Shewchuk, "Adaptive Precision Floating-Point Arithmetic and Fast
   Robust Geometric Predicates", Discrete & Computational Geometry 18 (1997).
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = [
    "WORK_SIZE",
]


# Shewchuk's machine constants for IEEE double precision (round to nearest).
_EPS = 2.0**-53


_SPLITTER = 2.0**27 + 1.0


_RESULT_ERRBOUND = (3.0 + 8.0 * _EPS) * _EPS


#: Length of the scratch buffer the ``*_exact`` scalar functions need.
WORK_SIZE = 16384


@njit(cache=True)
def two_sum(a, b):
    x = a + b
    bv = x - a
    av = x - bv
    return x, (a - av) + (b - bv)


@njit(cache=True)
def _two_diff(a, b):
    x = a - b
    bv = a - x
    av = x + bv
    return x, (a - av) + (bv - b)


@njit(cache=True)
def _split(a):
    c = _SPLITTER * a
    abig = c - a
    ahi = c - abig
    return ahi, a - ahi


@njit(cache=True)
def two_product(a, b):
    x = a * b
    ahi, alo = _split(a)
    bhi, blo = _split(b)
    err1 = x - ahi * bhi
    err2 = err1 - alo * bhi
    err3 = err2 - ahi * blo
    return x, alo * blo - err3


# Callers pass lengths typed int64 (np.int64(2), np.int64(0) for a loop's first
# value), not literals: a literal argument compiles one more copy of a kernel.
@njit(cache=True)
def _expansion_sum(elen, e, flen, f, h):
    """Shewchuk's fast_expansion_sum_zeroelim: h = e + f, returns len(h).

    e and f are nonoverlapping expansions with components in increasing order
    of magnitude; so is h, without zero components. h must not alias e or f.
    """
    if elen == 0:
        for i in range(flen):
            h[i] = f[i]
        return flen
    if flen == 0:
        for i in range(elen):
            h[i] = e[i]
        return elen
    enow = e[0]
    fnow = f[0]
    eindex = 0
    findex = 0
    if (fnow > enow) == (fnow > -enow):
        q = enow
        eindex += 1
        if eindex < elen:
            enow = e[eindex]
    else:
        q = fnow
        findex += 1
        if findex < flen:
            fnow = f[findex]
    hindex = 0
    if eindex < elen and findex < flen:
        if (fnow > enow) == (fnow > -enow):
            qnew = enow + q
            q_ = q - (qnew - enow)
            eindex += 1
            if eindex < elen:
                enow = e[eindex]
        else:
            qnew = fnow + q
            q_ = q - (qnew - fnow)
            findex += 1
            if findex < flen:
                fnow = f[findex]
        # Fast_Two_Sum(enow, q) computed above as qnew, q_ (hh)
        q = qnew
        if q_ != 0.0:
            h[hindex] = q_
            hindex += 1
        while eindex < elen and findex < flen:
            if (fnow > enow) == (fnow > -enow):
                q, hh = two_sum(q, enow)
                eindex += 1
                if eindex < elen:
                    enow = e[eindex]
            else:
                q, hh = two_sum(q, fnow)
                findex += 1
                if findex < flen:
                    fnow = f[findex]
            if hh != 0.0:
                h[hindex] = hh
                hindex += 1
    while eindex < elen:
        q, hh = two_sum(q, enow)
        eindex += 1
        if eindex < elen:
            enow = e[eindex]
        if hh != 0.0:
            h[hindex] = hh
            hindex += 1
    while findex < flen:
        q, hh = two_sum(q, fnow)
        findex += 1
        if findex < flen:
            fnow = f[findex]
        if hh != 0.0:
            h[hindex] = hh
            hindex += 1
    if q != 0.0 or hindex == 0:
        h[hindex] = q
        hindex += 1
    return hindex


@njit(cache=True)
def _scale_expansion(elen, e, b, h):
    """Shewchuk's scale_expansion_zeroelim: h = b * e, returns len(h)."""
    q, hh = two_product(e[0], b)
    hindex = 0
    if hh != 0.0:
        h[hindex] = hh
        hindex += 1
    for i in range(1, elen):
        p1, p0 = two_product(e[i], b)
        s, hh = two_sum(q, p0)
        if hh != 0.0:
            h[hindex] = hh
            hindex += 1
        q = p1 + s
        hh = s - (q - p1)
        if hh != 0.0:
            h[hindex] = hh
            hindex += 1
    if q != 0.0 or hindex == 0:
        h[hindex] = q
        hindex += 1
    return hindex


@njit(cache=True)
def _expansion_product(elen, e, flen, f, h, tmp1, tmp2):
    """h = e * f (both expansions); tmp1, tmp2 are scratch; returns len(h)."""
    hlen = np.int64(0)
    for i in range(flen):
        slen = _scale_expansion(elen, e, f[i], tmp1)
        nlen = _expansion_sum(hlen, h, slen, tmp1, tmp2)
        for k in range(nlen):
            h[k] = tmp2[k]
        hlen = nlen
    return hlen


@njit(cache=True)
def _sign_of(elen, e):
    """Sign of an expansion: that of its largest (last nonzero) component."""
    for i in range(elen - 1, -1, -1):
        if e[i] > 0.0:
            return 1
        if e[i] < 0.0:
            return -1
    return 0


@njit(cache=True)
def _set_diff(a, b, out):
    """Write a - b as an exact expansion (1 or 2 components) into out."""
    x, y = _two_diff(a, b)
    if y == 0.0:
        out[0] = x
        return 1
    out[0] = y
    out[1] = x
    return 2


@njit(cache=True)
def _cross_exact(adx, adxlen, bdy, bdylen, bdx, bdxlen, ady, adylen, h, work):
    """h = adx * bdy - bdx * ady for expansions; work needs >= 96 slots."""
    p = work[0:16]
    q = work[16:32]
    t1 = work[32:64]
    t2 = work[64:96]
    plen = _expansion_product(adxlen, adx, bdylen, bdy, p, t1, t2)
    qlen = _expansion_product(bdxlen, bdx, adylen, ady, q, t1, t2)
    for i in range(qlen):
        q[i] = -q[i]
    return _expansion_sum(plen, p, qlen, q, h)


@njit(cache=True)
def _dd_add(ah, al, bh, bl):
    """Accurate double-double sum (relative error below 3u**2, Joldes et al. 2017)."""
    s, e = two_sum(ah, bh)
    t, f = two_sum(al, bl)
    e += t
    x = s + e
    e = e - (x - s)
    e += f
    s = x + e
    return s, e - (s - x)


@njit(cache=True)
def _dd_mul(ah, al, bh, bl):
    """Double-double product (relative error below 7u**2 without FMA)."""
    p, e = two_product(ah, bh)
    e += ah * bl + al * bh
    x = p + e
    return x, e - (x - p)


@njit(cache=True)
def _dd_cross(ah, al, bh, bl, ch, cl, dh, dl):
    """a*b - c*d in double-double."""
    xh, xl = _dd_mul(ah, al, bh, bl)
    yh, yl = _dd_mul(ch, cl, dh, dl)
    return _dd_add(xh, xl, -yh, -yl)


@njit(cache=True)
def _dd_lift(xh, xl, yh, yl, zh, zl):
    ah, al = _dd_mul(xh, xl, xh, xl)
    bh, bl = _dd_mul(yh, yl, yh, yl)
    ch, cl = _dd_mul(zh, zl, zh, zl)
    ah, al = _dd_add(ah, al, bh, bl)
    return _dd_add(ah, al, ch, cl)


@njit(cache=True)
def _dd_minor3(z1h, z1l, m1h, m1l, z2h, z2l, m2h, m2l, z3h, z3l, m3h, m3l):
    """z1*m1 + z2*m2 + z3*m3 in double-double."""
    ah, al = _dd_mul(z1h, z1l, m1h, m1l)
    bh, bl = _dd_mul(z2h, z2l, m2h, m2l)
    ch, cl = _dd_mul(z3h, z3l, m3h, m3l)
    ah, al = _dd_add(ah, al, bh, bl)
    return _dd_add(ah, al, ch, cl)


@njit(cache=True)
def _cross4(a, b, c, d, out):
    """out = a*b - c*d exactly (Two_Two_Diff), zeros removed; returns length."""
    x1, x0 = two_product(a, b)
    y1, y0 = two_product(c, d)
    i, r0 = _two_diff(x0, y0)
    j, _0 = two_sum(x1, i)
    i, r1 = _two_diff(_0, y1)
    x3, x2 = two_sum(j, i)
    n = 0
    if r0 != 0.0:
        out[n] = r0
        n += 1
    if r1 != 0.0:
        out[n] = r1
        n += 1
    if x2 != 0.0:
        out[n] = x2
        n += 1
    if x3 != 0.0:
        out[n] = x3
        n += 1
    return n
