"""The Delaunay kernel: one Delaunay triangulation of 2D points for every method.

DESIGN.md, "One Delaunay kernel": admissible boundaries (§9.1), the
triangulator, the medial axis (§9.4), patterns and quad combination all stand
on :func:`delaunay`. Every geometric decision is a sign from
:mod:`meshcore.geometry.predicates` (exact after a float filter), so the
result is a true Delaunay triangulation of the input, whatever its
degeneracies.

Algorithm (a compiled sequential loop, numba ``@njit(cache=True)``):

1. Validate; rescale by a power of two (exact, changes no predicate sign) so
   that the coordinates sit in ``[-1, 1]`` and no product over- or underflows.
2. Order the points for insertion: biased randomized insertion order (BRIO:
   each point joins round ``r`` with probability ``2**-(r+1)``, the rounds
   are inserted from the smallest to the largest), each round sorted along a
   Hilbert curve, alternately forwards and backwards. The "random" draw is a
   hash of the point index, so the same input always gives the same run.
3. Incremental insertion with *ghost triangles*: the hull edges are closed by
   triangles on a vertex at infinity, so that there is no super-triangle
   whose removal could leave flat triangles or miss hull points. A point is
   located by a visibility walk that starts at a triangle of the nearest
   already inserted point along the Hilbert curve, inserted by a 1->3 split
   (inside a triangle, or outside the hull in a ghost triangle) or a 2->4
   split (on an edge), and the Delaunay property is restored by Lawson
   flips. Duplicates are found on the way (a point on two edges of its
   triangle), so they cost no separate pass. A point on a hull edge (every
   point of a sampled boundary's collinear runs) is in the closed hull, so
   the flips test only the two real triangles' outer edges, never the
   ghosts'. The walk starts of the next three points are prefetched: at
   10^6 points BRIO's rounds leave a point's neighbourhood anywhere in
   memory, and the walk's first loads were cache misses one after another.

Choices where the methods text leaves freedom:

* **Ties.** Four co-circular points are resolved by symbolic perturbation:
  each point's lifting ``x**2 + y**2`` is raised by ``eps**(r + 1)``, where
  ``r`` is its rank in lexicographic ``(x, y)`` order (smallest first). The
  perturbed point set is in general position, so its Delaunay triangulation is
  unique, and it is a Delaunay triangulation of the unperturbed points. The
  result therefore depends only on the point *set*: the same input gives the
  same triangles, a permutation of the input gives the same triangles mapped
  through the permutation, and exact translations and power-of-two scalings
  change nothing.
* **Hull.** A ghost triangle's "circumcircle" is its open outer half-plane;
  a point exactly on the line of a hull edge is in conflict only if it lies
  strictly inside the edge, which is then split. Collinear hull points
  therefore become hull vertices and no triangle is flat.

References
----------
Methods text §9.1 (Delaunay triangulation and admissible segments), §9.4
(the empty Delaunay triangulation); DESIGN.md "Geometry robustness" and "One
Delaunay kernel". O. Devillers, S. Pion and M. Teillaud, "Walking in a
triangulation" (2002); N. Amenta, S. Choi and G. Rote, "Incremental constructions con BRIO" (2003);
H. Edelsbrunner and E. Mücke, "Simulation of Simplicity" (1990).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numba import njit

from meshcore.delaunay.brio import brio_round, brio_rounds
from meshcore.delaunay.prefetch import prefetch
from meshcore.domain.numbers import refuse_non_numbers
from meshcore.errors import InputError
from meshcore.geometry.expansions import two_product, two_sum
from meshcore.geometry.ordering import radix_sort
from meshcore.geometry.predicates import (
    WORK_SIZE,
    incircle_exact,
    orient2d_exact,
)

__all__ = ["IncrementalDelaunay", "Triangulation", "delaunay"]

_CCW_ERRBOUND_A = (3.0 + 16.0 * 2.0**-53) * 2.0**-53
_ICC_ERRBOUND_A = (10.0 + 96.0 * 2.0**-53) * 2.0**-53
_HILBERT_BITS = 24
_CHUNK = 1 << 16
_MAX_POINTS = 1 << 28  # corners 3 * (2n) must fit the kernel's int32 arrays
# Smallest magnitude a nonzero coordinate may have after rescaling the largest
# to [0.5, 1): keeps every product of the exact predicates a normal number.
_MIN_SCALED = 2.0**-140

_OK, _DUPLICATE, _COLLINEAR = 0, 1, 2


@dataclass(frozen=True, eq=False)
class Triangulation:
    """A Delaunay triangulation of 2D points.

    Attributes
    ----------
    points : (n, 2) float64
        The input points (read-only).
    triangles : (m, 3) int64
        Point indices of each triangle, counter-clockwise (read-only).
    neighbors : (m, 3) int64
        ``neighbors[t, i]`` is the triangle across the edge opposite vertex
        ``triangles[t, i]``, or -1 when that edge is on the convex hull; the
        convention of ``scipy.spatial.Delaunay`` (read-only).
    """

    points: np.ndarray
    triangles: np.ndarray
    neighbors: np.ndarray


# ---------------------------------------------------------------------------
# Insertion order: BRIO rounds, Hilbert order within each round
# ---------------------------------------------------------------------------


def _hilbert_table() -> np.ndarray:
    """The Hilbert curve four levels at a time: entry ``(state << 8) | (x << 4)
    | y`` (``state = 2 * swap + complement``, ``x`` and ``y`` four bits of the
    cell's coordinates) holds the eight bits of the curve index those levels
    add, and the state after them in bits 8-9 (the per-level rule of
    :func:`_brio_hilbert_keys`, tabulated)."""
    out = np.empty(1024, np.int64)
    for state in range(4):
        for xb in range(16):
            for yb in range(16):
                sw, cp = state >> 1, state & 1
                d = 0
                for lvl in range(3, -1, -1):
                    bx = ((xb >> lvl) & 1) ^ cp
                    by = ((yb >> lvl) & 1) ^ cp
                    t = (bx ^ by) & sw
                    rx, ry = bx ^ t, by ^ t
                    d = (d << 2) | ((3 * rx) ^ ry)
                    sw ^= 1 - ry
                    cp ^= (1 - ry) & rx
                out[(state << 8) | (xb << 4) | yb] = d | (((sw << 1) | cp) << 8)
    return out


_HILBERT_TABLE = _hilbert_table()


@njit(cache=True)
def _brio_hilbert_keys(pts, factor, nbits):
    """Each point's BRIO round and Hilbert index, and the number of rounds.

    The coordinates are taken times ``factor`` (a power of two, so exactly)
    to keep the bounding box finite.
    """
    n = pts.shape[0]
    xmin = pts[0, 0] * factor
    xmax = xmin
    ymin = pts[0, 1] * factor
    ymax = ymin
    for i in range(n):
        x = pts[i, 0] * factor
        y = pts[i, 1] * factor
        xmin = min(xmin, x)
        xmax = max(xmax, x)
        ymin = min(ymin, y)
        ymax = max(ymax, y)
    extent = max(xmax - xmin, ymax - ymin)
    if extent <= 0.0:
        extent = 1.0
    side = (1 << nbits) - 1
    scale = side / extent
    # Rounds: the last round holds about half the points, the one before a
    # quarter, ...; the first round gathers the smallest 2**-rounds fraction.
    rounds = brio_rounds(n)
    rnd = np.empty(n, np.int64)
    curve = np.empty(n, np.int64)
    head = nbits % 4
    for i in range(n):
        hx = int((pts[i, 0] * factor - xmin) * scale)
        hy = int((pts[i, 1] * factor - ymin) * scale)
        hx = min(max(hx, 0), side)
        hy = min(max(hy, 0), side)
        # Hilbert index, branch-free: the transform applied to the lower bits
        # is one of {identity, swap, complement, both}, tracked as two bits;
        # the top ``nbits % 4`` levels one at a time, the others four at a
        # time from _HILBERT_TABLE (the same rule, tabulated).
        d = 0
        sw = 0
        cp = 0
        for lvl in range(nbits - 1, nbits - 1 - head, -1):
            bx = ((hx >> lvl) & 1) ^ cp
            by = ((hy >> lvl) & 1) ^ cp
            t = (bx ^ by) & sw
            rx = bx ^ t
            ry = by ^ t
            d = (d << 2) | ((3 * rx) ^ ry)
            sw ^= 1 - ry
            cp ^= (1 - ry) & rx
        state = (sw << 1) | cp
        for lvl in range(nbits - head - 4, -1, -4):
            e = _HILBERT_TABLE[(state << 8) | (((hx >> lvl) & 15) << 4) | ((hy >> lvl) & 15)]
            d = (d << 8) | (e & 255)
            state = e >> 8
        rnd[i] = brio_round(i, rounds)
        curve[i] = d
    return rnd, curve, rounds + 1


@njit(cache=True)
def _insertion_order(rnd, curve, nrounds):
    """The insertion order and the walk hints' inputs, from one sort.

    ``order``: the points round after round, each round along the Hilbert
    curve, forwards in even rounds and backwards in odd ones (so that each
    round starts where the previous one ended), points of one curve cell in
    index order: the stable sort of the key ``(round, index or its
    complement)``. ``along``: the insertion positions in curve order (one
    cell's in increasing position), ``curve_sorted`` their curve indices, as
    :func:`_walk_hints` takes them. One radix sort by curve index (the round
    carried in the low bits of the moved values) and a counting sort by
    round give both, where sorting the keys and then the curve indices in
    insertion order took two.
    """
    n = curve.shape[0]
    carried = np.empty(n, np.int64)
    for i in range(n):
        carried[i] = (i << 6) | rnd[i]
    curve_sorted, carried = radix_sort(curve, carried)
    fill = np.zeros(nrounds + 1, np.int64)
    for i in range(n):
        fill[rnd[i] + 1] += 1
    for r in range(nrounds):
        fill[r + 1] += fill[r]
    order = np.empty(n, np.int64)
    along = np.empty(n, np.int64)
    for j in range(n):  # even rounds, forwards
        r = carried[j] & 63
        if r % 2 == 0:
            along[j] = fill[r]
            order[fill[r]] = carried[j] >> 6
            fill[r] += 1
    j = n - 1
    while j >= 0:  # odd rounds, backwards cell by cell, one cell in index order
        g = j
        while g > 0 and curve_sorted[g - 1] == curve_sorted[j]:
            g -= 1
        for jj in range(g, j + 1):
            r = carried[jj] & 63
            if r % 2 == 1:
                along[jj] = fill[r]
                order[fill[r]] = carried[jj] >> 6
                fill[r] += 1
        j = g - 1
    j = 0
    while j < n:  # one cell's positions in increasing order
        g = j
        while g + 1 < n and curve_sorted[g + 1] == curve_sorted[j]:
            g += 1
        if g > j:
            along[j : g + 1] = np.sort(along[j : g + 1])
        j = g + 1
    return order, along, curve_sorted


@njit(cache=True)
def _walk_hints(seq, curve_sorted):
    """For each insertion position, an earlier-inserted point near it on the curve.

    ``seq[j]`` is the insertion position of the j-th point along the Hilbert
    curve and ``curve_sorted[j]`` its curve index. For each point the nearest
    point on either side along the curve that was inserted before it is found
    with two monotonic-stack sweeps (previous / next smaller element); the
    closer of the two is the walk's starting vertex. -1: none.
    """
    n = seq.shape[0]
    left = np.empty(n, np.int64)
    stack = np.empty(n, np.int64)
    sp = 0
    for j in range(n):
        while sp > 0 and seq[stack[sp - 1]] > seq[j]:
            sp -= 1
        left[j] = stack[sp - 1] if sp > 0 else -1
        stack[sp] = j
        sp += 1
    hint = np.empty(n, np.int32)
    sp = 0
    for j in range(n - 1, -1, -1):
        while sp > 0 and seq[stack[sp - 1]] > seq[j]:
            sp -= 1
        right = stack[sp - 1] if sp > 0 else -1
        stack[sp] = j
        sp += 1
        best = left[j]
        if right >= 0 and (
            best < 0 or curve_sorted[right] - curve_sorted[j] < curve_sorted[j] - curve_sorted[best]
        ):
            best = right
        hint[seq[j]] = seq[best] if best >= 0 else -1
    return hint


# ---------------------------------------------------------------------------
# Predicates as the kernel uses them (float filter inline, exact call rare)
# ---------------------------------------------------------------------------


# _orient and _incircle repeat the filters of predicates.orient2d_filtered and
# incircle_filtered, inlined: calling those instead measured 5-18 % slower here.
@njit(cache=True, inline="always")
def _orient(pts, a, b, c, work):
    ax = pts[a, 0]
    ay = pts[a, 1]
    bx = pts[b, 0]
    by = pts[b, 1]
    cx = pts[c, 0]
    cy = pts[c, 1]
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


@njit(cache=True, inline="always")
def _lex_less(pts, a, b):
    return pts[a, 0] < pts[b, 0] or (pts[a, 0] == pts[b, 0] and pts[a, 1] < pts[b, 1])


@njit(cache=True)
def _incircle_tie(pts, a, b, c, d, work):
    """Symbolic perturbation of an exact co-circular tie (a, b, c CCW).

    Lifting ``z_p += eps**(rank(p) + 1)`` (rank in lexicographic order) makes
    the sign that of the derivative of the determinant with respect to the
    lifting of the lexicographically smallest of the four points:
    ``-orient(a, b, c)`` for d, ``orient(d, b, c)`` for a, ``orient(a, d, c)``
    for b and ``orient(a, b, d)`` for c. None is zero for distinct points.
    """
    m = a
    if _lex_less(pts, b, m):
        m = b
    if _lex_less(pts, c, m):
        m = c
    if _lex_less(pts, d, m):
        m = d
    if m == d:
        return -1
    if m == a:
        return _orient(pts, d, b, c, work)
    if m == b:
        return _orient(pts, a, d, c, work)
    return _orient(pts, a, b, d, work)


@njit(cache=True)
def _sum4_sign(p, q, r, s):
    """Exact sign of ``p + q - r - s`` (Shewchuk's Two_Two_Sum: a
    non-overlapping expansion, whose sign is that of its largest nonzero
    component)."""
    s1, e1 = two_sum(p, q)
    s2, e2 = two_sum(-r, -s)
    i, x0 = two_sum(e1, e2)
    j, x1 = two_sum(s1, i)
    k, x2 = two_sum(x1, s2)
    x3, x2b = two_sum(j, k)
    for x in (x3, x2b, x2, x0):
        if x > 0.0:
            return 1
        if x < 0.0:
            return -1
    return 0


@njit(cache=True)
def _incircle_two_lines(ax, ay, bx, by, cx, cy, dx, dy):
    """Exact in-circle sign when two of the four points lie on one horizontal
    line and the other two, ``d`` among them, on another (a rectangle's
    sampled top and bottom, the commonest exact call; an axis-parallel
    rectangle's four corners give 0 here, the co-circular tie); 2 when they
    do not.

    With ``u, v`` the pair on one line and ``w`` the point of ``a, b, c`` on
    ``d``'s line, the circle through ``u, v, w`` is centred above
    ``m = (u_x + v_x) / 2``, so ``d`` is inside it exactly when
    ``|d_x - m| < |w_x - m|``, i.e. ``(d_x - w_x)(d_x + w_x - u_x - v_x) < 0``;
    the determinant's sign is that times ``orient(a, b, c)``, which is the
    product of two coordinate differences' signs.
    """
    if dy == ay and by == cy and by != dy:
        inside = (1 if dx < ax else -1) * _sum4_sign(dx, ax, bx, cx)
        turn = (1 if by > ay else -1) * (1 if bx > cx else -1)
    elif dy == by and ay == cy and ay != dy:
        inside = (1 if dx < bx else -1) * _sum4_sign(dx, bx, ax, cx)
        turn = -(1 if by > ay else -1) * (1 if cx > ax else -1)
    elif dy == cy and ay == by and ay != dy:
        inside = (1 if dx < cx else -1) * _sum4_sign(dx, cx, ax, bx)
        turn = (1 if bx > ax else -1) * (1 if cy > ay else -1)
    else:
        return 2
    return turn * inside


@njit(cache=True, inline="always")
def _sign(x):
    return 1 if x > 0.0 else (-1 if x < 0.0 else 0)


@njit(cache=True)
def _corner_inside(delta, omega, hu, hv):
    """Whether a point lies inside a circle, from offsets along two
    perpendicular lines through a corner ``P``: the circle meets one line at
    offsets ``hu, hv`` from ``P``, the other at ``omega`` and, by the power
    of ``P``, at ``hu hv / omega``; the point, at offset ``delta`` on the
    second line, is inside exactly when it lies strictly between those two,
    i.e. when ``(delta - omega)(delta omega - hu hv) / omega < 0``.
    +1 inside, -1 outside, 0 on the circle; 2 when an offset given is not
    the exact difference of the coordinates (not settled here)."""
    if omega == 0.0:
        return 2
    p1, e1 = two_product(delta, omega)
    p2, e2 = two_product(hu, hv)
    return -_sign(delta - omega) * _sign(omega) * _sum4_sign(p1, e1, p2, e2)


@njit(cache=True, inline="always")
def _exact_diff(a, b):
    """``a - b`` and whether it is exact."""
    x, e = two_sum(a, -b)
    return x, e == 0.0


@njit(cache=True)
def _corner_vertical(ax, ay, bx, by, cx, cy, dx, dy):
    """:func:`_incircle_corner` when ``d`` and ``w`` share their ``x``."""
    if dx == cx and ay == by:
        wy, ux, vx, line, turn = cy, ax, bx, ay, _sign(bx - ax) * _sign(cy - ay)
    elif dx == ax and by == cy:
        wy, ux, vx, line, turn = ay, bx, cx, by, _sign(cx - bx) * _sign(ay - by)
    elif dx == bx and ay == cy:
        wy, ux, vx, line, turn = by, ax, cx, ay, _sign(ax - cx) * _sign(by - ay)
    else:
        return 2
    omega, ok1 = _exact_diff(wy, line)
    delta, ok2 = _exact_diff(dy, line)
    hu, ok3 = _exact_diff(ux, dx)
    hv, ok4 = _exact_diff(vx, dx)
    if not (ok1 and ok2 and ok3 and ok4) or turn == 0 or dy == wy:
        return 2
    return turn * _corner_inside(delta, omega, hu, hv)


@njit(cache=True)
def _incircle_corner(ax, ay, bx, by, cx, cy, dx, dy):
    """Exact in-circle sign when two of ``a, b, c`` lie on one axis-parallel
    line and the third, ``w``, on the perpendicular line through ``d`` (the
    samples near a rectangle's corner, where the Delaunay triangles along
    the corner's bisector are nearly co-circular); 2 when they do not, or
    when a coordinate difference is not exact.

    The lines cross at ``P``; :func:`_corner_inside` decides by the power of
    ``P``, and ``orient(a, b, c)`` is the product of two coordinate
    differences' signs (two of its corners share a coordinate). With ``d``
    and ``w`` on a horizontal line the answer is minus that of the mirror
    image in ``y = x``.
    """
    s = _corner_vertical(ax, ay, bx, by, cx, cy, dx, dy)
    if s == 2:
        s = -_corner_vertical(ay, ax, by, bx, cy, cx, dy, dx)
        if s == -2:
            return 2
    return s


@njit(cache=True, inline="always")
def _incircle(pts, a, b, c, d, work):
    """Perturbed in-circle sign of d against CCW (a, b, c); never 0."""
    ax = pts[a, 0]
    ay = pts[a, 1]
    bx = pts[b, 0]
    by = pts[b, 1]
    cx = pts[c, 0]
    cy = pts[c, 1]
    dx = pts[d, 0]
    dy = pts[d, 1]
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
    return _incircle_near_zero(pts, a, b, c, d, work)


@njit(cache=True)
def _incircle_near_zero(pts, a, b, c, d, work):
    """:func:`_incircle` when the float filter cannot decide: an exact sign
    (the special cases of axis-parallel lines first: two horizontal or two
    vertical lines, which include the axis-parallel rectangles' exact ties,
    then a corner), the tie broken symbolically. Not inlined, so that the
    common path stays small."""
    ax = pts[a, 0]
    ay = pts[a, 1]
    bx = pts[b, 0]
    by = pts[b, 1]
    cx = pts[c, 0]
    cy = pts[c, 1]
    dx = pts[d, 0]
    dy = pts[d, 1]
    s = _incircle_two_lines(ax, ay, bx, by, cx, cy, dx, dy)
    if s == 2:  # two vertical lines: the mirror image in y = x, whose sign is opposite
        s = -_incircle_two_lines(ay, ax, by, bx, cy, cx, dy, dx)
        if s == -2:
            s = _incircle_corner(ax, ay, bx, by, cx, cy, dx, dy)
    if s == 2:
        s = incircle_exact(ax, ay, bx, by, cx, cy, dx, dy, work)
    if s != 0:
        return s
    return _incircle_tie(pts, a, b, c, d, work)


# ---------------------------------------------------------------------------
# The triangulation data structure
# ---------------------------------------------------------------------------
#
# Triangle t has corners 3t, 3t+1, 3t+2 (counter-clockwise). V[k] is the
# vertex at corner k (-1: the vertex at infinity of a ghost triangle); the
# edge of corner k is the one opposite V[k]; A[k] is the corner of the
# neighbouring triangle opposite the same edge. A closed triangulation of n
# points plus infinity has exactly 2n - 2 triangles, so the arrays are
# allocated once at that size and never grow.


@njit(cache=True, inline="always")
def _nxt(k):
    return k - 2 if k % 3 == 2 else k + 1


@njit(cache=True, inline="always")
def _prv(k):
    return k + 2 if k % 3 == 0 else k - 1


@njit(cache=True, inline="always")
def _is_ghost(V, t):
    return V[3 * t] < 0 or V[3 * t + 1] < 0 or V[3 * t + 2] < 0


@njit(cache=True, inline="always")
def _touch(V, vt, t):
    """Record real triangle t as the walk start of its three vertices."""
    a = V[3 * t]
    b = V[3 * t + 1]
    c = V[3 * t + 2]
    if a >= 0 and b >= 0 and c >= 0:
        vt[a] = t
        vt[b] = t
        vt[c] = t


@njit(cache=True)
def _start(pts, order, V, A, vt, state, work):
    """Build the first triangle and its three ghosts; reorder if needed.

    Finds the first point not collinear with the first two (moving it to
    position 2 of the insertion order) or reports duplicates / collinearity.
    """
    n = pts.shape[0]
    if pts[0, 0] == pts[1, 0] and pts[0, 1] == pts[1, 1]:
        state[2] = _DUPLICATE
        state[3] = order[0]
        state[4] = order[1]
        return
    k = 2
    while k < n and _orient(pts, 0, 1, k, work) == 0:
        k += 1
    if k == n:
        state[2] = _COLLINEAR
        return
    if k != 2:
        for c in range(2):
            tmp = pts[2, c]
            pts[2, c] = pts[k, c]
            pts[k, c] = tmp
        tmp = order[2]
        order[2] = order[k]
        order[k] = tmp
    a, b, c = 0, 1, 2
    if _orient(pts, 0, 1, 2, work) < 0:
        a, b = 1, 0
    # T0 = (a, b, c); G1 = (c, b, inf); G2 = (a, c, inf); G3 = (b, a, inf)
    V[0], V[1], V[2] = a, b, c
    V[3], V[4], V[5] = c, b, -1
    V[6], V[7], V[8] = a, c, -1
    V[9], V[10], V[11] = b, a, -1
    A[0], A[5] = 5, 0
    A[1], A[8] = 8, 1
    A[2], A[11] = 11, 2
    A[3], A[10] = 10, 3  # edge (b, inf)
    A[4], A[6] = 6, 4  # edge (c, inf)
    A[7], A[9] = 9, 7  # edge (a, inf)
    vt[0] = vt[1] = vt[2] = 0
    state[0] = 4
    state[1] = 0
    state[2] = _OK


@njit(cache=True)
def _insert_range(pts, V, A, stack, vt, hint, state, work, start, stop, log):
    """Insert points start..stop-1 (insertion order = row order of pts).

    state = [ntri, last real triangle, status, info1, info2]. ``log``
    None (whole triangulations: the logging compiled away), or room for
    the edges the insertions removed, as slot pairs ``(u, v)`` (-1: the
    vertex at infinity): the edge a 2->4 split splits, then each flip's
    diagonal. The insertions stop early, at a point whose edges might not
    fit (one removes fewer than the number of points so far plus 8).
    Returns how many pairs.
    """
    ntri = state[0]
    last = state[1]
    nlog = 0
    for p in range(start, stop):
        if log is not None:
            if 2 * (nlog + p + 8) > log.shape[0]:
                break
        # --- prefetch the walk starts of the next points, one level of
        # indirection per point ahead: vt[hint], then the triangle, then
        # its vertices (a miss each at 10^6 points, where BRIO's rounds
        # leave them anywhere in memory) ---------------------------------
        if p + 3 < stop and hint[p + 3] >= 0:
            prefetch(vt, hint[p + 3])
        if p + 2 < stop and hint[p + 2] >= 0:
            prefetch(V, 3 * vt[hint[p + 2]])
            prefetch(A, 3 * vt[hint[p + 2]])
        if p + 1 < stop and hint[p + 1] >= 0:
            b1 = 3 * vt[hint[p + 1]]
            for i in range(3):
                if V[b1 + i] >= 0:
                    prefetch(pts, V[b1 + i])
        # --- locate: visibility walk from the last triangle -------------
        h = hint[p]
        t = vt[h] if h >= 0 else last
        entry = -1
        zeros = 0
        zcorner = -1
        zcorner2 = -1
        located_ghost = False
        while True:
            base = 3 * t
            moved = False
            zeros = 0
            zcorner = -1
            for i in range(3):
                k = base + i
                if k == entry:
                    continue
                o = _orient(pts, V[_nxt(k)], V[_prv(k)], p, work)
                if o < 0:
                    kk = A[k]
                    t = kk // 3
                    entry = kk
                    moved = True
                    break
                if o == 0:
                    zeros += 1
                    if zeros == 1:
                        zcorner = k
                    else:
                        zcorner2 = k
            if not moved:
                break
            if _is_ghost(V, t):
                located_ghost = True
                break
        sp = 0
        if located_ghost or zeros == 0:
            # --- 1 -> 3 split of t (real, or ghost seen from outside) ------
            base = 3 * t
            a = V[base]
            b = V[base + 1]
            c = V[base + 2]
            a1 = A[base + 1]
            a2 = A[base + 2]
            t0 = t
            t1 = ntri
            t2 = ntri + 1
            ntri += 2
            V[3 * t0] = p
            A[3 * t0 + 1] = 3 * t1
            A[3 * t0 + 2] = 3 * t2
            V[3 * t1] = a
            V[3 * t1 + 1] = p
            V[3 * t1 + 2] = c
            A[3 * t1] = 3 * t0 + 1
            A[3 * t1 + 1] = a1
            A[3 * t1 + 2] = 3 * t2 + 1
            V[3 * t2] = a
            V[3 * t2 + 1] = b
            V[3 * t2 + 2] = p
            A[3 * t2] = 3 * t0 + 2
            A[3 * t2 + 1] = 3 * t1 + 2
            A[3 * t2 + 2] = a2
            A[a1] = 3 * t1 + 1
            A[a2] = 3 * t2 + 2
            _touch(V, vt, t0)
            _touch(V, vt, t1)
            _touch(V, vt, t2)
            stack[0] = 3 * t0
            stack[1] = 3 * t1 + 1
            stack[2] = 3 * t2 + 2
            sp = 3
            # The three triangles across p's new edges, asked for together
            # (their apexes are the first in-circle tests).
            prefetch(V, A[3 * t0])
            prefetch(V, a1)
            prefetch(V, a2)
            # The real one among the three (all three when t was real).
            if c < 0:
                last = t2
            elif b < 0:
                last = t1
            else:
                last = t0
        elif zeros == 1:
            # --- 2 -> 4 split of the edge of corner zcorner -------------------
            k = zcorner
            a = V[k]
            b = V[_nxt(k)]
            c = V[_prv(k)]
            if log is not None:
                log[2 * nlog] = b
                log[2 * nlog + 1] = c
                nlog += 1
            ab_ = A[_nxt(k)]  # edge (c, a)
            ac_ = A[_prv(k)]  # edge (a, b)
            kk = A[k]
            t2_ = kk // 3
            d = V[kk]
            bc_ = A[_nxt(kk)]  # edge (b, d)
            bb_ = A[_prv(kk)]  # edge (d, c)
            T1 = t
            T2 = ntri
            T3 = t2_
            T4 = ntri + 1
            ntri += 2
            V[3 * T1] = a
            V[3 * T1 + 1] = b
            V[3 * T1 + 2] = p
            A[3 * T1] = 3 * T4
            A[3 * T1 + 1] = 3 * T2 + 2
            A[3 * T1 + 2] = ac_
            V[3 * T2] = a
            V[3 * T2 + 1] = p
            V[3 * T2 + 2] = c
            A[3 * T2] = 3 * T3
            A[3 * T2 + 1] = ab_
            A[3 * T2 + 2] = 3 * T1 + 1
            V[3 * T3] = d
            V[3 * T3 + 1] = c
            V[3 * T3 + 2] = p
            A[3 * T3] = 3 * T2
            A[3 * T3 + 1] = 3 * T4 + 2
            A[3 * T3 + 2] = bb_
            V[3 * T4] = d
            V[3 * T4 + 1] = p
            V[3 * T4 + 2] = b
            A[3 * T4] = 3 * T1
            A[3 * T4 + 1] = bc_
            A[3 * T4 + 2] = 3 * T3 + 1
            A[ac_] = 3 * T1 + 2
            A[ab_] = 3 * T2 + 1
            A[bb_] = 3 * T3 + 2
            A[bc_] = 3 * T4 + 1
            _touch(V, vt, T1)
            _touch(V, vt, T2)
            _touch(V, vt, T3)
            _touch(V, vt, T4)
            stack[0] = 3 * T1 + 2
            stack[1] = 3 * T2 + 1
            stack[2] = 3 * T3 + 2
            stack[3] = 3 * T4 + 1
            # On a hull edge (d the vertex at infinity) p is in the closed hull,
            # so no ghost triangle can be in conflict: only the two real
            # triangles' outer edges are tested (a boundary sample's every
            # insertion, in collinear runs).
            sp = 4 if d >= 0 else 2
            last = T1
        else:
            # p lies on two edges of t: it coincides with their common vertex.
            other = 3 * t + 3 - zcorner % 3 - zcorner2 % 3
            state[0] = ntri
            state[1] = last
            state[2] = _DUPLICATE
            state[3] = p
            state[4] = V[other]
            return nlog
        # --- Lawson flips around p -----------------------------------------
        while sp > 0:
            sp -= 1
            k = stack[sp]
            kk = A[k]
            q = V[kk]
            if q < 0:
                continue  # real triangle against a hull edge: never in conflict
            kn = _nxt(k)
            kp = _prv(k)
            u = V[kn]
            v = V[kp]
            if u < 0:
                flip = _orient(pts, q, v, p, work) > 0
            elif v < 0:
                flip = _orient(pts, u, q, p, work) > 0
            else:
                flip = _incircle(pts, q, v, u, p, work) > 0
            if not flip:
                continue
            if log is not None:
                log[2 * nlog] = u
                log[2 * nlog + 1] = v
                nlog += 1
            t = k // 3
            t2 = kk // 3
            e_vp = A[kn]
            e_pu = A[kp]
            e_uq = A[_nxt(kk)]
            e_qv = A[_prv(kk)]
            b0 = 3 * t
            b2 = 3 * t2
            V[b0] = p
            V[b0 + 1] = u
            V[b0 + 2] = q
            A[b0] = e_uq
            A[b0 + 1] = b2 + 2
            A[b0 + 2] = e_pu
            V[b2] = p
            V[b2 + 1] = q
            V[b2 + 2] = v
            A[b2] = e_qv
            A[b2 + 1] = e_vp
            A[b2 + 2] = b0 + 1
            A[e_uq] = b0
            A[e_pu] = b0 + 2
            A[e_qv] = b2
            A[e_vp] = b2 + 1
            _touch(V, vt, t)
            _touch(V, vt, t2)
            if u >= 0:
                last = t
            elif v >= 0:
                last = t2
            stack[sp] = b0
            stack[sp + 1] = b2
            prefetch(V, e_uq)  # the triangles across the two new edges
            prefetch(V, e_qv)
            sp += 2
    state[0] = ntri
    state[1] = last
    state[2] = _OK
    return nlog


@njit(cache=True)
def _scan(pts):
    """(all finite, max |coordinate|, min nonzero |coordinate|) in one pass."""
    big = 0.0
    small = np.inf
    for i in range(pts.shape[0]):
        for c in range(2):
            x = pts[i, c]
            if not np.isfinite(x):
                return False, 0.0, 0.0
            x = abs(x)
            big = max(big, x)
            if x > 0.0:
                small = min(small, x)
    return True, big, small


@njit(cache=True)
def _gather(pts, order, factor):
    """Rows of pts in insertion order, times the power of two factor."""
    out = np.empty((order.shape[0], 2))
    for i in range(order.shape[0]):
        j = order[i]
        out[i, 0] = pts[j, 0] * factor
        out[i, 1] = pts[j, 1] * factor
    return out


@njit(cache=True)
def _output(V, A, ntri, order):
    """Real triangles as input point indices, and their neighbour table (the
    row of each triangle slot held in int32, as the slots: half the memory
    that the neighbour look-ups read at random)."""
    ids = np.empty(ntri, np.int32)
    m = 0
    for t in range(ntri):
        if V[3 * t] >= 0 and V[3 * t + 1] >= 0 and V[3 * t + 2] >= 0:
            ids[t] = m
            m += 1
        else:
            ids[t] = -1
    triangles = np.empty((m, 3), np.int64)
    neighbors = np.empty((m, 3), np.int64)
    for t in range(ntri):
        r = ids[t]
        if r >= 0:
            for i in range(3):
                triangles[r, i] = order[V[3 * t + i]]
                neighbors[r, i] = ids[A[3 * t + i] // 3]
    return triangles, neighbors


# ---------------------------------------------------------------------------
# Incremental use: insert more points into a built triangulation
# ---------------------------------------------------------------------------


@njit(cache=True, inline="always")
def _corner(V, t, v):
    """The corner of triangle t holding vertex v."""
    k = 3 * t
    if V[k] == v:
        return k
    if V[k + 1] == v:
        return k + 1
    return k + 2


@njit(cache=True)
def _nearest_neighbour(pts, V, A, vt, verts):
    """Squared distance from each vertex to its nearest other point: one of
    its Delaunay neighbours (the nearest-neighbour graph is a subgraph of
    every Delaunay triangulation)."""
    out = np.empty(verts.shape[0])
    for i in range(verts.shape[0]):
        v = verts[i]
        best = np.inf
        t0 = vt[v]
        t = t0
        while True:
            k = _corner(V, t, v)
            u = V[_nxt(k)]
            if u >= 0:
                dx = pts[u, 0] - pts[v, 0]
                dy = pts[u, 1] - pts[v, 1]
                best = min(best, dx * dx + dy * dy)
            t = A[_prv(k)] // 3
            if t == t0:
                break
        out[i] = best
    return out


class IncrementalDelaunay:
    """The Delaunay triangulation of a growing point set (§9.1.4's splits).

    Built like :func:`delaunay` from the first points; :meth:`insert` adds
    more, each located by a walk from a given nearby vertex and inserted by
    the kernel's own insertion and Lawson flips. The ties are broken by the
    same symbolic perturbation, so the triangles are at every moment those
    :func:`delaunay` gives for the same point set. Points are named by their
    index: the first ones as given, then each inserted batch in order.

    For :mod:`meshcore.delaunay.admissible`: each vertex's nearest other
    point (:meth:`nearest_distance`), and the arrays its compiled loop
    inserts with, one point at a time, reading the edges each insertion
    removed from the insertion's own log (:meth:`insertion_arrays`).

    Added points must lie in the convex hull of the first ones (split
    points of segments do), so that the power-of-two scale stays valid.
    """

    def __init__(self, points) -> None:
        pts_in = _validated(points)
        pts, order, V, A, vt, state, work, factor = _build(pts_in, None)
        n = len(pts_in)
        self._factor = factor
        self._n = n
        self._pts = pts
        self._slot = np.empty(n, np.int64)  # index -> slot
        self._slot[order] = np.arange(n)
        self._order = order  # slot -> index
        self._V, self._A, self._vt = V, A, vt
        self._state, self._work = state, work
        self._stack = np.empty(n + 8, np.int32)
        self._log = np.empty(2 * (n + 8), np.int32)  # one point's worst case
        self._hint = np.full(n, -1, np.int32)

    def __len__(self) -> int:
        return self._n

    def _reserve(self, extra: int) -> None:
        need = self._n + extra
        if need <= len(self._pts):
            return
        cap = max(need, 2 * len(self._pts))

        def grown(arr, size, fill=None):
            out = np.empty((size,) + arr.shape[1:], arr.dtype)
            out[: len(arr)] = arr
            if fill is not None:
                out[len(arr) :] = fill
            return out

        self._pts = grown(self._pts, cap)
        self._order = grown(self._order, cap)
        self._slot = grown(self._slot, cap)
        self._V = grown(self._V, 6 * cap)
        self._A = grown(self._A, 6 * cap)
        self._vt = grown(self._vt, cap)
        self._stack = np.empty(cap + 8, np.int32)
        self._log = np.empty(2 * (cap + 8), np.int32)
        self._hint = grown(self._hint, cap, -1)

    def insert(self, xy: np.ndarray, near: np.ndarray) -> tuple[int, int] | None:
        """Insert points ``xy`` (k, 2), walking from vertices ``near`` (k,).

        Returns None, or ``(i, j)`` when new point ``i`` coincides with point
        ``j`` (the insertion stops there, the triangulation is then unusable).
        """
        k = len(xy)
        pts, V, A, stack, vt, hint, state, work, order, slot, _ = self.insertion_arrays(k)
        n = self._n
        slots = np.arange(n, n + k)
        pts[n : n + k] = np.asarray(xy, dtype=np.float64) * self._factor
        order[n : n + k] = slots
        slot[n : n + k] = slots
        hint[n : n + k] = slot[near]
        _insert_range(pts, V, A, stack, vt, hint, state, work, n, n + k, None)
        if state[2] == _DUPLICATE:
            return int(order[state[3]]), int(order[state[4]])
        self._n = n + k
        return None

    def insertion_arrays(self, extra: int) -> tuple:
        """Room for ``extra`` more points, and the arrays a compiled caller in
        this package inserts them with, one call of :func:`_insert_range`
        per point (``pts, V, A, stack, vt, hint, state, work, order, slot,
        log``): it writes the point's scaled coordinates at slot ``n``
        (its own index, as are ``order`` and ``slot`` there), its walk
        start's slot in ``hint``, and then tells :meth:`grown_to`."""
        self._reserve(extra)
        return (
            self._pts,
            self._V,
            self._A,
            self._stack,
            self._vt,
            self._hint,
            self._state,
            self._work,
            self._order,
            self._slot,
            self._log,
        )

    def grown_to(self, n: int) -> None:
        """The points a compiled caller inserted (:meth:`insertion_arrays`)
        are now ``n`` in all."""
        self._n = n

    def nearest_distance(self, verts: np.ndarray) -> np.ndarray:
        """(k,) float64: distance from each vertex to its nearest other point."""
        d2 = _nearest_neighbour(self._pts, self._V, self._A, self._vt, self._slot[verts])
        return np.sqrt(d2) / self._factor

    def arrays(self):
        """The kernel's arrays, for compiled searches in this package.

        ``(pts, V, A, vt, order, slot)``: the points times the power-of-two
        scale, by slot; the corner arrays (module comment above); each
        slot's walk-start triangle; the index of each slot and the slot of
        each index.
        """
        return self._pts, self._V, self._A, self._vt, self._order, self._slot

    @property
    def scale(self) -> float:
        """The power of two the kernel's coordinates are multiplied by."""
        return self._factor

    def triangulation(self, points: np.ndarray) -> Triangulation:
        """The current triangulation; ``points`` are the current points (n, 2)."""
        triangles, neighbors = _output(self._V, self._A, int(self._state[0]), self._order)
        for arr in (triangles, neighbors):
            arr.flags.writeable = False
        return Triangulation(points=points, triangles=triangles, neighbors=neighbors)


# ---------------------------------------------------------------------------
# Public entry point
# ---------------------------------------------------------------------------


def _validated(points) -> np.ndarray:
    refuse_non_numbers(points, ("points",), code="bad_shape")  # numpy reads "1.5" and True
    try:
        pts = np.ascontiguousarray(points, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(
            "points must be an (n, 2) array of numbers", loc=("points",), code="bad_shape"
        ) from exc
    if pts.ndim != 2 or pts.shape[1] != 2:
        raise InputError(
            f"points must have shape (n, 2), got {pts.shape}", loc=("points",), code="bad_shape"
        )
    n = len(pts)
    if n >= _MAX_POINTS:
        raise InputError(
            f"at most {_MAX_POINTS - 1} points can be triangulated at once, got {n}",
            loc=("points",),
            code="too_many_points",
        )
    if n < 3:
        raise InputError(
            f"a triangulation needs at least 3 points, got {n}",
            loc=("points",),
            code="too_few_points",
        )
    return pts


def _scale_factor(pts: np.ndarray) -> float:
    """Power of two bringing max |coordinate| into [0.5, 1) (exact scaling);
    raises for non-finite or too widely spread coordinates (one pass)."""
    finite, big, small = _scan(pts)
    if not finite:
        bad = ~np.isfinite(pts)
        rows = np.flatnonzero(bad.any(axis=1))
        raise InputError(
            f"{rows.size} point(s) have a non-finite coordinate, first point {rows[0]}",
            code="non_finite",
            errors=[
                {
                    "loc": ["points", int(i)],
                    "msg": f"point {i} has a non-finite coordinate",
                    "type": "non_finite",
                }
                for i in rows[:20]
            ],
        )
    if big == 0.0:
        return 1.0
    e = int(np.frexp(big)[1])
    if small < np.inf and np.ldexp(small, -e) < _MIN_SCALED:
        raise InputError(
            "coordinate magnitudes span more than 2**140: the exact predicates would "
            "underflow; round tiny coordinates to zero or split the input",
            loc=("points",),
            code="coordinates_out_of_range",
        )
    return float(np.ldexp(1.0, -e))


def _duplicates_error(pts: np.ndarray, i: int, j: int) -> InputError:
    """An InputError naming duplicate points (all groups, up to 20)."""
    order = np.lexsort((pts[:, 1], pts[:, 0]))
    s = pts[order]
    same = np.flatnonzero((s[1:] == s[:-1]).all(axis=1))
    pairs = [(int(order[k]), int(order[k + 1])) for k in same[:20]]
    if not pairs:
        pairs = [(min(i, j), max(i, j))]
    pairs = [tuple(sorted(p)) for p in pairs]
    first = min(pairs)
    return InputError(
        f"{same.size or 1} duplicate point pair(s); first: points {first[0]} and {first[1]} "
        f"coincide at {pts[first[0]].tolist()}",
        code="duplicate_points",
        errors=[
            {
                "loc": ["points", b],
                "msg": f"point {b} duplicates point {a}",
                "type": "duplicate_points",
            }
            for a, b in pairs
        ],
    )


def _build(pts_in: np.ndarray, progress):
    """Insert validated points (BRIO / Hilbert order); the kernel's arrays.

    Returns ``(pts, order, V, A, vt, state, work, factor)``: the scaled
    points in insertion order, the input index of each, the corner arrays,
    each vertex's walk start, the kernel state, the exact-arithmetic work
    space and the scale factor.
    """
    n = len(pts_in)
    # A read-only view: the compiled passes see one array type whatever the
    # input's flags (numba compiles read-only and writable arrays apart).
    view = pts_in.view()
    view.flags.writeable = False
    factor = _scale_factor(view)
    # Hilbert cells: about 4n per side, so that even points sampling a curve
    # (boundaries) rarely share a cell.
    nbits = min(_HILBERT_BITS, max(8, n.bit_length() + 2))
    rnd, curve, nrounds = _brio_hilbert_keys(view, factor, nbits)
    order, along, curve_sorted = _insertion_order(rnd, curve, nrounds)
    del rnd, curve
    hint = _walk_hints(along, curve_sorted)
    del along, curve_sorted
    pts = _gather(view, order, factor)

    ntri_max = 2 * n
    V = np.empty(3 * ntri_max, np.int32)
    A = np.empty(3 * ntri_max, np.int32)
    stack = np.empty(n + 8, np.int32)
    state = np.zeros(5, np.int64)
    work = np.empty(WORK_SIZE)
    vt = np.zeros(n, np.int32)
    _start(pts, order, V, A, vt, state, work)
    if state[2] == _DUPLICATE:
        raise _duplicates_error(pts_in, int(state[3]), int(state[4]))
    if state[2] == _COLLINEAR:
        # Duplicates would also make the input collinear; name them first.
        s = pts_in[np.lexsort((pts_in[:, 1], pts_in[:, 0]))]
        if (s[1:] == s[:-1]).all(axis=1).any():
            raise _duplicates_error(pts_in, 0, 0)
        raise InputError(
            f"all {n} points are collinear: there is no triangle to make",
            loc=("points",),
            code="collinear_points",
        )
    done = 3
    while done < n:
        stop = min(n, done + _CHUNK)
        _insert_range(pts, V, A, stack, vt, hint, state, work, done, stop, None)
        if state[2] == _DUPLICATE:
            raise _duplicates_error(pts_in, int(order[state[3]]), int(order[state[4]]))
        done = stop
        if progress is not None:
            progress(done / n, f"inserted {done} of {n} points")

    return pts, order, V, A, vt, state, work, factor


def delaunay(
    points,
    *,
    progress: Callable[[float, str], None] | None = None,
) -> Triangulation:
    """Delaunay triangulation of 2D points, exact and deterministic.

    Parameters
    ----------
    points : (n, 2) float64
        Distinct, finite points, not all collinear; ``n >= 3``.
    progress : callable, optional
        ``progress(fraction, message)``, called between batches of insertions;
        it may raise (e.g. :class:`~meshcore.errors.Cancelled`) to stop.

    Returns
    -------
    Triangulation
        Counter-clockwise triangles covering exactly the convex hull of the
        points, each point a vertex, every edge locally Delaunay by the exact
        in-circle test, and no triangle of zero area; neighbours as
        ``scipy.spatial.Delaunay``.

    Raises
    ------
    InputError
        ``bad_shape`` (not an ``(n, 2)`` array of numbers), ``too_few_points`` (fewer
        than 3), ``non_finite`` (NaN or infinite coordinates, naming the
        points), ``duplicate_points`` (naming the coinciding indices),
        ``collinear_points`` (all points on one line),
        ``coordinates_out_of_range`` (nonzero coordinates more than 2**140
        times smaller than the largest: the exact arithmetic would underflow),
        ``too_many_points`` (2**28 or more).

    Notes
    -----
    Co-circular ties are broken by symbolic perturbation of the liftings in
    lexicographic order of the points (see the module docstring): the
    triangle *set* depends only on the point set, not on the input order, and
    is unchanged by exact translations and power-of-two scalings. The
    guarantee is that set: the order of the output rows and the starting
    vertex of each row are deterministic for a given input array but
    otherwise unspecified. They follow the insertion order, a stable sort
    (radix) of the points' round and Hilbert index, so points sharing a
    Hilbert cell keep their index order; numpy's unstable argsort, used
    before, could order such ties otherwise, which gave the same triangles
    in other rows.

    Cost: expected O(n log n) (sorting) plus O(n) insertions with expected
    constant work each, in compiled code. Memory: about 200 bytes per point
    at the peak, half of it the int64 output arrays.

    Limits: fewer than 2**28 points (int32 triangle indices inside the
    kernel).

    References
    ----------
    Methods text §9.1; DESIGN.md "One Delaunay kernel".
    """
    pts_in = _validated(points)
    pts, order, V, A, vt, state, work, _ = _build(pts_in, progress)
    triangles, neighbors = _output(V, A, int(state[0]), order)
    pts_out = pts_in if pts_in is not points else pts_in.copy()
    for arr in (pts_out, triangles, neighbors):
        arr.flags.writeable = False
    return Triangulation(points=pts_out, triangles=triangles, neighbors=neighbors)
