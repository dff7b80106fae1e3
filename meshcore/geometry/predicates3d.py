"""Robust 3D predicates: exact signs of orient3d, in-sphere and 3D dot products.

The 3D half of :mod:`meshcore.geometry.predicates` (whose module
documentation gives the scheme: float filter with a rigorous error bound,
exact expansion arithmetic from :mod:`meshcore.geometry.expansions` on the
undecided rows), with the same two interfaces: vectorized :func:`orient3d`,
:func:`insphere` and :func:`dot3d`, and scalar ``@njit`` functions
(``*_scalar``; ``*_exact`` and ``*_filtered`` with a scratch buffer) for the
compiled kernels (:mod:`meshcore.delaunay.kernel3d`, tetrahedralization,
surface validation, 3D optimization).

The exact insphere has stages: a double-double evaluation, the determinant
of the rounded differences formed exactly (exact when the differences are;
otherwise trusted beyond Shewchuk's ``isperrboundB``), then the 5 x 5 lifted
determinant of the original coordinates. :func:`insphere_perturbed` breaks
exact co-spherical ties by symbolic perturbation of the liftings in
lexicographic order of the points (Simulation of Simplicity), so that the 3D
Delaunay kernel's result depends only on the point set.

References
----------
Methods text §9.2-§9.3 (face classification and enforcement are signs of
these determinants); DESIGN.md "Geometry robustness".
"""

from __future__ import annotations

import numpy as np
from numba import njit

from meshcore.geometry.expansions import (
    _EPS,
    _RESULT_ERRBOUND,
    WORK_SIZE,
    _cross4,
    _cross_exact,
    _dd_add,
    _dd_cross,
    _dd_lift,
    _dd_minor3,
    _dd_mul,
    _expansion_product,
    _expansion_sum,
    _scale_expansion,
    _set_diff,
    _sign_of,
    _two_diff,
    two_product,
)
from meshcore.geometry.predicates import _prepare, _sign_int8

__all__ = [
    "dot3d",
    "insphere",
    "insphere_exact",
    "insphere_filtered",
    "insphere_perturbed",
    "insphere_scalar",
    "insphere_tie",
    "orient3d",
    "orient3d_exact",
    "orient3d_filtered",
    "orient3d_scalar",
]


_O3D_ERRBOUND_A = (7.0 + 56.0 * _EPS) * _EPS


_ISP_ERRBOUND_A = (16.0 + 224.0 * _EPS) * _EPS


_ISP_ERRBOUND_B = (5.0 + 72.0 * _EPS) * _EPS


_ISP_ERRBOUND_C = (71.0 + 1408.0 * _EPS) * _EPS * _EPS


# Double-double insphere: 256 u**2 of the permanent, well above the ~100 u**2
# its operations can stack up (see _insphere_dd).
_ISP_ERRBOUND_DD = 256.0 * _EPS * _EPS


@njit(cache=True)
def orient3d_exact(ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz, work):
    """Exact sign of Shewchuk's orient3d determinant; ``work`` is scratch.

    Returns
    -------
    int
        +1 if d lies below the plane through a, b, c (a, b, c appearing
        counter-clockwise seen from above), -1 above, 0 coplanar.

    Four points sharing a coordinate (in an axis plane: a column of the
    determinant is zero) give 0 without the expansions: the coplanar facet
    points of axis-aligned boxes are most of the exact calls there.
    """
    if (
        (ax == dx and bx == dx and cx == dx)
        or (ay == dy and by == dy and cy == dy)
        or (az == dz and bz == dz and cz == dz)
    ):
        return 0
    d = work[0:18]
    n = np.empty(9, np.int64)
    n[0] = _set_diff(ax, dx, d[0:2])
    n[1] = _set_diff(ay, dy, d[2:4])
    n[2] = _set_diff(az, dz, d[4:6])
    n[3] = _set_diff(bx, dx, d[6:8])
    n[4] = _set_diff(by, dy, d[8:10])
    n[5] = _set_diff(bz, dz, d[10:12])
    n[6] = _set_diff(cx, dx, d[12:14])
    n[7] = _set_diff(cy, dy, d[14:16])
    n[8] = _set_diff(cz, dz, d[16:18])
    xa, ya, za = d[0:2], d[2:4], d[4:6]
    xb, yb, zb = d[6:8], d[8:10], d[10:12]
    xc, yc, zc = d[12:14], d[14:16], d[16:18]
    scratch = work[100:300]
    cross = work[300:340]
    term = work[340:500]
    acc = work[500:1000]
    acc2 = work[1000:1500]
    t1 = work[1500:1600]
    t2 = work[1600:1800]
    alen = np.int64(0)
    for k in range(3):
        if k == 0:
            # adz * (bdx*cdy - cdx*bdy)
            z, zl = za, n[2]
            clen = _cross_exact(xb, n[3], yc, n[7], xc, n[6], yb, n[4], cross, scratch)
        elif k == 1:
            # bdz * (cdx*ady - adx*cdy)
            z, zl = zb, n[5]
            clen = _cross_exact(xc, n[6], ya, n[1], xa, n[0], yc, n[7], cross, scratch)
        else:
            # cdz * (adx*bdy - bdx*ady)
            z, zl = zc, n[8]
            clen = _cross_exact(xa, n[0], yb, n[4], xb, n[3], ya, n[1], cross, scratch)
        tlen = _expansion_product(clen, cross, zl, z, term, t1, t2)
        nl = _expansion_sum(alen, acc, tlen, term, acc2)
        for i in range(nl):
            acc[i] = acc2[i]
        alen = nl
    return _sign_of(alen, acc)


@njit(cache=True)
def orient3d_scalar(ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz):
    """Sign of Shewchuk's orient3d(a, b, c, d) (float filter, then exact).

    Returns
    -------
    int
        +1 if d lies below the plane through a, b, c (a, b, c appearing
        counter-clockwise seen from above), -1 above, 0 coplanar.
    """
    adx = ax - dx
    bdx = bx - dx
    cdx = cx - dx
    ady = ay - dy
    bdy = by - dy
    cdy = cy - dy
    adz = az - dz
    bdz = bz - dz
    cdz = cz - dz
    bdxcdy = bdx * cdy
    cdxbdy = cdx * bdy
    cdxady = cdx * ady
    adxcdy = adx * cdy
    adxbdy = adx * bdy
    bdxady = bdx * ady
    det = adz * (bdxcdy - cdxbdy) + bdz * (cdxady - adxcdy) + cdz * (adxbdy - bdxady)
    permanent = (
        (abs(bdxcdy) + abs(cdxbdy)) * abs(adz)
        + (abs(cdxady) + abs(adxcdy)) * abs(bdz)
        + (abs(adxbdy) + abs(bdxady)) * abs(cdz)
    )
    errbound = _O3D_ERRBOUND_A * permanent
    if det > errbound:
        return 1
    if -det > errbound:
        return -1
    return orient3d_exact(ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz, np.empty(2048))


@njit(cache=True)
def orient3d_filtered(ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz, work):
    """:func:`orient3d_scalar` with a ``(WORK_SIZE,)`` scratch buffer for the exact stage."""
    adx = ax - dx
    bdx = bx - dx
    cdx = cx - dx
    ady = ay - dy
    bdy = by - dy
    cdy = cy - dy
    adz = az - dz
    bdz = bz - dz
    cdz = cz - dz
    bdxcdy = bdx * cdy
    cdxbdy = cdx * bdy
    cdxady = cdx * ady
    adxcdy = adx * cdy
    adxbdy = adx * bdy
    bdxady = bdx * ady
    det = adz * (bdxcdy - cdxbdy) + bdz * (cdxady - adxcdy) + cdz * (adxbdy - bdxady)
    permanent = (
        (abs(bdxcdy) + abs(cdxbdy)) * abs(adz)
        + (abs(cdxady) + abs(adxcdy)) * abs(bdz)
        + (abs(adxbdy) + abs(bdxady)) * abs(cdz)
    )
    errbound = _O3D_ERRBOUND_A * permanent
    if det > errbound:
        return 1
    if -det > errbound:
        return -1
    return orient3d_exact(ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz, work)


# Row subsets of the 5 x 5 lifted determinant: the 10 pairs and 10 triples of
# the points 0..4 in increasing order, and for each triple the indices of its
# three sub-pairs (omitting its first, second, third element).
_PAIRS = np.array(
    [[0, 1], [0, 2], [0, 3], [0, 4], [1, 2], [1, 3], [1, 4], [2, 3], [2, 4], [3, 4]], np.int64
)


_TRIPLES = np.array(
    [
        [0, 1, 2],
        [0, 1, 3],
        [0, 1, 4],
        [0, 2, 3],
        [0, 2, 4],
        [0, 3, 4],
        [1, 2, 3],
        [1, 2, 4],
        [1, 3, 4],
        [2, 3, 4],
    ],
    np.int64,
)


@njit(cache=True)
def _pair_index(i, j):
    # Position of (i, j), i < j, in _PAIRS.
    return i * 4 - i * (i + 1) // 2 + j - 1


def _m4_triples() -> np.ndarray:
    """For each omitted row r and each position of the four others, the triple left."""
    index = {tuple(t): k for k, t in enumerate(_TRIPLES.tolist())}
    out = np.empty((5, 4), np.int64)
    for r in range(5):
        rows = [s for s in range(5) if s != r]
        for pos in range(4):
            out[r, pos] = index[tuple(rows[:pos] + rows[pos + 1 :])]
    return out


_M4_TRIPLE = _m4_triples()


@njit(cache=True)
def _insphere_raw(p, work):
    """Exact sign of the lifted 5 x 5 determinant of the rows ``p`` (5, 3).

    ``det [x, y, z, x**2 + y**2 + z**2, 1]`` over the rows in order, with
    original coordinates (no rounded differences): 2 x 2 minors (4
    components), 3 x 3 (24), 4 x 4 with the column of ones (96), lifted terms
    (1152) and their sum (at most 5760 components), as Shewchuk's
    ``insphereexact``. ``work`` needs :data:`WORK_SIZE` slots.
    """
    m2 = work[0:40]
    m2len = np.empty(10, np.int64)
    for q in range(10):
        i = _PAIRS[q, 0]
        j = _PAIRS[q, 1]
        m2len[q] = _cross4(p[i, 0], p[j, 1], p[j, 0], p[i, 1], m2[4 * q : 4 * q + 4])
    m3 = work[40:280]
    m3len = np.empty(10, np.int64)
    s8a = work[280:288]
    s8b = work[288:296]
    s8c = work[296:304]
    s16 = work[304:320]
    for q in range(10):
        i = _TRIPLES[q, 0]
        j = _TRIPLES[q, 1]
        k = _TRIPLES[q, 2]
        # det rows (i, j, k), columns (x, y, z), along the z column:
        # z_i * m2(j, k) - z_j * m2(i, k) + z_k * m2(i, j)
        jk = _pair_index(j, k)
        ik = _pair_index(i, k)
        ij = _pair_index(i, j)
        na = 0
        if m2len[jk] > 0 and p[i, 2] != 0.0:
            na = _scale_expansion(m2len[jk], m2[4 * jk : 4 * jk + 4], p[i, 2], s8a)
        nb = 0
        if m2len[ik] > 0 and p[j, 2] != 0.0:
            nb = _scale_expansion(m2len[ik], m2[4 * ik : 4 * ik + 4], -p[j, 2], s8b)
        nc = 0
        if m2len[ij] > 0 and p[k, 2] != 0.0:
            nc = _scale_expansion(m2len[ij], m2[4 * ij : 4 * ij + 4], p[k, 2], s8c)
        n16 = _expansion_sum(na, s8a, nb, s8b, s16)
        m3len[q] = _expansion_sum(n16, s16, nc, s8c, m3[24 * q : 24 * q + 24])
    m4 = work[320:800]
    m4len = np.empty(5, np.int64)
    t48a = work[800:824]
    t48b = work[824:920]
    for r in range(5):
        # det of the four rows other than r, columns (x, y, z, 1), along the
        # column of ones: sum over the row position pos of (-1)**(pos + 1 + 4)
        # times the 3 x 3 minor of the other three rows (_M4_TRIPLE[r, pos]).
        out = m4[96 * r : 96 * r + 96]
        alen = np.int64(0)
        for pos in range(4):
            q = _M4_TRIPLE[r, pos]
            ln = m3len[q]
            src = m3[24 * q : 24 * q + 24]
            if pos % 2 == 0:
                for z in range(ln):
                    t48a[z] = -src[z]
            else:
                for z in range(ln):
                    t48a[z] = src[z]
            nl = _expansion_sum(alen, out, ln, t48a, t48b)
            for z in range(nl):
                out[z] = t48b[z]
            alen = nl
        m4len[r] = alen
    lift = work[920:926]
    sq = work[926:928]
    l4 = work[928:934]
    term = work[1000:2152]
    tmp1 = work[2200:2400]
    tmp2 = work[2400:3600]
    acc = work[3600:9400]
    acc2 = work[9400:15200]
    alen = np.int64(0)
    for r in range(5):
        if m4len[r] == 0:
            continue
        # Lifting x**2 + y**2 + z**2 of row r, exactly (at most 6 components).
        llen = np.int64(0)
        for c in range(3):
            hi, lo = two_product(p[r, c], p[r, c])
            sq[0] = lo
            sq[1] = hi
            nl = _expansion_sum(llen, lift, np.int64(2), sq, l4)
            for z in range(nl):
                lift[z] = l4[z]
            llen = nl
        if llen == 1 and lift[0] == 0.0:
            continue
        # Cofactor sign of the lifting column (column 4 of 5): (-1)**(r + 1 + 4).
        if r % 2 == 0:
            for z in range(llen):
                lift[z] = -lift[z]
        tlen = _expansion_product(m4len[r], m4[96 * r : 96 * r + 96], llen, lift, term, tmp1, tmp2)
        nl = _expansion_sum(alen, acc, tlen, term, acc2)
        for z in range(nl):
            acc[z] = acc2[z]
        alen = nl
    return _sign_of(alen, acc)


@njit(cache=True)
def _insphere_from_diffs(aex, aey, aez, bex, bey, bez, cex, cey, cez, dex, dey, dez, work):
    """Exact lifted determinant of the four difference rows, as an expansion.

    Shewchuk's formula ``(dlift*abc - clift*dab) + (blift*cda - alift*bcd)``
    with every product formed exactly; exact when the differences are. The
    result (at most 1152 components) is left in ``work[1100:2252]`` and its
    length returned.
    """
    ab = work[0:4]
    bc = work[4:8]
    cd = work[8:12]
    da = work[12:16]
    ac = work[16:20]
    bd = work[20:24]
    nab = _cross4(aex, bey, bex, aey, ab)
    nbc = _cross4(bex, cey, cex, bey, bc)
    ncd = _cross4(cex, dey, dex, cey, cd)
    nda = _cross4(dex, aey, aex, dey, da)
    nac = _cross4(aex, cey, cex, aey, ac)
    nbd = _cross4(bex, dey, dex, bey, bd)
    s1 = work[24:32]
    s2 = work[32:40]
    s3 = work[40:48]
    s12 = work[48:64]
    t3 = work[64:160]  # abc, bcd, cda, dab: 24 slots each
    t3len = np.empty(4, np.int64)
    for k in range(4):
        if k == 0:  # abc = aez*bc - bez*ac + cez*ab
            z1, e1, l1, z2, e2, l2, z3, e3, l3 = aez, bc, nbc, -bez, ac, nac, cez, ab, nab
        elif k == 1:  # bcd = bez*cd - cez*bd + dez*bc
            z1, e1, l1, z2, e2, l2, z3, e3, l3 = bez, cd, ncd, -cez, bd, nbd, dez, bc, nbc
        elif k == 2:  # cda = cez*da + dez*ac + aez*cd
            z1, e1, l1, z2, e2, l2, z3, e3, l3 = cez, da, nda, dez, ac, nac, aez, cd, ncd
        else:  # dab = dez*ab + aez*bd + bez*da
            z1, e1, l1, z2, e2, l2, z3, e3, l3 = dez, ab, nab, aez, bd, nbd, bez, da, nda
        n1 = _scale_expansion(l1, e1, z1, s1) if (l1 > 0 and z1 != 0.0) else 0
        n2 = _scale_expansion(l2, e2, z2, s2) if (l2 > 0 and z2 != 0.0) else 0
        n3 = _scale_expansion(l3, e3, z3, s3) if (l3 > 0 and z3 != 0.0) else 0
        n12 = _expansion_sum(n1, s1, n2, s2, s12)
        t3len[k] = _expansion_sum(n12, s12, n3, s3, t3[24 * k : 24 * k + 24])
    lift = work[160:166]
    sq = work[166:168]
    l4 = work[168:174]
    term = work[200:488]
    tmp1 = work[488:540]
    tmp2 = work[540:830]
    acc = work[1100:2252]
    acc2 = work[2300:3452]
    alen = np.int64(0)
    for k in range(4):
        # det = dlift*abc - clift*dab + blift*cda - alift*bcd
        if k == 0:
            x, y, z, src, sgn = dex, dey, dez, 0, 1.0
        elif k == 1:
            x, y, z, src, sgn = cex, cey, cez, 3, -1.0
        elif k == 2:
            x, y, z, src, sgn = bex, bey, bez, 2, 1.0
        else:
            x, y, z, src, sgn = aex, aey, aez, 1, -1.0
        tl = t3len[src]
        if tl == 0:
            continue
        llen = np.int64(0)
        for c in range(3):
            v = x if c == 0 else (y if c == 1 else z)
            hi, lo = two_product(v, v)
            sq[0] = lo * sgn
            sq[1] = hi * sgn
            nl = _expansion_sum(llen, lift, np.int64(2), sq, l4)
            for q in range(nl):
                lift[q] = l4[q]
            llen = nl
        if llen == 1 and lift[0] == 0.0:
            continue
        tlen = _expansion_product(tl, t3[24 * src : 24 * src + 24], llen, lift, term, tmp1, tmp2)
        nl = _expansion_sum(alen, acc, tlen, term, acc2)
        for q in range(nl):
            acc[q] = acc2[q]
        alen = nl
    return alen


@njit(cache=True)
def _insphere_dd(
    aex, aext, aey, aeyt, aez, aezt, bex, bext, bey, beyt, bez, bezt,
    cex, cext, cey, ceyt, cez, cezt, dex, dext, dey, deyt, dez, dezt,
):  # fmt: skip
    """Shewchuk's insphere formula in double-double on the exact differences.

    Returns the double-double determinant's high part; its error is below
    about 100 u**2 times the permanent (every operation errs by at most
    7u**2 of its own magnitude, about a dozen of them stacked on any term).
    """
    abh, abl = _dd_cross(aex, aext, bey, beyt, bex, bext, aey, aeyt)
    bch, bcl = _dd_cross(bex, bext, cey, ceyt, cex, cext, bey, beyt)
    cdh, cdl = _dd_cross(cex, cext, dey, deyt, dex, dext, cey, ceyt)
    dah, dal = _dd_cross(dex, dext, aey, aeyt, aex, aext, dey, deyt)
    ach, acl = _dd_cross(aex, aext, cey, ceyt, cex, cext, aey, aeyt)
    bdh, bdl = _dd_cross(bex, bext, dey, deyt, dex, dext, bey, beyt)
    # abc = aez*bc - bez*ac + cez*ab, ... (Shewchuk's insphere)
    abch, abcl = _dd_minor3(aez, aezt, bch, bcl, -bez, -bezt, ach, acl, cez, cezt, abh, abl)
    bcdh, bcdl = _dd_minor3(bez, bezt, cdh, cdl, -cez, -cezt, bdh, bdl, dez, dezt, bch, bcl)
    cdah, cdal = _dd_minor3(cez, cezt, dah, dal, dez, dezt, ach, acl, aez, aezt, cdh, cdl)
    dabh, dabl = _dd_minor3(dez, dezt, abh, abl, aez, aezt, bdh, bdl, bez, bezt, dah, dal)
    alh, all_ = _dd_lift(aex, aext, aey, aeyt, aez, aezt)
    blh, bll = _dd_lift(bex, bext, bey, beyt, bez, bezt)
    clh, cll = _dd_lift(cex, cext, cey, ceyt, cez, cezt)
    dlh, dll = _dd_lift(dex, dext, dey, deyt, dez, dezt)
    t1h, t1l = _dd_mul(dlh, dll, abch, abcl)
    t2h, t2l = _dd_mul(clh, cll, dabh, dabl)
    t3h, t3l = _dd_mul(blh, bll, cdah, cdal)
    t4h, t4l = _dd_mul(alh, all_, bcdh, bcdl)
    xh, xl = _dd_add(t1h, t1l, -t2h, -t2l)
    yh, yl = _dd_add(t3h, t3l, -t4h, -t4l)
    h, _ = _dd_add(xh, xl, yh, yl)
    return h


@njit(cache=True)
def insphere_exact(ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz, ex, ey, ez, work):
    """Exact sign of Shewchuk's insphere determinant; ``work`` is scratch.

    Parameters
    ----------
    ax, ay, az, ..., ex, ey, ez : float64
        a, b, c, d define the sphere, e is tested.
    work : (WORK_SIZE,) float64
        Scratch buffer, overwritten.

    Returns
    -------
    int
        For positively oriented a, b, c, d (``orient3d(a, b, c, d) > 0``):
        +1 if e is strictly inside their circumsphere, -1 strictly outside,
        0 on it; the signs reverse for a negatively oriented tetrahedron.

    Notes
    -----
    Stages: (DD) the determinant of the exact differences in double-double
    arithmetic, trusted beyond 256 u**2 times the permanent; then Shewchuk's
    adaptive stages: (B) the determinant of the rounded
    differences ``p - e`` formed exactly, the exact answer when the
    differences are exact and otherwise trusted beyond ``isperrboundB``
    times the permanent; (C) first-order corrections for the differences'
    rounding errors, trusted beyond ``isperrboundC``; then the 5 x 5 lifted
    determinant of the original coordinates (``insphereexact``).
    """
    aex, aext = _two_diff(ax, ex)
    aey, aeyt = _two_diff(ay, ey)
    aez, aezt = _two_diff(az, ez)
    bex, bext = _two_diff(bx, ex)
    bey, beyt = _two_diff(by, ey)
    bez, bezt = _two_diff(bz, ez)
    cex, cext = _two_diff(cx, ex)
    cey, ceyt = _two_diff(cy, ey)
    cez, cezt = _two_diff(cz, ez)
    dex, dext = _two_diff(dx, ex)
    dey, deyt = _two_diff(dy, ey)
    dez, dezt = _two_diff(dz, ez)
    permanent = _insphere_permanent(aex, aey, aez, bex, bey, bez, cex, cey, cez, dex, dey, dez)
    # Stage DD: the exact differences in double-double arithmetic.
    det = _insphere_dd(
        aex, aext, aey, aeyt, aez, aezt, bex, bext, bey, beyt, bez, bezt,
        cex, cext, cey, ceyt, cez, cezt, dex, dext, dey, deyt, dez, dezt,
    )  # fmt: skip
    errbound = _ISP_ERRBOUND_DD * permanent
    if det > errbound:
        return 1
    if -det > errbound:
        return -1
    n = _insphere_from_diffs(aex, aey, aez, bex, bey, bez, cex, cey, cez, dex, dey, dez, work)
    exact = (
        aext == 0.0
        and aeyt == 0.0
        and aezt == 0.0
        and bext == 0.0
        and beyt == 0.0
        and bezt == 0.0
        and cext == 0.0
        and ceyt == 0.0
        and cezt == 0.0
        and dext == 0.0
        and deyt == 0.0
        and dezt == 0.0
    )
    if exact:
        return _sign_of(n, work[1100:2252])
    est = 0.0
    for i in range(n):
        est += work[1100 + i]
    errbound = _ISP_ERRBOUND_B * permanent
    if est >= errbound and est > 0.0:
        return 1
    if -est >= errbound and est < 0.0:
        return -1
    # Stage C (Shewchuk's insphereadapt): first-order corrections for the
    # tails of the differences, with the bound isperrboundC.
    m = work[3500:3504]
    n_ = _cross4(aex, bey, bex, aey, m)
    ab3 = m[n_ - 1] if n_ > 0 else 0.0
    n_ = _cross4(bex, cey, cex, bey, m)
    bc3 = m[n_ - 1] if n_ > 0 else 0.0
    n_ = _cross4(cex, dey, dex, cey, m)
    cd3 = m[n_ - 1] if n_ > 0 else 0.0
    n_ = _cross4(dex, aey, aex, dey, m)
    da3 = m[n_ - 1] if n_ > 0 else 0.0
    n_ = _cross4(aex, cey, cex, aey, m)
    ac3 = m[n_ - 1] if n_ > 0 else 0.0
    n_ = _cross4(bex, dey, dex, bey, m)
    bd3 = m[n_ - 1] if n_ > 0 else 0.0
    det = est
    errbound = _ISP_ERRBOUND_C * permanent + _RESULT_ERRBOUND * abs(det)
    abeps = (aex * beyt + bey * aext) - (aey * bext + bex * aeyt)
    bceps = (bex * ceyt + cey * bext) - (bey * cext + cex * beyt)
    cdeps = (cex * deyt + dey * cext) - (cey * dext + dex * ceyt)
    daeps = (dex * aeyt + aey * dext) - (dey * aext + aex * deyt)
    aceps = (aex * ceyt + cey * aext) - (aey * cext + cex * aeyt)
    bdeps = (bex * deyt + dey * bext) - (bey * dext + dex * beyt)
    det += (
        (bex * bex + bey * bey + bez * bez)
        * ((cez * daeps + dez * aceps + aez * cdeps) + (cezt * da3 + dezt * ac3 + aezt * cd3))
        + (dex * dex + dey * dey + dez * dez)
        * ((aez * bceps - bez * aceps + cez * abeps) + (aezt * bc3 - bezt * ac3 + cezt * ab3))
    ) - (
        (aex * aex + aey * aey + aez * aez)
        * ((bez * cdeps - cez * bdeps + dez * bceps) + (bezt * cd3 - cezt * bd3 + dezt * bc3))
        + (cex * cex + cey * cey + cez * cez)
        * ((dez * abeps + aez * bdeps + bez * daeps) + (dezt * ab3 + aezt * bd3 + bezt * da3))
    )
    det += 2.0 * (
        (
            (bex * bext + bey * beyt + bez * bezt) * (cez * da3 + dez * ac3 + aez * cd3)
            + (dex * dext + dey * deyt + dez * dezt) * (aez * bc3 - bez * ac3 + cez * ab3)
        )
        - (
            (aex * aext + aey * aeyt + aez * aezt) * (bez * cd3 - cez * bd3 + dez * bc3)
            + (cex * cext + cey * ceyt + cez * cezt) * (dez * ab3 + aez * bd3 + bez * da3)
        )
    )
    if det >= errbound and det > 0.0:
        return 1
    if -det >= errbound and det < 0.0:
        return -1
    p = np.empty((5, 3))
    p[0, 0], p[0, 1], p[0, 2] = ax, ay, az
    p[1, 0], p[1, 1], p[1, 2] = bx, by, bz
    p[2, 0], p[2, 1], p[2, 2] = cx, cy, cz
    p[3, 0], p[3, 1], p[3, 2] = dx, dy, dz
    p[4, 0], p[4, 1], p[4, 2] = ex, ey, ez
    return _insphere_raw(p, work)


@njit(cache=True)
def _insphere_permanent(aex, aey, aez, bex, bey, bez, cex, cey, cez, dex, dey, dez):
    """Shewchuk's permanent bounding the magnitude of the insphere terms."""
    aexbeyplus = abs(aex * bey)
    bexaeyplus = abs(bex * aey)
    bexceyplus = abs(bex * cey)
    cexbeyplus = abs(cex * bey)
    cexdeyplus = abs(cex * dey)
    dexceyplus = abs(dex * cey)
    dexaeyplus = abs(dex * aey)
    aexdeyplus = abs(aex * dey)
    aexceyplus = abs(aex * cey)
    cexaeyplus = abs(cex * aey)
    bexdeyplus = abs(bex * dey)
    dexbeyplus = abs(dex * bey)
    aezplus = abs(aez)
    bezplus = abs(bez)
    cezplus = abs(cez)
    dezplus = abs(dez)
    alift = aex * aex + aey * aey + aez * aez
    blift = bex * bex + bey * bey + bez * bez
    clift = cex * cex + cey * cey + cez * cez
    dlift = dex * dex + dey * dey + dez * dez
    return (
        (
            (cexdeyplus + dexceyplus) * bezplus
            + (dexbeyplus + bexdeyplus) * cezplus
            + (bexceyplus + cexbeyplus) * dezplus
        )
        * alift
        + (
            (dexaeyplus + aexdeyplus) * cezplus
            + (aexceyplus + cexaeyplus) * dezplus
            + (cexdeyplus + dexceyplus) * aezplus
        )
        * blift
        + (
            (aexbeyplus + bexaeyplus) * dezplus
            + (bexdeyplus + dexbeyplus) * aezplus
            + (dexaeyplus + aexdeyplus) * bezplus
        )
        * clift
        + (
            (bexceyplus + cexbeyplus) * aezplus
            + (cexaeyplus + aexceyplus) * bezplus
            + (aexbeyplus + bexaeyplus) * cezplus
        )
        * dlift
    )


@njit(cache=True)
def _insphere_float(aex, aey, aez, bex, bey, bez, cex, cey, cez, dex, dey, dez):
    """Shewchuk's float insphere determinant of the differences ``p - e``."""
    ab = aex * bey - bex * aey
    bc = bex * cey - cex * bey
    cd = cex * dey - dex * cey
    da = dex * aey - aex * dey
    ac = aex * cey - cex * aey
    bd = bex * dey - dex * bey
    abc = aez * bc - bez * ac + cez * ab
    bcd = bez * cd - cez * bd + dez * bc
    cda = cez * da + dez * ac + aez * cd
    dab = dez * ab + aez * bd + bez * da
    alift = aex * aex + aey * aey + aez * aez
    blift = bex * bex + bey * bey + bez * bez
    clift = cex * cex + cey * cey + cez * cez
    dlift = dex * dex + dey * dey + dez * dez
    return (dlift * abc - clift * dab) + (blift * cda - alift * bcd)


@njit(cache=True)
def insphere_filtered(ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz, ex, ey, ez, work):
    """:func:`insphere_scalar` with a ``(WORK_SIZE,)`` scratch buffer for the exact stage."""
    aex = ax - ex
    aey = ay - ey
    aez = az - ez
    bex = bx - ex
    bey = by - ey
    bez = bz - ez
    cex = cx - ex
    cey = cy - ey
    cez = cz - ez
    dex = dx - ex
    dey = dy - ey
    dez = dz - ez
    det = _insphere_float(aex, aey, aez, bex, bey, bez, cex, cey, cez, dex, dey, dez)
    permanent = _insphere_permanent(aex, aey, aez, bex, bey, bez, cex, cey, cez, dex, dey, dez)
    errbound = _ISP_ERRBOUND_A * permanent
    if det > errbound:
        return 1
    if -det > errbound:
        return -1
    return insphere_exact(ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz, ex, ey, ez, work)


@njit(cache=True)
def insphere_scalar(ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz, ex, ey, ez):
    """Sign of the insphere test of e against the sphere through a, b, c, d.

    Parameters
    ----------
    ax, ay, az, ..., ex, ey, ez : float64

    Returns
    -------
    int
        For positively oriented a, b, c, d (``orient3d(a, b, c, d) > 0``):
        +1 if e is strictly inside the circumsphere, -1 strictly outside,
        0 exactly on it; reversed for a negatively oriented tetrahedron.
    """
    return insphere_filtered(
        ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz, ex, ey, ez, np.empty(WORK_SIZE)
    )


@njit(cache=True)
def _lex_less3(p, q):
    return p[0] < q[0] or (p[0] == q[0] and (p[1] < q[1] or (p[1] == q[1] and p[2] < q[2])))


@njit(cache=True)
def insphere_perturbed(p, work):
    """Insphere sign under symbolic perturbation: never 0 for a proper tetrahedron.

    Parameters
    ----------
    p : (5, 3) float64
        Rows a, b, c, d (the tetrahedron, ``orient3d(a, b, c, d) != 0``) and
        e (the tested point), pairwise distinct.
    work : (WORK_SIZE,) float64
        Scratch buffer, overwritten.

    Returns
    -------
    int
        The exact sign of :func:`insphere_exact` when it is not 0. On an exact
        tie, the sign after raising each point's lifting
        ``x**2 + y**2 + z**2`` by ``eps**(r + 1)``, ``r`` its rank in
        lexicographic ``(x, y, z)`` order (smallest first), for an
        infinitesimal ``eps > 0`` (Edelsbrunner and Mücke's Simulation of
        Simplicity, as the 2D kernel's ``incircle`` ties). Returns 0 only
        when a, b, c, d are coplanar.

    Notes
    -----
    The determinant is linear in the liftings, and the coefficient of
    point q's lifting is ``orient3d`` of the tetrahedron with q replaced by
    e (for q among a..d) or ``-orient3d(a, b, c, d)`` (for e). The points are
    visited in rank order and the first nonzero coefficient decides: the
    one of e is nonzero, so the loop ends. The perturbed sign depends only
    on the five points, not on their order in any input, and is unchanged by
    exact translations and power-of-two scalings.
    """
    s = insphere_exact(
        p[0, 0], p[0, 1], p[0, 2], p[1, 0], p[1, 1], p[1, 2], p[2, 0], p[2, 1], p[2, 2],
        p[3, 0], p[3, 1], p[3, 2], p[4, 0], p[4, 1], p[4, 2], work,
    )  # fmt: skip
    if s != 0:
        return s
    return insphere_tie(p, work)


@njit(cache=True)
def insphere_tie(p, work):
    """The sign :func:`insphere_perturbed` gives to an exact co-spherical tie.

    Parameters
    ----------
    p : (5, 3) float64
        Rows a, b, c, d, e with ``insphere_exact(a, b, c, d, e) == 0``.
    work : (WORK_SIZE,) float64
        Scratch buffer, overwritten.

    Returns
    -------
    int
        The coefficient sign of the first point, in lexicographic order,
        whose lifting's coefficient is not zero (see
        :func:`insphere_perturbed`); 0 only when a, b, c, d are coplanar.
        For callers that already know the exact sign is 0.
    """
    done = 0
    for _ in range(5):
        m = -1
        for i in range(5):
            if not (done >> i) & 1 and (m < 0 or _lex_less3(p[i], p[m])):
                m = i
        done |= 1 << m
        # orient3d of a, b, c, d with row m replaced by e (m == 4: the
        # coefficient of e's lifting, -orient3d(a, b, c, d)).
        i0 = 4 if m == 0 else 0
        i1 = 4 if m == 1 else 1
        i2 = 4 if m == 2 else 2
        i3 = 4 if m == 3 else 3
        s = orient3d_filtered(
            p[i0, 0], p[i0, 1], p[i0, 2], p[i1, 0], p[i1, 1], p[i1, 2],
            p[i2, 0], p[i2, 1], p[i2, 2], p[i3, 0], p[i3, 1], p[i3, 2], work,
        )  # fmt: skip
        if m == 4:
            return -s
        if s != 0:
            return s
    return 0


@njit(cache=True)
def _orient3d_rows(a, b, c, d, rows, out):
    work = np.empty(WORK_SIZE)
    for r in rows:
        out[r] = orient3d_exact(
            a[r, 0],
            a[r, 1],
            a[r, 2],
            b[r, 0],
            b[r, 1],
            b[r, 2],
            c[r, 0],
            c[r, 1],
            c[r, 2],
            d[r, 0],
            d[r, 1],
            d[r, 2],
            work,
        )


@njit(cache=True)
def _insphere_rows(a, b, c, d, e, rows, out):
    work = np.empty(WORK_SIZE)
    for r in rows:
        out[r] = insphere_exact(
            a[r, 0], a[r, 1], a[r, 2], b[r, 0], b[r, 1], b[r, 2], c[r, 0], c[r, 1], c[r, 2],
            d[r, 0], d[r, 1], d[r, 2], e[r, 0], e[r, 1], e[r, 2], work,
        )  # fmt: skip


@njit(cache=True)
def _insphere_perturbed_rows(a, b, c, d, e, out):
    work = np.empty(WORK_SIZE)
    p = np.empty((5, 3))
    for r in range(a.shape[0]):
        for k in range(3):
            p[0, k] = a[r, k]
            p[1, k] = b[r, k]
            p[2, k] = c[r, k]
            p[3, k] = d[r, k]
            p[4, k] = e[r, k]
        out[r] = insphere_perturbed(p, work)


def orient3d(a, b, c, d) -> np.ndarray:
    """Exact orientation of point quadruples in 3D, row by row.

    Parameters
    ----------
    a, b, c, d : (n, 3) float64 or (3,) float64
        Points; shapes broadcast (any leading shape ``(..., 3)``).

    Returns
    -------
    (n,) int8
        Shewchuk's convention: +1 where d lies below the plane through a, b, c
        (a, b, c appearing counter-clockwise seen from above, i.e. from the
        side the right-hand normal (b - a) x (c - a) points to), -1 above,
        0 exactly coplanar.

    Raises
    ------
    InputError
        ``bad_shape`` or ``non_finite`` as :func:`orient2d`.

    Notes
    -----
    Float64 evaluation with Shewchuk's ``o3derrboundA``; undecided rows are
    recomputed exactly. References: DESIGN.md "Geometry robustness".
    """
    (a, b, c, d), lead = _prepare((a, b, c, d), 3, "abcd")
    adx = a[:, 0] - d[:, 0]
    bdx = b[:, 0] - d[:, 0]
    cdx = c[:, 0] - d[:, 0]
    ady = a[:, 1] - d[:, 1]
    bdy = b[:, 1] - d[:, 1]
    cdy = c[:, 1] - d[:, 1]
    adz = a[:, 2] - d[:, 2]
    bdz = b[:, 2] - d[:, 2]
    cdz = c[:, 2] - d[:, 2]
    bdxcdy = bdx * cdy
    cdxbdy = cdx * bdy
    cdxady = cdx * ady
    adxcdy = adx * cdy
    adxbdy = adx * bdy
    bdxady = bdx * ady
    det = adz * (bdxcdy - cdxbdy) + bdz * (cdxady - adxcdy) + cdz * (adxbdy - bdxady)
    permanent = (
        (np.abs(bdxcdy) + np.abs(cdxbdy)) * np.abs(adz)
        + (np.abs(cdxady) + np.abs(adxcdy)) * np.abs(bdz)
        + (np.abs(adxbdy) + np.abs(bdxady)) * np.abs(cdz)
    )
    out = _sign_int8(det)
    rows = np.flatnonzero(~(np.abs(det) > _O3D_ERRBOUND_A * permanent))
    if rows.size:
        _orient3d_rows(a, b, c, d, rows, out)
    return out.reshape(lead)


def insphere(a, b, c, d, e, *, perturbed: bool = False) -> np.ndarray:
    """Exact insphere test of e against the sphere through a, b, c, d, row by row.

    Parameters
    ----------
    a, b, c, d, e : (n, 3) float64 or (3,) float64
        Points; shapes broadcast (any leading shape ``(..., 3)``).
    perturbed : bool
        Break exact ties by the symbolic perturbation of
        :func:`insphere_perturbed` (the one the 3D Delaunay kernel uses):
        then 0 only where a, b, c, d are coplanar. The five points of a row
        must be pairwise distinct.

    Returns
    -------
    (n,) int8
        For positively oriented a, b, c, d (``orient3d(a, b, c, d) > 0``):
        +1 where e lies strictly inside their circumsphere, -1 strictly
        outside, 0 exactly on it. The sign reverses for negatively oriented
        a, b, c, d (it is the sign of Shewchuk's determinant) and is 0
        whenever a, b, c, d are coplanar and e is on their circle or plane
        in a degenerate way. The leading broadcast shape is kept.

    Raises
    ------
    InputError
        ``bad_shape`` or ``non_finite`` as :func:`orient2d`.

    Notes
    -----
    Float64 evaluation with Shewchuk's ``isperrboundA``; undecided rows are
    recomputed exactly (:func:`insphere_exact`). References: DESIGN.md
    "Geometry robustness"; methods text §9.2-§9.3 (a face is Delaunay when
    some sphere through it is empty).
    """
    (a, b, c, d, e), lead = _prepare((a, b, c, d, e), 3, "abcde")
    aex, aey, aez = (a - e).T
    bex, bey, bez = (b - e).T
    cex, cey, cez = (c - e).T
    dex, dey, dez = (d - e).T
    ab = aex * bey - bex * aey
    bc = bex * cey - cex * bey
    cd = cex * dey - dex * cey
    da = dex * aey - aex * dey
    ac = aex * cey - cex * aey
    bd = bex * dey - dex * bey
    abc = aez * bc - bez * ac + cez * ab
    bcd = bez * cd - cez * bd + dez * bc
    cda = cez * da + dez * ac + aez * cd
    dab = dez * ab + aez * bd + bez * da
    alift = aex * aex + aey * aey + aez * aez
    blift = bex * bex + bey * bey + bez * bez
    clift = cex * cex + cey * cey + cez * cez
    dlift = dex * dex + dey * dey + dez * dez
    det = (dlift * abc - clift * dab) + (blift * cda - alift * bcd)
    aez, bez, cez, dez = np.abs(aez), np.abs(bez), np.abs(cez), np.abs(dez)
    ab_ = np.abs(aex * bey) + np.abs(bex * aey)
    bc_ = np.abs(bex * cey) + np.abs(cex * bey)
    cd_ = np.abs(cex * dey) + np.abs(dex * cey)
    da_ = np.abs(dex * aey) + np.abs(aex * dey)
    ac_ = np.abs(aex * cey) + np.abs(cex * aey)
    bd_ = np.abs(bex * dey) + np.abs(dex * bey)
    permanent = (
        (cd_ * bez + bd_ * cez + bc_ * dez) * alift
        + (da_ * cez + ac_ * dez + cd_ * aez) * blift
        + (ab_ * dez + bd_ * aez + da_ * bez) * clift
        + (bc_ * aez + ac_ * bez + ab_ * cez) * dlift
    )
    out = _sign_int8(det)
    rows = np.flatnonzero(~(np.abs(det) > _ISP_ERRBOUND_A * permanent))
    if rows.size:
        if perturbed:
            sub = np.empty(rows.size, np.int8)
            _insphere_perturbed_rows(a[rows], b[rows], c[rows], d[rows], e[rows], sub)
            out[rows] = sub
        else:
            _insphere_rows(a, b, c, d, e, rows, out)
    return out.reshape(lead)


def dot3d(a, b, c) -> np.ndarray:
    """Exact sign of the dot product ``(a - c) . (b - c)`` in 3D, row by row.

    Parameters
    ----------
    a, b, c : (n, 3) float64 or (3,) float64
        Points; shapes broadcast.

    Returns
    -------
    (n,) int8
        +1 where the angle a-c-b is acute (c strictly outside the closed
        diametral ball of ab), -1 where it is obtuse (c strictly inside the
        open ball: c *encroaches* the segment ab, §9.2), 0 on the sphere or
        where c coincides with a or b.

    Raises
    ------
    InputError
        ``bad_shape`` or ``non_finite`` as :func:`orient3d`.

    Notes
    -----
    Float evaluation with the bound ``6 eps * sum |terms|`` (each of the
    three differences, products and sums rounds once per operation; the
    bound is Shewchuk's ``ccwerrboundA`` argument with one more term), then
    exact expansion arithmetic for the rows it cannot decide (rare: points
    within rounding of the sphere). Used by Delaunay refinement in 3D
    (:mod:`meshcore.tets.refinement`) for encroached subsegments.
    References: methods text §9.2 (the ball B_AB); DESIGN.md "Geometry robustness".
    """
    (a, b, c), lead = _prepare((a, b, c), 3, "abc")
    t = (a - c) * (b - c)
    det = t.sum(axis=1)
    errbound = (6.0 + 64.0 * _EPS) * _EPS * np.abs(t).sum(axis=1)
    out = _sign_int8(det)
    rows = np.flatnonzero(~(np.abs(det) > errbound))
    if rows.size:  # only rows within rounding of zero
        sub = np.empty(rows.size, np.int8)
        _dot3d_rows(a[rows], b[rows], c[rows], sub)
        out[rows] = sub
    return out.reshape(lead)


@njit(cache=True)
def _dot3d_rows(a, b, c, out):
    """The exact sign of ``(a - c) . (b - c)`` row by row, by expansions: each difference
    exact in two components, each product in eight, the sum in 24."""
    u = np.empty(2)
    v = np.empty(2)
    p = np.empty(8)
    t1 = np.empty(8)
    t2 = np.empty(8)
    acc = np.empty(24)
    h = np.empty(24)
    for r in range(a.shape[0]):
        n = np.int64(0)
        for k in range(3):
            ulen = _set_diff(a[r, k], c[r, k], u)
            vlen = _set_diff(b[r, k], c[r, k], v)
            plen = _expansion_product(ulen, u, vlen, v, p, t1, t2)
            n = _expansion_sum(n, acc, plen, p, h)
            acc[:n] = h[:n]
        out[r] = _sign_of(n, acc)
