"""Robust geometric predicates: exact signs of orientation, in-circle and in-sphere tests.

Every geometric decision of meshcore goes through these functions and their
3D half, :mod:`meshcore.geometry.predicates3d` (DESIGN.md, "Geometry
robustness"); the exact arithmetic under both is
:mod:`meshcore.geometry.expansions`. They follow Shewchuk's scheme [1]_: the determinant is
first evaluated in float64 together with a rigorous bound on its rounding
error (a dynamic "semi-static" filter); only when ``|det|`` does not exceed
the bound is the sign recomputed exactly with floating-point expansion
arithmetic (``two_sum``, ``two_product`` with Dekker's splitting, zero
eliminating expansion sums and scalings).

The exact stage is ours, simpler than Shewchuk's four adaptive stages: the
coordinate differences are formed exactly as two-term expansions; when those
are all exact single doubles (the common case, e.g. nearby points) the
determinant is expanded from the differences alone, otherwise from the
two-term differences. Both give the exact sign; no intermediate error bound is
trusted after the filter.

Two interfaces share one implementation:

* vectorized functions :func:`orient2d`, :func:`incircle`, :func:`orient3d`,
  :func:`insphere`, :func:`dot2d` and :func:`indiametral` take arrays of points, run the
  filter in numpy and the exact stage, in compiled code, on the undecided
  rows only;
* scalar numba functions :func:`orient2d_scalar`, :func:`incircle_scalar`,
  :func:`orient3d_scalar`, :func:`insphere_scalar` (``@njit``) for compiled
  kernels such as :mod:`meshcore.delaunay.kernel2d` and ``kernel3d``. The
  ``*_exact`` and ``*_filtered`` variants take a scratch buffer (``work``,
  float64, at least :data:`WORK_SIZE` long) so that a kernel calls them
  without allocating.

The exact insphere has two stages: the determinant of the rounded
differences formed exactly (exact when the differences are; otherwise
trusted beyond Shewchuk's ``isperrboundB``), then the 5 x 5 lifted
determinant of the original coordinates. :func:`insphere_perturbed` breaks
exact co-spherical ties by symbolic perturbation of the liftings in
lexicographic order of the points (Simulation of Simplicity), so that the 3D
Delaunay kernel's result depends only on the point set.

Assumptions (as Shewchuk's): no overflow or underflow in the products formed,
which holds when every coordinate difference is either zero or has magnitude
within about ``[2**-150, 2**150]`` (orient2d tolerates far more). Callers
with more extreme input rescale by a power of two first, which is exact and
changes no sign (see :func:`meshcore.delaunay.kernel2d.delaunay`).

References
----------
.. [1] J. R. Shewchuk, "Adaptive Precision Floating-Point Arithmetic and Fast
   Robust Geometric Predicates", Discrete & Computational Geometry 18 (1997).
   Methods text §9.1 (every Case decision of a boundary segment is a sign of
   these determinants); DESIGN.md "Geometry robustness".
"""

from __future__ import annotations

import numpy as np
from numba import njit

from meshcore.errors import InputError
from meshcore.geometry.expansions import (
    _EPS,
    WORK_SIZE,
    _cross4,
    _cross_exact,
    _expansion_product,
    _expansion_sum,
    _scale_expansion,
    _set_diff,
    _sign_of,
    _two_diff,
    two_product,
)

__all__ = [
    "CONVEX_PROOF",
    "WORK_SIZE",
    "dot2d",
    "dot2d_exact",
    "dot2d_filtered",
    "incircle",
    "incircle_exact",
    "incircle_filtered",
    "incircle_scalar",
    "indiametral",
    "orient2d",
    "orient2d_exact",
    "orient2d_filtered",
    "orient2d_scalar",
]


_CCW_ERRBOUND_A = (3.0 + 16.0 * _EPS) * _EPS


_ICC_ERRBOUND_A = (10.0 + 96.0 * _EPS) * _EPS

CONVEX_PROOF = 1e-6
"""A quad whose corner quality (8.4) is above this is strictly convex without an exact
sign: every corner's sine is then above it, so each corner's floating-point
determinant exceeds :func:`orient2d_filtered`'s error bound many times over and the
predicate would return its sign unchanged; at or below it the predicate decides."""


@njit(cache=True)
def orient2d_exact(ax, ay, bx, by, cx, cy, work):
    """Exact sign of the orientation of (a, b, c); ``work`` is scratch.

    Parameters
    ----------
    ax, ay, bx, by, cx, cy : float64
        The three points.
    work : (WORK_SIZE,) float64
        Scratch buffer, overwritten.

    Returns
    -------
    int
        +1 if a, b, c turn counter-clockwise, -1 if clockwise, 0 if collinear.
    """
    acx, acxt = _two_diff(ax, cx)
    acy, acyt = _two_diff(ay, cy)
    bcx, bcxt = _two_diff(bx, cx)
    bcy, bcyt = _two_diff(by, cy)
    if acxt == 0.0 and acyt == 0.0 and bcxt == 0.0 and bcyt == 0.0:
        # Differences are exact: det = acx*bcy - acy*bcx from two products.
        l1, l0 = two_product(acx, bcy)
        r1, r0 = two_product(acy, bcx)
        work[0] = l0
        work[1] = l1
        work[2] = -r0
        work[3] = -r1
        e = work[0:2]
        f = work[2:4]
        hlen = _expansion_sum(np.int64(2), e, np.int64(2), f, work[4:8])
        return _sign_of(hlen, work[4:8])
    e1 = work[0:2]
    e2 = work[2:4]
    e3 = work[4:6]
    e4 = work[6:8]
    n1 = _set_diff(ax, cx, e1)
    n2 = _set_diff(by, cy, e2)
    n3 = _set_diff(bx, cx, e3)
    n4 = _set_diff(ay, cy, e4)
    h = work[8:40]
    hlen = _cross_exact(e1, n1, e2, n2, e3, n3, e4, n4, h, work[40:200])
    return _sign_of(hlen, h)


@njit(cache=True)
def orient2d_filtered(ax, ay, bx, by, cx, cy, work):
    """:func:`orient2d_scalar` with a ``(WORK_SIZE,)`` scratch buffer for the exact stage.

    For compiled loops that allocate the buffer once (the CDT kernels).
    """
    detleft = (ax - cx) * (by - cy)
    detright = (ay - cy) * (bx - cx)
    det = detleft - detright
    errbound = _CCW_ERRBOUND_A * (abs(detleft) + abs(detright))
    if det > errbound:
        return 1
    if -det > errbound:
        return -1
    if detleft == 0.0 or detright == 0.0:
        if det > 0.0:
            return 1
        if det < 0.0:
            return -1
        return 0
    return orient2d_exact(ax, ay, bx, by, cx, cy, work)


@njit(cache=True)
def orient2d_scalar(ax, ay, bx, by, cx, cy):
    """Sign of the orientation of the points a, b, c (float filter, then exact).

    Parameters
    ----------
    ax, ay, bx, by, cx, cy : float64

    Returns
    -------
    int
        +1 counter-clockwise, -1 clockwise, 0 collinear (exactly).
    """
    detleft = (ax - cx) * (by - cy)
    detright = (ay - cy) * (bx - cx)
    det = detleft - detright
    errbound = _CCW_ERRBOUND_A * (abs(detleft) + abs(detright))
    if det > errbound:
        return 1
    if -det > errbound:
        return -1
    if detleft == 0.0 or detright == 0.0:
        # One product is exactly zero (no underflow): det is correctly rounded.
        if det > 0.0:
            return 1
        if det < 0.0:
            return -1
        return 0
    return orient2d_exact(ax, ay, bx, by, cx, cy, np.empty(256))


@njit(cache=True)
def dot2d_exact(ax, ay, bx, by, cx, cy, work):
    """Exact sign of ``(a - c) . (b - c)``; ``work`` is scratch.

    Parameters
    ----------
    ax, ay, bx, by, cx, cy : float64
        The three points.
    work : (WORK_SIZE,) float64
        Scratch buffer, overwritten.

    Returns
    -------
    int
        +1 if the angle acb is acute (c strictly outside the closed ball of
        diameter ab), -1 if obtuse (c strictly inside it), 0 if right or if c
        coincides with a or b.
    """
    acx, acxt = _two_diff(ax, cx)
    acy, acyt = _two_diff(ay, cy)
    bcx, bcxt = _two_diff(bx, cx)
    bcy, bcyt = _two_diff(by, cy)
    if acxt == 0.0 and acyt == 0.0 and bcxt == 0.0 and bcyt == 0.0:
        # Differences are exact: det = acx*bcx + acy*bcy from two products.
        l1, l0 = two_product(acx, bcx)
        r1, r0 = two_product(acy, bcy)
        work[0] = l0
        work[1] = l1
        work[2] = r0
        work[3] = r1
        hlen = _expansion_sum(np.int64(2), work[0:2], np.int64(2), work[2:4], work[4:8])
        return _sign_of(hlen, work[4:8])
    e1 = work[0:2]
    e2 = work[2:4]
    e3 = work[4:6]
    e4 = work[6:8]
    n1 = _set_diff(ax, cx, e1)
    n2 = _set_diff(bx, cx, e2)
    n3 = _set_diff(ay, cy, e3)
    n4 = _set_diff(by, cy, e4)
    p = work[8:24]
    q = work[24:40]
    t1 = work[40:72]
    t2 = work[72:104]
    h = work[104:140]
    plen = _expansion_product(n1, e1, n2, e2, p, t1, t2)
    qlen = _expansion_product(n3, e3, n4, e4, q, t1, t2)
    hlen = _expansion_sum(plen, p, qlen, q, h)
    return _sign_of(hlen, h)


@njit(cache=True)
def dot2d_filtered(ax, ay, bx, by, cx, cy, work):
    """Sign of ``(a - c) . (b - c)`` (filter, then exact); ``work`` is scratch.

    -1 when c is in the open diametral ball of ab (§9.1.1), 0 on its circle.
    """
    left = (ax - cx) * (bx - cx)
    right = (ay - cy) * (by - cy)
    det = left + right
    errbound = _CCW_ERRBOUND_A * (abs(left) + abs(right))
    if det > errbound:
        return 1
    if -det > errbound:
        return -1
    if left == 0.0 or right == 0.0:
        if det > 0.0:
            return 1
        if det < 0.0:
            return -1
        return 0
    return dot2d_exact(ax, ay, bx, by, cx, cy, work)


@njit(cache=True, inline="always")
def axis_rectangle(ax, ay, bx, by, cx, cy, dx, dy):
    """Whether a, b, c, d are the four corners of an axis-parallel rectangle, by
    exact comparisons: two pairs share their x, two other pairs their y, and
    the points sharing an x differ in y. Such points are co-circular (the
    in-circle determinant is exactly 0), the commonest exact tie in practice
    (grids; top and bottom samples of a rectangle's boundary)."""
    if ax == bx:
        return (
            cx == dx
            and ax != cx
            and ay != by
            and ((ay == cy and by == dy) or (ay == dy and by == cy))
        )
    if ax == cx:
        return (
            bx == dx
            and ax != bx
            and ay != cy
            and ((ay == by and cy == dy) or (ay == dy and cy == by))
        )
    if ax == dx:
        return (
            bx == cx
            and ax != bx
            and ay != dy
            and ((ay == by and dy == cy) or (ay == cy and dy == by))
        )
    return False


@njit(cache=True)
def incircle_exact(ax, ay, bx, by, cx, cy, dx, dy, work):
    """Exact sign of the in-circle determinant; ``work`` is scratch.

    Parameters
    ----------
    ax, ay, bx, by, cx, cy, dx, dy : float64
        a, b, c define the circle, d is tested.
    work : (WORK_SIZE,) float64
        Scratch buffer, overwritten.

    Returns
    -------
    int
        For counter-clockwise a, b, c: +1 if d is inside the circle through
        them, -1 outside, 0 on it (signs reverse when a, b, c is clockwise).
    """
    if axis_rectangle(ax, ay, bx, by, cx, cy, dx, dy):
        return 0
    adx, adxt = _two_diff(ax, dx)
    ady, adyt = _two_diff(ay, dy)
    bdx, bdxt = _two_diff(bx, dx)
    bdy, bdyt = _two_diff(by, dy)
    cdx, cdxt = _two_diff(cx, dx)
    cdy, cdyt = _two_diff(cy, dy)
    exact = (
        adxt == 0.0 and adyt == 0.0 and bdxt == 0.0 and bdyt == 0.0 and cdxt == 0.0 and cdyt == 0.0
    )
    if exact:
        return _incircle_from_diffs(adx, ady, bdx, bdy, cdx, cdy, work)
    # General case: every difference is a (1 or 2 term) expansion.
    d = work[0:12]
    la = _set_diff(ax, dx, d[0:2])
    lb = _set_diff(ay, dy, d[2:4])
    lc = _set_diff(bx, dx, d[4:6])
    ld = _set_diff(by, dy, d[6:8])
    le = _set_diff(cx, dx, d[8:10])
    lf = _set_diff(cy, dy, d[10:12])
    xa, ya = d[0:2], d[2:4]
    xb, yb = d[4:6], d[6:8]
    xc, yc = d[8:10], d[10:12]
    scratch = work[100:300]
    cross = work[300:340]
    lift = work[340:380]
    sq1 = work[380:400]
    sq2 = work[400:420]
    term = work[420:1500]
    acc = work[1500:3200]
    acc2 = work[3200:4900]
    t1 = work[4900:5000]
    t2 = work[5000:6100]
    alen = np.int64(0)
    for k in range(3):
        if k == 0:
            # alift * (bdx*cdy - cdx*bdy)
            x0, x0l, y0, y0l = xa, la, ya, lb
            clen = _cross_exact(xb, lc, yc, lf, xc, le, yb, ld, cross, scratch)
        elif k == 1:
            # blift * (cdx*ady - adx*cdy)
            x0, x0l, y0, y0l = xb, lc, yb, ld
            clen = _cross_exact(xc, le, ya, lb, xa, la, yc, lf, cross, scratch)
        else:
            # clift * (adx*bdy - bdx*ady)
            x0, x0l, y0, y0l = xc, le, yc, lf
            clen = _cross_exact(xa, la, yb, ld, xb, lc, ya, lb, cross, scratch)
        s1 = _expansion_product(x0l, x0, x0l, x0, sq1, t1, scratch)
        s2 = _expansion_product(y0l, y0, y0l, y0, sq2, t1, scratch)
        liftlen = _expansion_sum(s1, sq1, s2, sq2, lift)
        tlen = _expansion_product(liftlen, lift, clen, cross, term, t1, t2)
        nlen = _expansion_sum(alen, acc, tlen, term, acc2)
        for i in range(nlen):
            acc[i] = acc2[i]
        alen = nlen
    return _sign_of(alen, acc)


@njit(cache=True)
def _incircle_from_diffs(adx, ady, bdx, bdy, cdx, cdy, work):
    """Exact in-circle sign when the six coordinate differences are exact.

    The sum over the vertices of ``lift * cross`` with every partial
    expansion zero-eliminated and zero factors skipped: degenerate inputs
    (co-circular lattice-like points) have many zero differences.
    """
    cr = work[0:4]
    t8 = work[12:20]
    t16a = work[20:36]
    t16b = work[36:52]
    t32 = work[52:84]
    acc = work[84:180]
    acc2 = work[180:276]
    alen = np.int64(0)
    for k in range(3):
        if k == 0:
            px, py = adx, ady
            clen = _cross4(bdx, cdy, cdx, bdy, cr)
        elif k == 1:
            px, py = bdx, bdy
            clen = _cross4(cdx, ady, adx, cdy, cr)
        else:
            px, py = cdx, cdy
            clen = _cross4(adx, bdy, bdx, ady, cr)
        if clen == 0:
            continue
        n1 = 0
        if px != 0.0:
            n = _scale_expansion(clen, cr, px, t8)
            n1 = _scale_expansion(n, t8, px, t16a)
        n2 = 0
        if py != 0.0:
            n = _scale_expansion(clen, cr, py, t8)
            n2 = _scale_expansion(n, t8, py, t16b)
        tl = _expansion_sum(n1, t16a, n2, t16b, t32)
        nl = _expansion_sum(alen, acc, tl, t32, acc2)
        for i in range(nl):
            acc[i] = acc2[i]
        alen = nl
    return _sign_of(alen, acc)


@njit(cache=True)
def incircle_filtered(ax, ay, bx, by, cx, cy, dx, dy, work):
    """:func:`incircle_scalar` with a ``(WORK_SIZE,)`` scratch buffer for the exact stage."""
    adx = ax - dx
    bdx = bx - dx
    cdx = cx - dx
    ady = ay - dy
    bdy = by - dy
    cdy = cy - dy
    bdxcdy = bdx * cdy
    cdxbdy = cdx * bdy
    alift = adx * adx + ady * ady
    cdxady = cdx * ady
    adxcdy = adx * cdy
    blift = bdx * bdx + bdy * bdy
    adxbdy = adx * bdy
    bdxady = bdx * ady
    clift = cdx * cdx + cdy * cdy
    det = alift * (bdxcdy - cdxbdy) + blift * (cdxady - adxcdy) + clift * (adxbdy - bdxady)
    permanent = (
        (abs(bdxcdy) + abs(cdxbdy)) * alift
        + (abs(cdxady) + abs(adxcdy)) * blift
        + (abs(adxbdy) + abs(bdxady)) * clift
    )
    errbound = _ICC_ERRBOUND_A * permanent
    if det > errbound:
        return 1
    if -det > errbound:
        return -1
    return incircle_exact(ax, ay, bx, by, cx, cy, dx, dy, work)


@njit(cache=True)
def incircle_scalar(ax, ay, bx, by, cx, cy, dx, dy):
    """Sign of the in-circle test of d against the circle through a, b, c.

    Parameters
    ----------
    ax, ay, bx, by, cx, cy, dx, dy : float64

    Returns
    -------
    int
        For counter-clockwise a, b, c: +1 if d is strictly inside the
        circumcircle, -1 strictly outside, 0 exactly on it; reversed for a
        clockwise triangle.
    """
    return incircle_filtered(ax, ay, bx, by, cx, cy, dx, dy, np.empty(WORK_SIZE))


@njit(cache=True)
def _orient2d_rows(a, b, c, rows, out):
    work = np.empty(WORK_SIZE)
    for r in rows:
        out[r] = orient2d_exact(a[r, 0], a[r, 1], b[r, 0], b[r, 1], c[r, 0], c[r, 1], work)


@njit(cache=True)
def _dot2d_rows(a, b, c, rows, out):
    work = np.empty(WORK_SIZE)
    for r in rows:
        out[r] = dot2d_exact(a[r, 0], a[r, 1], b[r, 0], b[r, 1], c[r, 0], c[r, 1], work)


@njit(cache=True)
def _incircle_rows(a, b, c, d, rows, out):
    work = np.empty(WORK_SIZE)
    for r in rows:
        out[r] = incircle_exact(
            a[r, 0], a[r, 1], b[r, 0], b[r, 1], c[r, 0], c[r, 1], d[r, 0], d[r, 1], work
        )


def _prepare(args: tuple, dim: int, names: str) -> tuple[tuple[np.ndarray, ...], tuple]:
    """Broadcast point arrays of shape (..., dim) to flat (n, dim) float64."""
    arrays = []
    for name, arg in zip(names, args, strict=True):
        try:
            arr = np.asarray(arg, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise InputError(
                f"{name} must be an array of {dim}D points", loc=(name,), code="bad_shape"
            ) from exc
        if arr.ndim == 0 or arr.shape[-1] != dim:
            raise InputError(
                f"{name} must have shape (..., {dim}), got {arr.shape}",
                loc=(name,),
                code="bad_shape",
            )
        if not np.isfinite(arr).all():
            raise InputError(f"{name} has a non-finite coordinate", loc=(name,), code="non_finite")
        arrays.append(arr)
    shape = arrays[0].shape
    if len(shape) == 2 and all(a.shape == shape for a in arrays):  # nothing to broadcast
        return tuple(_flat_view(a) for a in arrays), shape[:1]
    try:
        shape = np.broadcast_shapes(*(a.shape for a in arrays))
    except ValueError as exc:
        raise InputError(
            "point arrays do not broadcast: " + ", ".join(str(a.shape) for a in arrays),
            loc=(),
            code="bad_shape",
        ) from exc
    lead = shape[:-1]
    flat = tuple(_flat_view(np.broadcast_to(a, shape).reshape(-1, dim)) for a in arrays)
    return flat, lead


def _flat_view(a: np.ndarray) -> np.ndarray:
    """``a`` as a read-only C-contiguous array (a view, or a copy when ``a`` is not
    contiguous): the compiled exact stages see one array type for every argument
    (numba compiles read-only and writable arrays as two types, so mixed flags
    compiled up to 2**5 copies of a stage)."""
    view = np.ascontiguousarray(a).view()
    view.flags.writeable = False
    return view


def _sign_int8(det: np.ndarray) -> np.ndarray:
    return np.sign(det).astype(np.int8)


def orient2d(a, b, c) -> np.ndarray:
    """Exact orientation of point triples, row by row.

    Parameters
    ----------
    a, b, c : (n, 2) float64 or (2,) float64
        Points; shapes broadcast (any leading shape ``(..., 2)``).

    Returns
    -------
    (n,) int8
        +1 where a, b, c turn counter-clockwise (c left of the directed line
        a->b), -1 clockwise, 0 exactly collinear. The leading broadcast shape
        is kept, so three single points give a 0-d array.

    Raises
    ------
    InputError
        ``bad_shape`` for arrays that are not ``(..., 2)`` or do not
        broadcast, ``non_finite`` for NaN or infinite coordinates.

    Notes
    -----
    Float64 evaluation with Shewchuk's error bound ``ccwerrboundA``; the rows
    it cannot decide are recomputed exactly. References: DESIGN.md "Geometry
    robustness"; methods text §9.1.
    """
    (a, b, c), lead = _prepare((a, b, c), 2, "abc")
    detleft = (a[:, 0] - c[:, 0]) * (b[:, 1] - c[:, 1])
    detright = (a[:, 1] - c[:, 1]) * (b[:, 0] - c[:, 0])
    det = detleft - detright
    errbound = _CCW_ERRBOUND_A * (np.abs(detleft) + np.abs(detright))
    out = _sign_int8(det)
    undecided = ~(np.abs(det) > errbound) & (detleft != 0.0) & (detright != 0.0)
    rows = np.flatnonzero(undecided)
    if rows.size:
        _orient2d_rows(a, b, c, rows, out)
    return out.reshape(lead)


def dot2d(a, b, c) -> np.ndarray:
    """Exact sign of the dot product ``(a - c) . (b - c)``, row by row.

    Parameters
    ----------
    a, b, c : (n, 2) float64 or (2,) float64
        Points; shapes broadcast (any leading shape ``(..., 2)``).

    Returns
    -------
    (n,) int8
        +1 where the angle a-c-b is acute (c strictly outside the closed
        ball of diameter ab), -1 where it is obtuse (c strictly inside the
        open ball), 0 where it is right (c on the circle of diameter ab) or c
        coincides with a or b. The leading broadcast shape is kept.

    Raises
    ------
    InputError
        ``bad_shape`` or ``non_finite`` as :func:`orient2d`.

    Notes
    -----
    The determinant has the shape of orient2d's (two products of coordinate
    differences, added instead of subtracted), so Shewchuk's bound
    ``ccwerrboundA * (|t1| + |t2|)`` holds for it unchanged: each difference,
    each product and the sum round once. Terms of equal sign never cancel and
    are decided by the filter; an exactly zero term leaves the other, whose
    sign is exact; the remaining undecided rows are recomputed exactly.
    Used for the diametral-ball tests of §9.1.2 (Case 1 / Case 2) and for the
    acute angles of Exercises 9.2-9.4. References: methods text §9.1;
    DESIGN.md "Geometry robustness".
    """
    (a, b, c), lead = _prepare((a, b, c), 2, "abc")
    t1 = (a[:, 0] - c[:, 0]) * (b[:, 0] - c[:, 0])
    t2 = (a[:, 1] - c[:, 1]) * (b[:, 1] - c[:, 1])
    det = t1 + t2
    errbound = _CCW_ERRBOUND_A * (np.abs(t1) + np.abs(t2))
    out = _sign_int8(det)
    undecided = ~(np.abs(det) > errbound) & (t1 != 0.0) & (t2 != 0.0)
    rows = np.flatnonzero(undecided)
    if rows.size:
        _dot2d_rows(a, b, c, rows, out)
    return out.reshape(lead)


def indiametral(a, b, p) -> np.ndarray:
    """Exact test of p against the diametral ball of the segment ab, row by row.

    Parameters
    ----------
    a, b, p : (n, 2) float64 or (2,) float64
        Segment endpoints and tested points; shapes broadcast.

    Returns
    -------
    (n,) int8
        +1 where p lies strictly inside the open ball of diameter ab (the
        ball :math:`B_f^{min}` of §9.1.1; the angle a-p-b is obtuse), 0 on
        its circle (or at a or b), -1 strictly outside. The sign of
        ``-(a - p) . (b - p)``, see :func:`dot2d`.

    Raises
    ------
    InputError
        ``bad_shape`` or ``non_finite`` as :func:`orient2d`.

    Notes
    -----
    References: methods text §9.1.1 (Table 9.1), §9.1.2 (Case 1: the ball
    is empty; Case 2: it holds points).
    """
    return -dot2d(a, b, p)


def incircle(a, b, c, d) -> np.ndarray:
    """Exact in-circle test of d against the circle through a, b, c, row by row.

    Parameters
    ----------
    a, b, c, d : (n, 2) float64 or (2,) float64
        Points; shapes broadcast (any leading shape ``(..., 2)``).

    Returns
    -------
    (n,) int8
        For counter-clockwise a, b, c: +1 where d lies strictly inside their
        circumcircle, -1 strictly outside, 0 exactly on it. The sign reverses
        for clockwise a, b, c (it is the sign of Shewchuk's determinant), and
        is 0 whenever a, b, c are collinear and d is on their line.

    Raises
    ------
    InputError
        ``bad_shape`` or ``non_finite`` as :func:`orient2d`.

    Notes
    -----
    Float64 evaluation with Shewchuk's ``iccerrboundA``; undecided rows are
    recomputed exactly. Ties (0) are reported, not broken: the Delaunay
    kernel breaks them by symbolic perturbation on its own. References:
    DESIGN.md "Geometry robustness"; methods text §9.1.
    """
    (a, b, c, d), lead = _prepare((a, b, c, d), 2, "abcd")
    adx = a[:, 0] - d[:, 0]
    bdx = b[:, 0] - d[:, 0]
    cdx = c[:, 0] - d[:, 0]
    ady = a[:, 1] - d[:, 1]
    bdy = b[:, 1] - d[:, 1]
    cdy = c[:, 1] - d[:, 1]
    bdxcdy = bdx * cdy
    cdxbdy = cdx * bdy
    alift = adx * adx + ady * ady
    cdxady = cdx * ady
    adxcdy = adx * cdy
    blift = bdx * bdx + bdy * bdy
    adxbdy = adx * bdy
    bdxady = bdx * ady
    clift = cdx * cdx + cdy * cdy
    det = alift * (bdxcdy - cdxbdy) + blift * (cdxady - adxcdy) + clift * (adxbdy - bdxady)
    permanent = (
        (np.abs(bdxcdy) + np.abs(cdxbdy)) * alift
        + (np.abs(cdxady) + np.abs(adxcdy)) * blift
        + (np.abs(adxbdy) + np.abs(bdxady)) * clift
    )
    out = _sign_int8(det)
    rows = np.flatnonzero(~(np.abs(det) > _ICC_ERRBOUND_A * permanent))
    if rows.size:
        _incircle_rows(a, b, c, d, rows, out)
    return out.reshape(lead)
