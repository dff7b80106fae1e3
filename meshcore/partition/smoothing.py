"""Smoothing of quad meshes that never inverts a cell: the length-weighted
Laplacian (:func:`smooth_quads`) and an optimization-based pass that squares
the corners (:func:`square_corners`).

Used by the direct quad methods (paving §8.5.1, recursive partition §8.7.2,
"a point relocation step"). One compiled loop (numba) visits the free points
in turn (Gauss-Seidel: each move sees the moves before it), ``sweeps`` times:

* **Length-weighted Laplacian** (Blacker and Stephenson's paving smoother):
  the point ``x`` goes to ``x + sum_i |c_i| c_i / sum_i |c_i|`` with
  ``c_i = x_i - x`` the edges to its neighbours: long edges pull harder,
  which evens out the lengths.
* **Boundary angle correction** (the same paper): a free point ``x`` joined
  to a boundary point ``b`` is also pulled to where the edge ``b x`` splits
  the interior angle at ``b`` evenly (a single interior edge on the
  bisector; ``k`` interior edges at ``j / (k + 1)`` of the angle, in their
  counter-clockwise order), at its current length. The two targets are
  averaged, so rows next to the boundary leave it at right angles.
* **Acceptance.** The move is tried at the full step, then at one half and
  one quarter; it is kept at the first step where every quad around the
  point is strictly convex (exact
  :func:`~meshcore.geometry.predicates.orient2d_scalar`, asked only where the
  quality (8.4) is at most ``CONVEX_PROOF``: above, it proves it) and their least
  quality (8.4) is at least ``min(its old value, floor)``, where ``floor`` is
  the larger of 0.5 and the least quality of the mesh at the start, and
  either the sum of their qualities does not drop or their least rises, both
  beyond rounding (``_TIE`` per quad: a point sliding along a row of
  rectangles leaves every quality 1 up to rounding, whose sign would choose;
  and the input's own rounding after a shift by 1e6, 1e-10 of the domain,
  moves the qualities by about 1e-8 at 10,000 quads: with a tie of 1e-12
  those signs flipped moves, and the paving of the gear at 10,000 quads
  came out up to 4.6e-3 apart at the origin and at +1e6; with 1e-7, 9e-10).
  So no cell inverts and the least quality of the mesh never drops, while
  cells above 0.5 may give a little to lift their neighbours (a strict
  "never lower a cell" rule stalls the smoothing); a move that only lowers
  the quality around the point on the whole is not made (on a coarse square
  with a hole the plain rule lowered the mean quality, 0.842 to 0.837).

The angle-correction directions are computed once (boundary points never
move); a free point's order of neighbours around a boundary point is that
of the input.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from meshcore.geometry.predicates import CONVEX_PROOF
from meshcore.mesh.topology import group_slots, unique_edges
from meshcore.partition.kernel import orient

__all__ = [
    "SWEEPS",
    "boundary_edges",
    "boundary_points",
    "quad_q",
    "smooth_quads",
    "square_corners",
]

#: Default number of sweeps.
SWEEPS = 8
_FLOOR = 0.5  # cells above this may drop to it when a neighbour gains
_STEPS = (1.0, 0.5, 0.25)
_TIE = 1e-7  # qualities (8.4) within this of each other, per quad, tie (rounding)


def boundary_edges(cells: np.ndarray) -> np.ndarray:
    """(b, 2) int64: the edges of one cell only (the mesh's boundary), sorted pairs."""
    e, cell_edges = unique_edges(cells, "quad" if cells.shape[1] == 4 else "triangle")
    return e[np.bincount(cell_edges.ravel(), minlength=len(e)) == 1]


def boundary_points(points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """(n,) bool: the points on an edge of one cell only (the mesh's boundary)."""
    out = np.zeros(len(points), bool)
    out[boundary_edges(cells).ravel()] = True
    return out


def _incidence(quads: np.ndarray, n: int):
    """The points around each of the ``n`` points (``nptr``, ``nidx``: along quad
    edges) and the quads around it (``cptr``, ``cidx``), in CSR form."""
    e, _ = unique_edges(quads, "quad")
    order, nptr = group_slots(np.concatenate([e[:, 0], e[:, 1]]), n)
    nidx = np.concatenate([e[:, 1], e[:, 0]])[order]
    order, cptr = group_slots(quads, n)
    cidx = order // 4  # slot 4 q + k is quad q's corner k
    return nptr, nidx, cptr, cidx


def _angle_targets(P, quads, fixed, nptr, nidx):
    """(n_adj,) unit directions: for each adjacency entry (x -> b), x free and b a
    boundary point, the direction from b that splits b's interior angle evenly among
    its interior edges (NaN elsewhere)."""
    n = len(P)
    direc = np.full((len(nidx), 2), np.nan)
    # at a boundary point b: the cell corners there give its wedge, in ccw order
    corner_v = quads.ravel()
    nxt = np.roll(quads, -1, axis=1).ravel()
    prv = np.roll(quads, 1, axis=1).ravel()
    on_b = fixed[corner_v]
    if not on_b.any():
        return direc
    bv, bn, bp = corner_v[on_b], nxt[on_b], prv[on_b]
    # a corner (b; next, prev) spans the angle from b->next ccw to b->prev
    # the wedge at b starts at the edge b->s whose s is no corner's prev at b
    key_next = bv * n + bn
    key_prev = bv * n + bp
    start = ~np.isin(key_next, key_prev)
    order, cut = group_slots(bv)
    bv, bn, bp, start = bv[order], bn[order], bp[order], start[order]
    lookup = {}
    for lo, hi in zip(cut[:-1].tolist(), cut[1:].tolist(), strict=True):
        grp = np.arange(lo, hi)  # per boundary point: a few corners
        b = int(bv[grp[0]])
        first = grp[start[grp]]
        if len(first) != 1:
            continue  # a pinched boundary point: no correction
        chain = [int(bn[first[0]])]
        nmap = dict(zip(bn[grp].tolist(), bp[grp].tolist(), strict=True))
        while chain[-1] in nmap and len(chain) <= len(grp):
            chain.append(nmap[chain[-1]])
        if len(chain) != len(grp) + 1:
            continue
        e0 = P[chain[0]] - P[b]
        e1 = P[chain[-1]] - P[b]
        a0 = math.atan2(e0[1], e0[0])
        span = math.atan2(e0[0] * e1[1] - e0[1] * e1[0], e0 @ e1)
        if span <= 0:
            span += 2 * math.pi
        k = len(chain) - 2
        for j, x in enumerate(chain[1:-1], start=1):
            if not fixed[x]:
                t = a0 + span * j / (k + 1)
                lookup[(x, b)] = (math.cos(t), math.sin(t))
    if not lookup:
        return direc
    owner = np.repeat(np.arange(n), np.diff(nptr))
    for r in np.flatnonzero(fixed[nidx] & ~fixed[owner]):
        d = lookup.get((int(owner[r]), int(nidx[r])))
        if d is not None:
            direc[r] = d
    return direc


def smooth_quads(points: np.ndarray, quads: np.ndarray, fixed: np.ndarray, sweeps: int = SWEEPS):
    """Length-weighted Laplacian smoothing with the boundary angle correction.

    Never inverts a cell nor lowers the least quality (8.4) of the mesh.

    Parameters
    ----------
    points : (n, 2) float64
    quads : (m, 4) int64, counter-clockwise, strictly convex
    fixed : (n,) bool
        Points that stay (the boundary).
    sweeps : int

    Returns
    -------
    points : (n, 2) float64
    undone : int
        Moves refused at every step (a quad would not stay strictly convex,
        by the exact test, or the least quality around the point would drop;
        module docstring).

    References
    ----------
    Methods text §8.5.1 (smoothing of paved meshes), §8.4.4 (8.4); Blacker and
    Stephenson, "Paving", IJNME 32 (1991), the length-weighted Laplacian and
    its boundary angle correction.
    """
    P = np.ascontiguousarray(points, dtype=np.float64).copy()
    quads = np.ascontiguousarray(quads, dtype=np.int64)
    nptr, nidx, cptr, cidx = _incidence(quads, len(P))
    fixed = np.asarray(fixed, bool)
    direc = _angle_targets(P, quads, fixed, nptr, nidx)
    undone = _sweeps(P, quads, fixed, nptr, nidx, cptr, cidx, direc, sweeps, np.array(_STEPS))
    return P, int(undone)


@njit(cache=True, inline="always")
def _corner_cos(ax, ay, bx, by, la, lb):
    """|cos| of the corner between a and b (squared lengths la, lb); -1 when it does
    not turn left (the operations of :func:`quad_q`'s corner)."""
    if ax * by - ay * bx <= 0:
        return -1.0
    den = math.sqrt(la * lb)
    return abs((ax * bx + ay * by) / den) if den > 0 else 1.0


@njit(cache=True, inline="always")
def _edges(P, quads, c):
    """The edges ``e_j`` (corner j to j + 1) of quad row c and their squared lengths:
    (x0, y0, x1, y1, x2, y2, x3, y3, l0, l1, l2, l3), for :func:`quad_q` and
    :func:`_skew` (inlined, as they are)."""
    a = quads[c, 0]
    b = quads[c, 1]
    d = quads[c, 2]
    e = quads[c, 3]
    x0 = P[b, 0] - P[a, 0]
    y0 = P[b, 1] - P[a, 1]
    x1 = P[d, 0] - P[b, 0]
    y1 = P[d, 1] - P[b, 1]
    x2 = P[e, 0] - P[d, 0]
    y2 = P[e, 1] - P[d, 1]
    x3 = P[a, 0] - P[e, 0]
    y3 = P[a, 1] - P[e, 1]
    l0 = x0 * x0 + y0 * y0
    l1 = x1 * x1 + y1 * y1
    l2 = x2 * x2 + y2 * y2
    l3 = x3 * x3 + y3 * y3
    return x0, y0, x1, y1, x2, y2, x3, y3, l0, l1, l2, l3


@njit(cache=True, inline="always")
def quad_q(P, quads, c):
    """Quality (8.4) of quad row c (0 when a corner does not turn left in floating point).

    The same operations as :func:`meshcore.mesh.quality.quad_quality`, for one
    quad: the compiled loops ask for a few quads at a time. Each edge ``e_j``
    (corner j to j + 1) and its squared length is formed once, corner j taking
    ``e_j`` and ``-e_{j-1}``: a negated difference is the reversed difference,
    exactly, so every sign and cosine is the one of the corner's own differences.
    Inlined: as a call it cost the smoothing loops as much as its arithmetic.
    """
    x0, y0, x1, y1, x2, y2, x3, y3, l0, l1, l2, l3 = _edges(P, quads, c)
    c0 = _corner_cos(x0, y0, -x3, -y3, l0, l3)
    c1 = _corner_cos(x1, y1, -x0, -y0, l1, l0)
    c2 = _corner_cos(x2, y2, -x1, -y1, l2, l1)
    c3 = _corner_cos(x3, y3, -x2, -y2, l3, l2)
    if c0 < 0 or c1 < 0 or c2 < 0 or c3 < 0:
        return 0.0
    big = max(max(c0, c1), max(c2, c3))
    return 1.0 - (2.0 / math.pi) * math.asin(min(big, 1.0))


@njit(cache=True, inline="always")
def _accepted(P, quads, cptr, cidx, v, qc, floor, qnew):
    """Whether point v where it stands now is kept (module docstring, *Acceptance*):
    every quad around it strictly convex (exact), their least quality (8.4) at least
    ``min(old least, floor)``, and their sum not lower or their least higher than
    before (``qc``, the qualities before the move, updated when it is kept)."""
    old = 2.0
    total = 0.0
    for r in range(cptr[v], cptr[v + 1]):
        old = min(old, qc[cidx[r]])
        total += qc[cidx[r]]
    need = min(old, floor)
    gain = 0.0
    low = 2.0
    k = 0
    for r in range(cptr[v], cptr[v + 1]):
        q = quad_q(P, quads, cidx[r])
        if q < need:
            return False
        qnew[k] = q
        gain += q
        low = min(low, q)
        k += 1
    for r in range(cptr[v], cptr[v + 1]):
        if qnew[r - cptr[v]] > CONVEX_PROOF:  # the quality proves it
            continue
        c = cidx[r]
        for j in range(4):
            if orient(P, quads[c, j], quads[c, (j + 1) % 4], quads[c, (j + 2) % 4]) <= 0:
                return False
    if gain < total - _TIE * k and low <= old + _TIE:
        return False
    k = 0
    for r in range(cptr[v], cptr[v + 1]):
        qc[cidx[r]] = qnew[k]
        k += 1
    return True


@njit(cache=True)
def _sweeps(P, quads, fixed, nptr, nidx, cptr, cidx, direc, sweeps, steps):
    """The Gauss-Seidel sweeps (module docstring); after the first, only the points
    next to a point that moved by more than 1e-3 of its mean edge are visited."""
    n = len(P)
    qc = np.empty(len(quads))
    least = 2.0
    for c in range(len(quads)):
        qc[c] = quad_q(P, quads, c)
        least = min(least, qc[c])
    floor = max(_FLOOR, least)
    qnew = np.empty(64)
    active = np.ones(n, np.bool_)
    undone = 0
    for _ in range(sweeps):
        woke = np.zeros(n, np.bool_)
        for v in range(n):
            if fixed[v] or not active[v] or nptr[v + 1] == nptr[v]:
                continue
            if cptr[v + 1] - cptr[v] > 64:
                continue
            x = P[v, 0]
            y = P[v, 1]
            sw = 0.0
            dx = 0.0
            dy = 0.0
            ax = 0.0
            ay = 0.0
            na = 0
            for r in range(nptr[v], nptr[v + 1]):
                u = nidx[r]
                cx = P[u, 0] - x
                cy = P[u, 1] - y
                w = math.sqrt(cx * cx + cy * cy)
                sw += w
                dx += w * cx
                dy += w * cy
                if not math.isnan(direc[r, 0]):
                    # where the edge would split the angle at u evenly, at its length
                    ax += P[u, 0] + w * direc[r, 0] - x
                    ay += P[u, 1] + w * direc[r, 1] - y
                    na += 1
            if sw <= 0.0:
                continue
            dx /= sw
            dy /= sw
            if na > 0:
                dx = 0.5 * (dx + ax / na)
                dy = 0.5 * (dy + ay / na)
            deg = nptr[v + 1] - nptr[v]
            if math.sqrt(dx * dx + dy * dy) < 1e-3 * sw / deg:
                continue
            kept = False
            for t in steps:
                P[v, 0] = x + t * dx
                P[v, 1] = y + t * dy
                if _accepted(P, quads, cptr, cidx, v, qc, floor, qnew):
                    kept = True
                    break
            if not kept:
                P[v, 0] = x
                P[v, 1] = y
                undone += 1
                continue
            woke[v] = True
            for r in range(nptr[v], nptr[v + 1]):
                woke[nidx[r]] = True
        active = woke
    return undone


def square_corners(points: np.ndarray, quads: np.ndarray, fixed: np.ndarray, sweeps: int = 10):
    """Optimization-based smoothing: each free point moved to square the corners around it.

    Never inverts a cell nor lowers the least quality (8.4) of the mesh.

    Each free point in turn (Gauss-Seidel, ``sweeps`` times; after the first,
    only the points next to one that moved by more than 1e-3 of its mean edge;
    never a point whose quads are all of quality ``_SQUARE_ENOUGH`` or more)
    takes one step of steepest descent on the
    sum over the quads around it of the 4-norm of their four corners'
    ``cos^2`` (zero for rectangles: a smooth stand-in of (8.4), the least
    corner quality (8.3) of a quad; the norm leans on the worst corner, and
    4 did better than 1, 2, 3 and 6 on the plate and the gear; one step per
    sweep did better than two or three, and costs less); the point
    reached is kept under the acceptance rule of :func:`smooth_quads` (module
    docstring), else the point stays. The step: a trial at the linear model's
    zero (at most a fifth of an edge, halved while the skew there exceeds
    twice the skew now), then ``_OVER`` times the least of the parabola
    through the skew, its slope and the trial's skew, halved until the skew
    drops by ``_ARMIJO`` of the model's gain; points whose model gains less
    than ``_SLOPE`` of their skew stay. Halving from the linear model's zero
    until the skew dropped (before) made the step jump with rounding: a
    ``1e-11`` change of the points (the input's rounding after a shift by
    1e6) grew ``x20`` a sweep, to ``1.2e-7`` on the gear at 2,000 quads and
    ``3e-3`` at 10,000; the parabola's step varies smoothly with the points
    (``1.3e-10`` on that gear), costs fewer trials, and with ``_OVER`` = 1.5
    keeps the mean quality (paving's 100k-quad hole, plate and gear: 0.9833,
    0.9221, 0.9355 against 0.9833, 0.9219, 0.9354). The Laplacian of :func:`smooth_quads`
    evens out the edge lengths; this pass then squares the corners, which the
    Laplacian leaves skewed next to irregular points.

    Parameters
    ----------
    points : (n, 2) float64
    quads : (m, 4) int64, counter-clockwise, strictly convex
    fixed : (n,) bool
        Points that stay (the boundary).
    sweeps : int

    Returns
    -------
    points : (n, 2) float64
    moved : int
        Moves kept.

    References
    ----------
    Methods text §8.3 (optimization-based methods), §8.4.4 (8.3)-(8.4).
    """
    P = np.ascontiguousarray(points, dtype=np.float64).copy()
    quads = np.ascontiguousarray(quads, dtype=np.int64)
    nptr, nidx, cptr, cidx = _incidence(quads, len(P))
    fixed = np.ascontiguousarray(fixed, dtype=np.bool_)
    moved = _descents(P, quads, fixed, nptr, nidx, cptr, cidx, np.int64(sweeps))
    return P, int(moved)


_SQUARE_ENOUGH = 0.98  # square_corners leaves points whose quads are all this good
_HALVINGS = 6  # square_corners' step halved at most this many times
_SLOPE = 1e-6  # ... tried only when the linear model gains this share of the skew
_ARMIJO = 0.01  # ... and kept when the skew drops by this share of the model's gain
_OVER = 1.5  # ... at this many times the least of its parabola (over-relaxed)
#: The role of v at corner j of a quad (:func:`_skew_corner`, column j) when v is its
#: corner ``at`` (row): the corner itself (0), the corner's next (1), its previous (2),
#: the opposite corner (3).
_ROLE = np.array([[0, 2, 3, 1], [1, 0, 2, 3], [3, 1, 0, 2], [2, 3, 1, 0]], np.int64)


@njit(cache=True, inline="always")
def _skew_corner(ax, ay, bx, by, la, lb, role, slope):
    """One corner of :func:`_skew`: edges a and b from it (squared lengths la, lb),
    the moving point v being the corner (``role`` 0), a's end (1), b's end (2) or
    none (3). Returns (cos^8, the gradient's x and y terms, whether it turns left)."""
    if ax * by - ay * bx <= 0:
        return 0.0, 0.0, 0.0, False
    w = 1.0 / math.sqrt(la * lb)
    cs = (ax * bx + ay * by) * w
    c2 = cs * cs
    c6 = c2 * c2 * c2
    if not slope or role == 3:
        return c6 * c2, 0.0, 0.0, True
    # d cos / d v
    if role == 1:
        dx = bx * w - cs * ax / la
        dy = by * w - cs * ay / la
    elif role == 2:
        dx = ax * w - cs * bx / lb
        dy = ay * w - cs * by / lb
    else:
        dx = -(bx * w - cs * ax / la) - (ax * w - cs * bx / lb)
        dy = -(by * w - cs * ay / la) - (ay * w - cs * by / lb)
    return c6 * c2, 8.0 * c6 * cs * dx, 8.0 * c6 * cs * dy, True


@njit(cache=True, inline="always")
def _skew(P, quads, cptr, cidx, v, grad, slope):
    """Sum over the quads around v of the 4-norm of their corners' cos^2 (inf when a
    corner does not turn left), and, if ``slope``, its gradient with respect to v in
    grad (the sum is the same either way).

    Each edge ``e_j`` of a quad and its squared length is formed once, corner j
    taking ``e_j`` and ``-e_{j-1}`` (exactly its own differences, as in
    :func:`quad_q`). Inlined, as :func:`quad_q`.
    """
    f = 0.0
    if slope:
        grad[0] = 0.0
        grad[1] = 0.0
    for r in range(cptr[v], cptr[v + 1]):
        c = cidx[r]
        x0, y0, x1, y1, x2, y2, x3, y3, l0, l1, l2, l3 = _edges(P, quads, c)
        # v is corner `at` of the quad (v is one of its corners); corner j sees it in the
        # role _ROLE[at, j]
        at = 0 if v == quads[c, 0] else 1 if v == quads[c, 1] else 2 if v == quads[c, 2] else 3
        t0, gx0, gy0, ok0 = _skew_corner(x0, y0, -x3, -y3, l0, l3, _ROLE[at, 0], slope)
        t1, gx1, gy1, ok1 = _skew_corner(x1, y1, -x0, -y0, l1, l0, _ROLE[at, 1], slope)
        t2, gx2, gy2, ok2 = _skew_corner(x2, y2, -x1, -y1, l2, l1, _ROLE[at, 2], slope)
        t3, gx3, gy3, ok3 = _skew_corner(x3, y3, -x2, -y2, l3, l2, _ROLE[at, 3], slope)
        if not (ok0 and ok1 and ok2 and ok3):
            return math.inf
        s = t0 + t1 + t2 + t3
        if s > 0.0:
            r4 = math.sqrt(math.sqrt(s))
            f += r4
            if slope:
                t = r4 / (4.0 * s)
                grad[0] += t * (gx0 + gx1 + gx2 + gx3)
                grad[1] += t * (gy0 + gy1 + gy2 + gy3)
    return f


@njit(cache=True)
def _descents(P, quads, fixed, nptr, nidx, cptr, cidx, sweeps):
    """The sweeps of :func:`square_corners`: moves kept."""
    n = len(P)
    qc = np.empty(len(quads))
    least = 2.0
    for c in range(len(quads)):
        qc[c] = quad_q(P, quads, c)
        least = min(least, qc[c])
    floor = max(_FLOOR, least)
    qnew = np.empty(64)
    grad = np.empty(2)
    active = np.ones(n, np.bool_)
    moved = 0
    for _ in range(sweeps):
        woke = np.zeros(n, np.bool_)
        for v in range(n):
            if fixed[v] or not active[v] or cptr[v + 1] == cptr[v]:
                continue
            if cptr[v + 1] - cptr[v] > 64:
                continue
            low = 2.0
            for r in range(cptr[v], cptr[v + 1]):
                low = min(low, qc[cidx[r]])
            if low >= _SQUARE_ENOUGH:
                continue
            x = P[v, 0]
            y = P[v, 1]
            mean = 0.0
            for r in range(nptr[v], nptr[v + 1]):
                u = nidx[r]
                mean += math.sqrt((P[u, 0] - x) ** 2 + (P[u, 1] - y) ** 2)
            mean /= nptr[v + 1] - nptr[v]
            f = _skew(P, quads, cptr, cidx, v, grad, True)
            g = math.sqrt(grad[0] ** 2 + grad[1] ** 2)
            if not g > 0.0 or not f < math.inf:
                continue
            # the linear model's zero, at most a fifth of an edge, halved while the skew
            # there is above twice f (near a flat corner it is ill-conditioned), then the
            # least of the parabola through f, its slope and the skew there: a step that
            # varies smoothly with the points, so that the rounding of the input is not
            # amplified from sweep to sweep
            t = min(f / g, 0.2 * mean)
            if t * g < _SLOPE * f:
                continue
            f1 = math.inf
            for _half in range(_HALVINGS):
                P[v, 0] = x - t * grad[0] / g
                P[v, 1] = y - t * grad[1] / g
                f1 = _skew(P, quads, cptr, cidx, v, grad, False)
                if f1 <= 2.0 * f:
                    break
                t *= 0.5
            curv = (f1 - f + g * t) / (t * t)
            if curv > 0.0 and f1 < math.inf:
                t = min(t, _OVER * 0.5 * g / curv)
            better = False
            for _half in range(_HALVINGS):
                P[v, 0] = x - t * grad[0] / g
                P[v, 1] = y - t * grad[1] / g
                if _skew(P, quads, cptr, cidx, v, grad, False) < f - _ARMIJO * t * g:
                    better = True
                    break
                t *= 0.5
            if not better:
                P[v, 0] = x
                P[v, 1] = y
                continue
            d = math.sqrt((P[v, 0] - x) ** 2 + (P[v, 1] - y) ** 2)
            if not _accepted(P, quads, cptr, cidx, v, qc, floor, qnew):
                P[v, 0] = x
                P[v, 1] = y
                continue
            moved += 1
            if d > 1e-3 * mean:
                woke[v] = True
                for r in range(nptr[v], nptr[v + 1]):
                    woke[nidx[r]] = True
        active = woke
    return moved
