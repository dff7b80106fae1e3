"""All-quad fill of a medial-axis partition's regions (§9.7.2, §8.5.3).

:func:`quads_on` turns the regions of a :class:`~meshcore.medial.partitioning.Partition`
into quads: midpoint subdivision into coarse quads, the counts of their sides, the
transfinite fill, then smoothing and untangling.

Quads (§9.7.2, §8.5.3). With ``size``, a partition whose regions all have four
corners (an annulus: the regions between its loop's cross-sections and the two
rings) is filled one patch per region, as the text's "if the polygon is not a quad
itself": the midpoint subdivision put two quads at least across each ring (1.76x
area / size**2 at size 0.15; one patch each: 0.88x, least quality 0.80). With
``four`` (tried by :func:`~meshcore.medial.partitioning.quad_medial` where the first
mesh passes the count), so is every four-sided region whose
corners are within :data:`WHOLE_ANGLES` among regions of other side counts: a side it
shares with a subdivided neighbour has that neighbour's side point, and the region
is then cut across from it to a point on the opposite side (two patches, four when
both pairs of sides are so), the cut carried on through a chain of such regions
(:func:`_halved`), so that its sides' counts stay those of the conformity classes
below (one count per class: a side of one patch against two halves would need the
sum of two counts); a four-sided region had four coarse quads and so at least four
quads (figures: :mod:`meshcore.medial.partitioning`).
Otherwise every region is split by midpoint subdivision (a
sharp convex input corner, turning by more than 60 degrees, counts as one of
the region's corners there, so that it is the corner of one coarse quad, not
the side point of two, each of half its angle): a
point inside (the centroid of its side points, or of its corners, or its
area centroid, whichever gives the best smallest corner area) joined to
one point on each side (the arclength midpoint, on the boundary for a
boundary side), giving as many coarse quads as sides. Each coarse quad is
then filled by transfinite (Coons) interpolation of its four sides on an
``n1 x n2`` grid. Conformity: the two pairs of opposite sides of every
coarse quad must have equal counts and a side shared by two coarse quads
one count, so counts are constant on classes of sides (a union-find), each
class taking ``round(mean length / size)`` of its members (the largest, as
before, multiplied the count along chains of classes: 24,600 quads for
1,300 asked on a 128-gon disk), but at least one more than the input
vertices inside each member side, so that every input vertex is a mesh
point (polygons covered exactly; a boundary sampled more finely than
``size`` then raises the count; where that passes :data:`MOST_COUNT` x area /
size**2 on every partition tried, ``quads_on``'s ``transitions``: a boundary side
with input vertices inside is not tied to its opposite side, its count that one's
plus an even number up to three times it, the extra pieces taken by 3-to-1
templates in the coarse quad's row along it, :func:`_transition`)
(``levels`` instead gives ``2**levels`` everywhere: repeated midpoint
subdivision). Boundary points are placed by arclength along the boundary
pieces (so they lie on the input boundary) and the input vertices of a
boundary side are snapped onto division points when there are enough of
them, so polygonal domains are covered exactly. A side's point is its
input corner nearest to the middle when one lies in its middle half (no
coarse quad cuts a corner). The transfinite fill folds cells next to reflex
corners; Gauss-Seidel Laplacian sweeps over the interior points then keep
each move that raises the smallest corner area around the point or keeps it
above half of what the fill gave (untangling without flattening quads
against a concave boundary). Then the whole mesh is relaxed
(:func:`meshcore.quads.relaxation.relax_quads`: the regularized condition
number of every corner minimized, which untangles and smooths at once),
with the coarse corners on the boundary and the input vertices fixed, the
other boundary points sliding along their input segment (:func:`boundary_slides`:
the fill's points are on it only to rounding, so an exact collinearity test let
none slide) and the interior
coarse corners free (the butterfly's valence-3 corners open from 90/135/135
to about 120 degrees); kept when it leaves fewer folded corners, or as many
and a better least quality. Last, the mesh is optimized as any all-quad mesh
(§8.4.3, :func:`meshcore.medial.partitioning._optimized`): the quad operators and smoothing of
:func:`meshcore.quads.optimization.optimize_quads`, then the corner angles
relaxed with the boundary points sliding (kept when the mean rises), then once
more with the power :data:`LEAST_POWER` over the quads under 0.5 and their
neighbours (kept when the least corner quality away from input vertices rises);
last, :func:`lift_least`: a pattern search, point by point, of the least corner
quality (8.3) that the point moves, around the quads under 0.6 (the boundary points
sliding, the input vertices fixed; no corner falls under the least it had): on the 32
random stars of :func:`tests.meshcore.quads.stars.issue_star` it took the least quality
away from input spikes to 0.5 on 24 at size 0.1 (19 before) and 20 at 0.15 (14)
(27 and 24 with the other partitions tried: :data:`~meshcore.medial.partitioning.GOOD_LEAST`).
Where a border vertex's corners average more than :data:`OPEN_ANGLE` (125
degrees) the fill gets one quad more there (:func:`_opened`, before the
smoothing); an interior vertex in more than :data:`MOST_VALENCE` quads (a crowded
junction of the partition, a gear's hub: each region meeting there puts a coarse
quad at it, 11 of 33 degrees on an 11-tooth gear) gets an O-grid instead of its fan
(:func:`_flowered`: an 11-tooth gear at size 0.1 from least quality 0.36 to 0.61,
1.08x to 1.21x area / size**2); neither adds a quad at a border point whose corners
would then average under :data:`OPEN_LEAST`. After the smoothing, a border vertex whose
corners average under :data:`CLOSE_ANGLE` (four regions meeting at a straight boundary
point: 45 degrees each at best; five quads at a reflex corner) gives one of its quads
up, an edge there turned (:func:`_closed`: gear 8 at size 0.1 from least quality
0.4996 to 0.543). The
relaxation's untangling rounds shrink Escobar's
regularization each round, so that a fold among corners far smaller than
the median (a reflex input corner next to a short piece) is not lost in
it, and a sliding point stays between the midpoints to its neighbours (it
can neither collapse onto an input corner nor pass another point).
References
----------
Methods text §9.7.2 (quad mesh construction, Figure 9.14), §8.5.3 (midpoint
subdivision, algebraic method and its consistency constraints).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from numba import njit

from meshcore.errors import InputError
from meshcore.geometry.constructions import coons_grid
from meshcore.geometry.predicates import orient2d
from meshcore.limits import MAX_QUADS
from meshcore.medial.axis import MedialAxis, _classes, _csr
from meshcore.medial.regions import KITE_ANGLE, at_input_vertex, input_index, turns
from meshcore.mesh import CellBlock, Mesh, quality, topology
from meshcore.partition.smoothing import boundary_points
from meshcore.quads.optimization import sliding_nodes
from meshcore.quads.relaxation import relax_quads
from meshcore.quads.vertex_moves import lift_corners

if TYPE_CHECKING:
    from meshcore.medial.partitioning import Partition

__all__ = [
    "MAX_QUADS",
    "MOST_COUNT",
    "area_centroid",
    "boundary_slides",
    "folded",
    "lift_least",
    "quads_on",
]

#: Gauss-Seidel smoothing sweeps after the transfinite fill (at most).
SMOOTHING_SWEEPS = 50
#: A convex input corner turning by more than this (radians; an interior angle under
#: 120 degrees) is a corner of its region's midpoint subdivision (one quad there, not
#: two of half its angle).
SHARP_TURN = math.radians(60.0)
#: The count promised: at most this times area / size**2 where the partition allows.
MOST_COUNT = 1.5
#: A border vertex whose quads' corners there average more than this (degrees) gets
#: one quad more (:func:`_opened`).
OPEN_ANGLE = 125.0
#: :func:`_opened` and :func:`_flowered` add no quad at a border point whose quads'
#: corners would then average under this (degrees).
OPEN_LEAST = 45.0
#: :func:`_closed` takes a quad from a border point whose quads' corners average under
#: this (degrees): four quads at a straight point (45), five at a reflex input corner
#: under 280 degrees (star 26 at size 0.1: 274.4 degrees, least quality 0.472 -> 0.494;
#: at 50 it was left). From 50 to 56: least quality away from spikes up on stars 25
#: and 26 at 0.1 and 1 and 25 at 0.15, no other of the 32 stars nor 7 gears changed.
CLOSE_ANGLE = 56.0
#: :func:`_closed`'s new quads may have one corner up to this (degrees; the turned
#: edge's end loses a quad, its two corners one: about 180 degrees), which the
#: smoothing that follows opens (all the turns are undone when it leaves more quads
#: folded than before them). 200 refused gear 7's straight point of four quads at
#: size 0.1 (the fill's corners there 18-82 degrees: 202-251 after the turn): least
#: quality 0.4997 -> 0.561 at 260; no other gear of 6-12 teeth nor any of the 32 issue
#: stars changed at 0.1 or 0.15.
CLOSE_BEND = 260.0
#: The kite at a spike's tip (:data:`meshcore.medial.regions.KITE_ANGLE`): the points of
#: its two sides this times size from the tip (at most a third of the side), its inner
#: point tried at :data:`KITE_PAST` times their distance past their middle.
KITE_SIDE = 1.0
#: The kite's inner point is tried this many times the distance of its two side points
#: past their middle (away from the tip).
KITE_PAST = (0.05, 0.1, 0.2, 0.35, 0.5, 0.8)
#: An interior vertex held by more quads than this gets an O-grid (:func:`_flowered`):
#: each of 8 quads has a corner of 45 degrees there at best, quality 0.5.
MOST_VALENCE = 7
#: Where the count passes :data:`MOST_COUNT` x area / size**2, the classes' counts are
#: taken again for ``size`` times each of these in turn (the input vertices' counts
#: still bind), counting the quads :func:`_opened` adds: rounding each class up and the
#: ring of an annulus carrying the outer circle's count inwards made 1.68x at size 0.1.
#: Up to 1.5 a random star of 60 vertices (95 regions, 343 coarse quads for area /
#: size**2 = 315) kept 1.74x; 2.0 to 3.0 take it to 1.47x (least quality away from
#: input spikes 0.44 -> 0.46), and another from 1.51x (with its opened corners) to 1.35x.
#: A region of four corners, each of these many degrees, is one patch with ``size``
#: (:func:`_halved`): the midpoint subdivision's side points only where a neighbour
#: halves its sides.
WHOLE_ANGLES = (45.0, 135.0)
STRETCH = (1.0, 1.15, 1.3, 1.5, 2.0, 2.5, 3.0)


def area_centroid(xy: np.ndarray) -> tuple[float, np.ndarray]:
    """The signed area and area centroid of a ring, relative to its first vertex."""
    d = xy - xy[0]
    x, y = d[:, 0], d[:, 1]
    cross = x * np.roll(y, -1) - np.roll(x, -1) * y
    area = float(cross.sum()) / 2
    c = np.array([((x + np.roll(x, -1)) * cross).sum(), ((y + np.roll(y, -1)) * cross).sum()])
    return area, xy[0] + c / (6 * area)


def _polyline_points(xy: np.ndarray, n: int, fixed: np.ndarray) -> np.ndarray:
    """``n + 1`` points along a polyline by arclength, with the vertices flagged
    in ``fixed`` (interior corners) moved onto division points where they fit."""
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])
    target = np.linspace(0.0, s[-1], n + 1)
    knots = [0]
    corners = np.flatnonzero(fixed[1:-1]) + 1
    for i, k in enumerate(corners):
        left_after = len(corners) - i - 1  # corners still to place after this one
        j = int(round(s[k] / s[-1] * n)) if s[-1] > 0 else 0
        j = min(max(j, knots[-1] + 1), n - 1 - left_after)
        if knots[-1] < j < n:
            target[j] = s[k]
            knots.append(j)
    knots.append(n)
    for a, b in zip(knots[:-1], knots[1:], strict=True):
        target[a : b + 1] = np.linspace(target[a], target[b], b - a + 1)
    out = np.column_stack([np.interp(target, s, xy[:, 0]), np.interp(target, s, xy[:, 1])])
    out[0], out[-1] = xy[0], xy[-1]
    return out


def _side_point(xy: np.ndarray, s: np.ndarray, fixed: np.ndarray, at: float | None = None):
    """The point of a side (a polyline with cumulative lengths ``s``).

    Its input corner nearest to the middle when one lies in the middle half
    (so that no coarse quad cuts a corner), else the arclength midpoint, or
    the vertex within 5 % of the side's length of it. ``at``: the arclength
    wanted instead of the middle (the kite at a spike, :data:`KITE_ANGLE`), an
    input corner within half of the shorter part from there taken instead.
    Returns ``(m, point, at_vertex)``: the point is vertex ``m``, or lies
    inside the piece from vertex ``m`` to ``m + 1``.
    """
    mid_s = s[-1] / 2 if at is None else at
    reach = s[-1] / 4 if at is None else min(at, s[-1] - at) / 2
    inner = np.flatnonzero(fixed[1:-1]) + 1
    if inner.size:
        k = inner[np.argmin(np.abs(s[inner] - mid_s))]
        if abs(s[k] - mid_s) <= reach:
            return int(k), xy[k], True
    m = min(int(np.searchsorted(s, mid_s, side="right")) - 1, len(s) - 2)
    # a midpoint within 5 % of the side's length of a vertex is that vertex (the nearest
    # of the two: the first one changed with rounding where the midpoint fell on a
    # sample): a point a rounding error away from an input corner would make a
    # zero-length edge
    near = [k for k in (m, m + 1) if 0 < k < len(s) - 1]
    if near:
        k = min(near, key=lambda i: abs(s[i] - mid_s))
        if abs(s[k] - mid_s) <= 0.05 * min(s[-1], 4 * reach):
            return k, xy[k], True
    t = (mid_s - s[m]) / (s[m + 1] - s[m]) if s[m + 1] > s[m] else 0.0
    return m, xy[m] + t * (xy[m + 1] - xy[m]), False


def _corner_areas(points: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """(m, 4): twice the signed area of the triangle at each corner of each quad
    (all positive iff the quad is strictly convex)."""
    p = points[quads]
    a, b = np.roll(p, 1, axis=1) - p, np.roll(p, -1, axis=1) - p
    return b[..., 0] * a[..., 1] - b[..., 1] * a[..., 0]


@njit(cache=True)
def _worst_corner(P, quads, start, cells, v, x, y):
    """Smallest corner area of the quads around vertex v with v moved to (x, y)."""
    worst = np.inf
    for j in range(start[v], start[v + 1]):
        q = cells[j]
        for k in range(4):
            a = quads[q, (k + 3) % 4]
            b = quads[q, k]
            c = quads[q, (k + 1) % 4]
            ax, ay = (x, y) if a == v else (P[a, 0], P[a, 1])
            bx, by = (x, y) if b == v else (P[b, 0], P[b, 1])
            cx, cy = (x, y) if c == v else (P[c, 0], P[c, 1])
            area = (cx - bx) * (ay - by) - (cy - by) * (ax - bx)
            if area < worst:
                worst = area
    return worst


@njit(cache=True)
def _smoothed(points, quads, fixed, sweeps):
    """Gauss-Seidel Laplacian sweeps over the free vertices. A move is kept when
    it raises the smallest corner area of the quads around the vertex, or keeps
    it above half of what the transfinite fill gave there: this untangles what
    the fill folded at reflex corners and evens the rest without flattening
    quads against a concave boundary. (A sequential sweep: each move sees the
    previous ones.)"""
    P = points.copy()
    n = P.shape[0]
    start, cells = _csr(n, quads)
    floor = np.empty(n)
    for v in range(n):
        floor[v] = 0.5 * _worst_corner(P, quads, start, cells, v, P[v, 0], P[v, 1])
    for _ in range(sweeps):
        moved = 0
        for v in range(n):
            if fixed[v]:
                continue
            sx = 0.0
            sy = 0.0
            cnt = 0
            for j in range(start[v], start[v + 1]):
                q = cells[j]
                for k in range(4):
                    if quads[q, k] == v:
                        for w in (quads[q, (k + 1) % 4], quads[q, (k + 3) % 4]):
                            sx += P[w, 0]
                            sy += P[w, 1]
                            cnt += 1
            x = sx / cnt
            y = sy / cnt
            now = _worst_corner(P, quads, start, cells, v, P[v, 0], P[v, 1])
            new = _worst_corner(P, quads, start, cells, v, x, y)
            if new > now or (new > 0.0 and new >= floor[v]):
                if x != P[v, 0] or y != P[v, 1]:
                    moved += 1
                P[v, 0] = x
                P[v, 1] = y
        if moved == 0:
            break
    return P


def _around(Q: np.ndarray, start: np.ndarray, cells: np.ndarray, b: int, first: int):
    """The quads at an interior vertex ``b`` counter-clockwise from ``first``
    (None when ``b`` is on the border: the walk stops)."""
    ring = [first]
    while True:
        cur = ring[-1]
        p = Q[cur, (int(np.flatnonzero(Q[cur] == b)[0]) + 3) % 4]  # edge b - p, then ccw
        nxt = [int(q) for q in cells[start[b] : start[b + 1]] if q != cur and p in Q[q]]
        if not nxt:
            return None
        if nxt[0] == first:
            return ring
        if len(ring) > len(cells):
            return None
        ring.append(nxt[0])


def _fan_angles(P: np.ndarray, Q: np.ndarray, start, cells, v: int):
    """The corner angle (radians, in [0, pi]) at vertex ``v`` of each of its quads, in
    the order of ``cells``, and ``v``'s slot (0-3) in each: two dicts quad -> value."""
    ang, at = {}, {}
    for q in cells[start[v] : start[v + 1]].tolist():  # a loop over the vertex's quads
        c = P[Q[q]]
        at[q] = i = int(np.flatnonzero(Q[q] == v)[0])
        a, b = c[i - 1] - c[i], c[(i + 1) % 4] - c[i]
        ang[q] = math.atan2(abs(a[0] * b[1] - a[1] * b[0]), float(a @ b))
    return ang, at


def _border_angle(P: np.ndarray, Q: np.ndarray, ang: dict, at: dict, v: int) -> float:
    """The domain's angle (radians, in [0, 2 pi)) at a border vertex ``v`` between its
    two border edges (``ang``, ``at``: :func:`_fan_angles` of ``v``): the sum of its
    quads' corners where none is folded, and the input's angle too where the fill folded
    one (a region's reflex corner: its coarse quad's corner there over 180 degrees, read
    as 360 minus it). Where ``v`` is on the border twice, the sum of ``ang``."""
    nxt = {int(Q[q, (at[q] + 1) % 4]) for q in ang}
    prv = {int(Q[q, at[q] - 1]) for q in ang}
    ends = nxt - prv, prv - nxt
    if any(len(e) != 1 for e in ends):
        return sum(ang.values())
    u, w = P[ends[0].pop()] - P[v], P[ends[1].pop()] - P[v]
    return math.atan2(u[0] * w[1] - u[1] * w[0], float(u @ w)) % (2 * math.pi)


def _opened(points: np.ndarray, quads: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """A quad more at every border vertex whose quads' corners there average more
    than :data:`OPEN_ANGLE` (a reflex input corner over 250 degrees that the
    midpoint subdivision gave two quads, each with a corner over 125 degrees; the
    domain's angle there, :func:`_border_angle`, divided by its quads): the
    interior edge ``v - b`` between its two widest corners is opened into a quad
    ``(v, b, z, b2)``, ``b`` split in two along the path ``v - b - z`` (``z`` the
    neighbour of ``b`` across from ``v``; ``b`` keeps the quads on one side, the new
    point ``b2`` takes the others); not where ``z`` is a border point whose corners
    would then average under :data:`OPEN_LEAST`. ``b`` and ``b2`` start a third of the
    way to the centroids of their quads, the smoothing that follows places them.
    Returns the points, the quads and how many edges were opened."""
    n = len(points)
    P, Q = points.copy(), quads.copy()
    start, cells = _csr(n, Q)
    border = boundary_points(P, Q)
    added: list[np.ndarray] = []
    for v in np.flatnonzero(border):
        ang, at = _fan_angles(P, Q, start, cells, v)
        fan = list(ang)
        if len(fan) < 2 or math.degrees(_border_angle(P, Q, ang, at, v)) / len(fan) <= OPEN_ANGLE:
            continue
        best = None
        for q1 in fan:  # q1 = (v, a, x, b) and q2 = (v, b, y, c) around the edge v - b
            b = int(Q[q1, (at[q1] + 3) % 4])
            q2 = [q for q in fan if Q[q, (at[q] + 1) % 4] == b]
            if q2 and not border[b] and (best is None or ang[q1] + ang[q2[0]] > best[0]):
                best = (ang[q1] + ang[q2[0]], q1, q2[0], b)
        if best is None:
            continue
        _, q1, q2, b = best
        ring = _around(Q, start, cells, b, q1)
        if ring is None or len(ring) < 4 or ring[-1] != q2:
            continue
        side1, side2 = ring[: len(ring) // 2], ring[len(ring) // 2 :]
        z = int(Q[side1[-1], (int(np.flatnonzero(Q[side1[-1]] == b)[0]) + 3) % 4])
        if border[z] and sum(_fan_angles(P, Q, start, cells, z)[0].values()) / (
            start[z + 1] - start[z] + 1
        ) < math.radians(OPEN_LEAST):
            continue
        b2 = n + len(added)
        c1 = P[Q[side1]].reshape(-1, 2).mean(axis=0)
        c2 = P[Q[side2]].reshape(-1, 2).mean(axis=0)
        for q in side2:
            Q[q][Q[q] == b] = b2
        added.append(P[b] + (c2 - P[b]) / 3)
        P = np.vstack([P, added[-1]])
        border = np.append(border, False)  # b2 is inside
        P[b] += (c1 - P[b]) / 3
        Q = np.vstack([Q, np.array([[v, b, z, b2]], dtype=Q.dtype)])
        start, cells = _csr(len(P), Q)
    return P, Q, len(added)


def _closed(points: np.ndarray, quads: np.ndarray) -> tuple[np.ndarray, int]:
    """A quad less at every border vertex ``v`` whose quads' corners there average under
    :data:`CLOSE_ANGLE` (four regions of the partition meeting at a straight boundary
    point: 45 degrees each at best): the two quads ``(v, a, x, b)`` and ``(v, b, y, c)``
    around an interior edge ``v - b`` become ``(a, x, b, y)`` and ``(v, a, y, c)`` (the
    edge turned to ``a - y``), for the edge whose new quads have the largest least
    corner, when each has at most one corner that is not strictly convex (exact), that
    one under :data:`CLOSE_BEND`. The quads keep their count; the smoothing that
    follows places the points (``quads_on`` keeps the turns only when it leaves no
    more quads folded than before them). Returns the quads and how many edges were so
    turned."""
    Q = quads.copy()
    start, cells = _csr(len(points), Q)
    border = boundary_points(points, Q)
    done = 0
    for v in np.flatnonzero(border):  # a loop over the border vertices
        ang, at = _fan_angles(points, Q, start, cells, v)
        fan = list(ang)
        if len(fan) < 3 or sum(ang.values()) / len(fan) >= math.radians(CLOSE_ANGLE):
            continue
        best = None
        for q1 in fan:  # q1 = (v, a, x, b), q2 = (v, b, y, c)
            r1 = np.roll(Q[q1], -at[q1])
            b = int(r1[3])
            q2 = [q for q in fan if q != q1 and b in Q[q]]
            if border[b] or len(q2) != 1:
                continue
            r2 = np.roll(Q[q2[0]], -at[q2[0]])
            if r2[1] != b:
                continue
            new = np.array([[r1[1], r1[2], b, r2[2]], [v, r1[1], r2[2], r2[3]]], Q.dtype)
            corners = quality.quad_angles(points, new)
            if (folded(points, new) > 1).any() or corners.max() > CLOSE_BEND:
                continue
            least = corners.min()
            if best is None or least > best[0]:
                best = (least, q1, q2[0], new)
        if best is None:
            continue
        _, q1, q2, new = best
        Q[q1], Q[q2] = new
        start, cells = _csr(len(points), Q)
        done += 1
    return Q, done


def _flowered(points: np.ndarray, quads: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """Every interior vertex held by more than :data:`MOST_VALENCE` quads (a crowded
    junction of the partition: a gear's hub, where each region puts a coarse quad, made
    corners of 33 degrees around it) replaced by a small structured patch: the ``2k``-gon
    of its ``k`` quads gets a ring of ``2k`` quads around an ``a x b`` grid (``a + b =
    k``) on the polygon shrunk to half about the vertex, so that no vertex there holds
    more than 3 new quads (an O-grid). The fan's far corners get a quad more each: not
    done where one is a border point whose corners would then average under
    :data:`OPEN_LEAST` (a 58 degree input corner of a random star, the far corner of
    its region's coarse quad, got two quads of 29 degrees). The smoothing that follows
    places the points.
    Returns the points, the quads and how many vertices were so replaced."""
    n = len(points)
    start, cells = _csr(n, quads)
    val = np.diff(start)
    border = boundary_points(points, quads)
    P, keep, new_quads = [points], np.ones(len(quads), dtype=bool), []
    m = n
    done = 0
    taken = np.zeros(n, dtype=bool)  # vertices of a replaced fan (fans must not overlap)
    for v in np.flatnonzero((val > MOST_VALENCE) & ~border):
        fan = _around(quads, start, cells, int(v), int(cells[start[v]]))
        if fan is None or len(fan) != val[v] or taken[quads[fan].ravel()].any():
            continue
        outer = []
        for q in fan:  # (v, x1, x2, x3) counter-clockwise: x1, x2 on the fan's border
            r = np.roll(quads[q], -int(np.flatnonzero(quads[q] == v)[0]))
            outer += [int(r[1]), int(r[2])]
        far = [x for x in outer[1::2] if border[x]]  # each gets a quad more
        if any(
            sum(_fan_angles(points, quads, start, cells, x)[0].values()) / (val[x] + 1)
            < math.radians(OPEN_LEAST)
            for x in far
        ):
            continue
        taken[quads[fan].ravel()] = True
        k = len(fan)
        a, b = k // 2, k - k // 2
        ring = points[v] + 0.5 * (points[outer] - points[v])
        idx = np.arange(2 * k + 1) % (2 * k)
        grid = coons_grid(
            ring[idx[: a + 1]],
            ring[idx[a : a + b + 1]],
            ring[idx[a + b : 2 * a + b + 1]][::-1],
            ring[idx[2 * a + b :]][::-1],
        )
        ids = m + np.arange((a + 1) * (b + 1)).reshape(a + 1, b + 1)
        ids[ids == m] = v  # the vertex's id goes to the grid's first point
        ids[ids > m] -= 1
        m += (a + 1) * (b + 1) - 1
        flat = grid.reshape(-1, 2)
        P[0] = P[0].copy() if P[0] is points else P[0]
        P[0][v] = flat[0]
        P.append(flat[1:])
        new_quads.append(
            np.stack([ids[:-1, :-1], ids[1:, :-1], ids[1:, 1:], ids[:-1, 1:]], axis=-1).reshape(
                -1, 4
            )
        )
        inner = np.concatenate([ids[:a, 0], ids[a, :b], ids[a:0:-1, b], ids[0, b:0:-1]])
        new_quads.append(np.column_stack([outer, np.roll(outer, -1), np.roll(inner, -1), inner]))
        keep[fan] = False
        done += 1
    if not done:
        return points, quads, 0
    return np.concatenate(P), np.concatenate([quads[keep], *new_quads]), done


def _inner_point(
    ring: np.ndarray, corners: np.ndarray, mids: np.ndarray, sharp: np.ndarray
) -> np.ndarray:
    """The point joined to the side points: among the mean of the side points, the
    mean of the corners, the area centroid, a 9 x 9 lattice over the corners'
    bounding box and, at each ``sharp`` corner (a spike's tip, its side points next
    to it), points just past the middle of its two side points
    (:data:`KITE_PAST`), the one whose coarse quads ``(corner, side point, G,
    previous side point)`` have the best worst corner quality ((8.3), 0 when not
    convex; a sharp corner's own angle left out: it is the input's), the mean of
    the corners' qualities breaking ties."""
    centroid = area_centroid(ring)[1]
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    t = (np.arange(9) + 0.5) / 9
    lattice = lo + np.stack(np.meshgrid(t, t), axis=-1).reshape(-1, 2) * (hi - lo)
    g = [mids.mean(axis=0), corners.mean(axis=0), centroid, lattice]
    for j in np.flatnonzero(sharp):  # a loop over the region's spikes (one or none)
        a, b = mids[j - 1], mids[j]
        u = (a + b) / 2 - corners[j]
        u /= max(float(np.hypot(*u)), np.finfo(float).tiny)
        g.append((a + b) / 2 + np.outer(KITE_PAST, u) * float(np.hypot(*(b - a))))
    g = np.vstack(g)
    k, c = len(corners), len(g)
    quads = np.stack(
        [
            np.broadcast_to(corners, (c, k, 2)),
            np.broadcast_to(mids, (c, k, 2)),
            np.broadcast_to(g[:, None, :], (c, k, 2)),
            np.broadcast_to(np.roll(mids, 1, axis=0), (c, k, 2)),
        ],
        axis=2,
    ).reshape(-1, 4, 2)
    pts = quads.reshape(-1, 2)
    cells = np.arange(len(pts)).reshape(-1, 4)
    ang = quality.quad_angles(pts, cells)
    qp = np.where(ang <= 90.0, ang / 90.0, np.maximum(2.0 - ang / 90.0, 0.0))
    qp[:, 0] = np.where(np.tile(sharp, c), 1.0, qp[:, 0])
    qp = np.where((_corner_areas(pts, cells).min(axis=1) > 0)[:, None], qp, -1.0).reshape(c, -1)
    # the least to 1e-9, then the mean: a fixed corner of the region is often the least
    # for every candidate, and rounding then chose (a translated input changed the mesh)
    least, mean = np.round(qp.min(axis=1), 9), qp.mean(axis=1)
    return g[int(np.lexsort((-mean, -least))[0])]


def _relaxed(points: np.ndarray, quads: np.ndarray, corner: np.ndarray, ax: MedialAxis):
    """The fill untangled and smoothed (:func:`meshcore.quads.relaxation.relax_quads`):
    the coarse quads' corners on the boundary (``corner``) and the boundary samples
    that are input vertices stay, the other boundary points slide along their input
    segment. Kept when it leaves fewer folded quads, or as many and a better least
    quality, than the fill; returns the points and whether they were kept."""
    vertex = ax.samples[at_input_vertex(ax)]
    fixed = corner | (input_index(points, vertex) >= 0)
    new = relax_quads(points, quads, fixed, slide=boundary_slides(points, quads, fixed, vertex))
    before, after = folded(points, quads).sum(), folded(new, quads).sum()
    q0 = quality.cell_quality(points, quads, "quad").min()
    q1 = quality.cell_quality(new, quads, "quad").min()
    if after < before or (after == before and q1 > q0):
        return new, True
    return points, False


def boundary_slides(P: np.ndarray, Q: np.ndarray, fixed: np.ndarray, inputs: np.ndarray):
    """The boundary points of a fill that slide, as
    :func:`~meshcore.quads.optimization.sliding_nodes` (``node, a, b``: ``node`` slides on
    the segment from point ``a`` to point ``b``): every boundary point between two
    consecutive ``fixed`` points of a boundary loop, when every input vertex
    (``inputs``) is one of the ``fixed`` points. The fill puts every boundary point on
    the input boundary, so those between two fixed points then lie on one input
    segment; they are off it by rounding (interpolated), and the exact collinearity
    test of ``sliding_nodes`` let none of them slide on a random star (a boundary
    fixed in every relaxation). Otherwise (an input vertex not a mesh point:
    ``sliding_nodes``, exact)."""
    at = input_index(P, inputs)
    if len(topology.unique_ints(at[at >= 0])) < len(inputs) or not fixed[at >= 0].all():
        return sliding_nodes(P, Q, fixed)
    n = len(P)
    a, b = Q.ravel(), np.roll(Q, -1, axis=1).ravel()
    key, rev = a * np.int64(n) + b, b * np.int64(n) + a
    once = ~topology.isin_ints(key, rev)  # a boundary edge: its reverse is in no quad
    nxt = np.full(n, -1, np.int64)
    nxt[a[once]] = b[once]
    node, sa, sb = [], [], []
    for s in np.flatnonzero((nxt >= 0) & fixed):  # a walk from every fixed boundary point
        run = []
        v = int(nxt[s])
        while not fixed[v] and v != s:
            run.append(v)
            v = int(nxt[v])
        if run and v != s:
            node += run
            sa += [int(s)] * len(run)
            sb += [v] * len(run)
    return tuple(np.array(x, np.int64) for x in (node, sa, sb))


def lift_least(P: np.ndarray, Q: np.ndarray, fixed: np.ndarray, inputs: np.ndarray, below: float):
    """The least corner quality (8.3) raised around the quads under ``below``
    (:func:`meshcore.quads.vertex_moves.lift_corners`, every quad judged): the other
    boundary points slide along their input segment (:func:`boundary_slides`), ``fixed``
    ones stay. No corner falls under the least it had before; every quad stays
    strictly convex. Returns the points and the moves made (§8.4.3:
    optimization-based smoothing of the worst corners)."""
    slide = boundary_slides(P, Q, fixed, inputs)
    return lift_corners(P, Q, fixed, slide, np.ones(len(Q), bool), below)


def folded(P: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """(q,) int: the corners of each quad that are not strictly convex (exact
    :func:`~meshcore.geometry.predicates.orient2d`)."""
    c = P[quads]
    prv, nxt = np.roll(c, 1, axis=1), np.roll(c, -1, axis=1)
    return sum((orient2d(prv[:, k], c[:, k], nxt[:, k]) <= 0).astype(np.int64) for k in range(4))


def _spread(n: int, k: int, skip_first: bool) -> np.ndarray:
    """Which of ``n`` cells get the ``k`` templates of :func:`_transition`: spread evenly
    (past the first with ``skip_first``)."""
    lo = int(skip_first)
    plus = np.zeros(n, dtype=bool)
    plus[lo:] = np.diff(np.floor(np.arange(n - lo + 1) * k / max(n - lo, 1))) > 0
    return plus


def _transition(bottom, right, top, left):
    """A coarse quad whose ``bottom`` has ``2 k`` more edges than its ``top`` (``k`` at
    most the top's edges), and its ``left`` ``2 m`` more than its ``right``: the
    transfinite grid of :func:`coons_grid` on the top's and right's counts, its first row
    along the bottom made of ``k`` 3-to-1 templates (four quads: two points inside,
    halfway across the row) spread evenly among plain quads, its first column along the
    left of ``m`` (both: none in the corner cell, so ``k`` and ``m`` at most one less),
    so that a boundary side crowded with input vertices does not carry its count across
    the region (§8.5.3's consistency constraints, relaxed to a conforming transition).
    The points (the grid's, then the templates' side and inner points), the quads,
    counterclockwise like the grid's (with ``k = m = 0`` exactly the :func:`coons_grid` grid,
    in its order), and the ids of the four corners."""
    nb, nt, nl, nr = len(bottom) - 1, len(top) - 1, len(left) - 1, len(right) - 1
    k, m = (nb - nt) // 2, (nl - nr) // 2
    plus_b, plus_l = _spread(nt, k, m > 0), _spread(nr, m, k > 0)
    fb = np.concatenate([[0], np.cumsum(1 + 2 * plus_b)])  # coarse vertex -> side index
    fl = np.concatenate([[0], np.cumsum(1 + 2 * plus_l)])
    grid = coons_grid(bottom[fb], right, top, left[fl])
    n2 = grid.shape[1] - 1
    ids = np.arange(grid.shape[0] * grid.shape[1]).reshape(grid.shape[:2])
    quads = np.stack([ids[:-1, :-1], ids[1:, :-1], ids[1:, 1:], ids[:-1, 1:]], axis=-1)
    corners = [ids[0, 0], ids[-1, 0], ids[0, -1], ids[-1, -1]]
    if k == m == 0:  # no template: the grid
        return grid.reshape(-1, 2), quads.reshape(-1, 4), corners
    pts = [grid.reshape(-1, 2)]
    added = []
    n = ids.size
    for side, f, plus, on, line, transposed in (
        (bottom, fb, plus_b, ids[:, 0], ids[:, 1], False),
        (left, fl, plus_l, ids[0, :], ids[1, :], True),
    ):
        extra = np.setdiff1d(np.arange(len(side)), f)  # the templates' side points
        at = np.empty(len(side), dtype=np.int64)  # side index -> point id
        at[f], at[extra] = on, n + np.arange(len(extra))
        n += len(extra)
        pts.append(side[extra])
        i = np.flatnonzero(plus)
        b, t0, t1 = f[i], line[i], line[i + 1]
        p1 = n + 2 * np.arange(len(i))
        p2 = p1 + 1
        n += 2 * len(i)
        inner0, inner1 = grid.reshape(-1, 2)[t0], grid.reshape(-1, 2)[t1]
        pts.append(
            np.stack(
                [
                    inner0 + (side[b + 1] - inner0 + (inner1 - inner0) / 3) / 2,
                    inner1 + (side[b + 2] - inner1 + (inner0 - inner1) / 3) / 2,
                ],
                axis=1,
            ).reshape(-1, 2)
        )
        rows = [
            (at[b], at[b + 1], p1, t0),
            (at[b + 1], at[b + 2], p2, p1),
            (at[b + 2], at[b + 3], t1, p2),
            (p1, p2, t1, t0),
        ]
        if transposed:  # the left's templates: reversed to stay counterclockwise
            rows = [(a, d, c, bb) for a, bb, c, d in rows]
        first = np.column_stack(rows[0]).reshape(-1, 4)
        if transposed:
            quads[0, i] = first
        else:
            quads[i, 0] = first
        added += [np.column_stack(r) for r in rows[1:]]
    quads = np.concatenate([quads.reshape(nt * n2, 4), *added])
    return np.concatenate(pts), quads, corners


def _filled(seg_xy, seg_fixed, n_of, patches):
    """The transfinite fill of the coarse quads (:func:`coons_grid`), the segments divided
    into ``n_of`` pieces each, a patch whose first (last) side has more pieces than its
    opposite filled by :func:`_transition`: the points (coincident copies merged), the quads and the
    ids of the coarse quads' corners."""
    seg_pts = [
        _polyline_points(xy, int(n_of[i]), fx)
        for i, (xy, fx) in enumerate(zip(seg_xy, seg_fixed, strict=True))
    ]

    def along(ref):
        sid, rev = ref
        return seg_pts[sid][::-1] if rev else seg_pts[sid]

    blocks = [_transition(*(along(r) for r in patch)) for patch in patches]
    allpts = np.concatenate([pts for pts, _, _ in blocks])
    # coincident points (the shared sides' copies) are one, numbered in order of first
    # occurrence: a lexicographic numbering followed the coordinates' rounding (a
    # translated input renumbered, and the smoothing's sweeps then moved differently)
    uniq, first, inverse = np.unique(allpts, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first)
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    uniq, inverse = uniq[order], rank[inverse.ravel()]
    quads = []
    corner_ids = []
    offset = 0
    for pts, q, corners in blocks:
        quads.append(inverse[offset + q])
        corner_ids += [int(inverse[offset + c]) for c in corners]
        offset += len(pts)
    return uniq, np.concatenate(quads), corner_ids


def _tied(n_seg: int, patches, fine: np.ndarray):
    """The conformity classes of the segments (a label each, their number): a patch's
    opposite sides tied, but for its fine sides (``fine``: 1 its first, 2 its last, 3
    both; see :func:`_transition`); and a row (fine side, opposite side, both fine?) per
    fine side."""
    pairs = [(s0[0], s2[0]) for (s0, _, s2, _), f in zip(patches, fine, strict=True) if not f & 1]
    pairs += [(s1[0], s3[0]) for (_, s1, _, s3), f in zip(patches, fine, strict=True) if not f & 2]
    label, n_classes = _classes(n_seg, np.array(pairs, dtype=np.int64).reshape(-1, 2))
    rows = [
        (s0[0], s2[0], f == 3) for (s0, _, s2, _), f in zip(patches, fine, strict=True) if f & 1
    ]
    rows += [
        (s3[0], s1[0], f == 3) for (_, s1, _, s3), f in zip(patches, fine, strict=True) if f & 2
    ]
    return label, n_classes, np.array(rows, dtype=np.int64).reshape(-1, 3)


def _transition_counts(count: np.ndarray, cls: np.ndarray, need: np.ndarray) -> None:
    """Counts (per class, in place) that :func:`_transition` can fill: each fine side
    (class ``cls[:, 0]``, a class of its own, at least ``need``) at least its opposite
    side's count (``cls[:, 1]``), of the same parity and at most three times it (two less
    where both of the patch's sides are fine, ``cls[:, 2]``; the opposite class raised
    where not; repeated until nothing changes)."""
    changed = True
    while changed:
        changed = False
        for (f, o, both), least in zip(cls, need, strict=True):
            nf = max(count[f], count[o])
            if (nf - count[o]) % 2:
                nf += -1 if nf - 1 >= max(least, count[o]) else 1
            count[f] = nf
            if nf > 3 * count[o] - 2 * both:
                count[o] = -(-(nf + 2 * both) // 3)
                changed = True


def _halved(sides: list, one: list) -> dict:
    """Which sides get a side point (a dict over the bytes of each side's canonical
    vertex chain; ``sides``: per region, its sides as ``(key, chain, flipped)``, the key
    those bytes): every side of a region not ``one`` patch (its midpoint subdivision,
    §8.5.3); a region that is ``one`` (four sides) is cut across where one of two
    opposite sides is halved (by a neighbour), repeated until nothing changes (a chain
    of four-sided regions carries a halving along it)."""
    halved: dict = {}
    for region, whole in zip(sides, one, strict=True):
        for key, *_ in region:
            halved[key] = halved.get(key, False) or not whole
    fours = [[key for key, *_ in region] for region, w in zip(sides, one, strict=True) if w]
    changed = True
    while changed:  # a loop over the chains of four-sided regions' length, at most
        changed = False
        for keys in fours:
            for a, b in ((keys[0], keys[2]), (keys[1], keys[3])):
                if halved[a] != halved[b]:
                    halved[a] = halved[b] = changed = True
    return halved


def _patch(a, b, c, d):
    """A coarse quad from its four sides as segment references ``(id, reversed?)`` in
    counterclockwise order: :func:`_transition`'s bottom, right, top and left (the top
    and left run the other way)."""
    return a, b, (c[0], not c[1]), (d[0], not d[1])


def _coarse(part: Partition, regions: list, halved: dict, size: float | None, is_corner):
    """The coarse quads of a partition's regions (``regions``: per region its vertices
    from a corner, the corners' positions, its sides as ``(key, chain, flipped)`` and its
    corner angles) with the sides ``halved`` given (:func:`_halved`): a region with
    every side halved by its midpoint subdivision (a point inside joined to its side
    points: :func:`_inner_point`), a four-sided one with none as one patch, with two
    opposite ones as two (split between their side points). Returns the segments'
    points, their fixed flags (input vertices, ends) and the patches (:func:`_patch`)."""
    points = part.points
    p = len(part.axis.samples)
    # segments: half-sides (in canonical direction) and spokes
    seg_xy: list[np.ndarray] = []
    seg_fixed: list[np.ndarray] = []
    half_id: dict[tuple[bytes, int], int] = {}
    patches = []  # per coarse quad: its four sides (segment id, reversed?)

    def new_segment(xy, fixed) -> int:
        seg_xy.append(xy)
        seg_fixed.append(fixed)
        return len(seg_xy) - 1

    for verts, ci, sides, alpha in regions:
        k = len(ci)
        ring = points[verts]
        tip = (alpha < KITE_ANGLE) & (k == 3) & (verts[ci] < p)  # a spike cut off
        halves = []  # per side: (first-half id, reversed?), (second-half id, reversed?)
        mids = []  # per side: its side point (None: the side is not halved)
        for j, (key, canon, flipped) in enumerate(sides):
            if not halved[key]:  # one segment, in the counterclockwise direction
                if (key, 0) not in half_id:
                    fixed = is_corner[canon].copy()
                    fixed[[0, -1]] = True
                    half_id[(key, 0)] = new_segment(points[canon], fixed)
                halves.append((half_id[(key, 0)], flipped))
                mids.append(None)
                continue
            if (key, 0) not in half_id:  # (a side shared with a region before: made)
                xy = points[canon]
                s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])
                fixed = is_corner[canon]
                at = None  # next to a spike's tip: the kite's side (KITE_ANGLE)
                if size is not None and tip[[j, (j + 1) % k]].any():
                    at = min(KITE_SIDE * size, s[-1] / 3)
                    if not tip[j] or alpha[(j + 1) % k] < alpha[j]:
                        at = s[-1] - at  # from the tip at the side's end
                    if flipped:
                        at = s[-1] - at
                m, mid, at_vertex = _side_point(xy, s, fixed, at)
                if at_vertex:  # the side point is vertex m
                    first, second = xy[: m + 1], xy[m:]
                    f1, f2 = fixed[: m + 1].copy(), fixed[m:].copy()
                else:  # inside the piece (m, m + 1)
                    first, second = np.vstack([xy[: m + 1], mid]), np.vstack([mid, xy[m + 1 :]])
                    f1, f2 = np.append(fixed[: m + 1], True), np.insert(fixed[m + 1 :], 0, True)
                f1[-1] = f2[0] = True
                half_id[(key, 0)] = new_segment(first, f1)
                half_id[(key, 1)] = new_segment(second, f2)
            a, b = half_id[(key, 0)], half_id[(key, 1)]
            mids.append(seg_xy[a][-1])
            halves.append(((b, True), (a, True)) if flipped else ((a, False), (b, False)))
        if all(m is None for m in mids):  # a four-sided region as one patch
            patches.append(_patch(*halves))
        elif all(m is not None for m in mids):  # the midpoint subdivision
            g = _inner_point(ring, points[verts[ci]], np.array(mids), tip)
            spokes = [new_segment(np.vstack([mids[j], g]), np.ones(2, bool)) for j in range(k)]
            patches += [
                _patch(halves[j][0], (spokes[j], False), (spokes[j - 1], True), halves[j - 1][1])
                for j in range(k)
            ]
        else:  # four sides, two opposite ones halved: two patches, split between them
            j = 0 if mids[0] is not None else 1
            cut = new_segment(np.vstack([mids[j], mids[j + 2]]), np.ones(2, bool))
            patches.append(_patch(halves[j][1], halves[j + 1], halves[j + 2][0], (cut, True)))
            patches.append(_patch(halves[j + 2][1], halves[j - 1], halves[j][0], (cut, False)))
    return seg_xy, seg_fixed, patches


def _counted(part: Partition, regions, halved, size, levels, is_corner, transitions, only_within):
    """The fill of :func:`_coarse`'s coarse quads: the sides' conformity classes, their
    counts at the first stretch (:data:`STRETCH`) within :data:`MOST_COUNT` x area /
    size**2, else the last (``levels``: ``2**levels`` each), the transfinite fill and the
    quads it opens (:func:`_opened`, :func:`_flowered`). Returns the points, quads,
    coarse corners' ids and their stats (coarse quads, stretch, transition templates,
    side classes, quads opened); None ``only_within`` where the count is passed at
    every stretch (the fill would only add quads: :func:`_opened`, :func:`_flowered`)
    or, with ``transitions``, where no side can take one (:func:`quads_on`)."""
    seg_xy, seg_fixed, patches = _coarse(part, regions, halved, size, is_corner)
    # conformity classes: opposite patch sides, shared sides
    n_seg = len(seg_xy)
    # a boundary side (in one patch only) with input vertices inside is its patch's
    # fine side (:func:`_transition`): not tied to its opposite side's count
    length = np.array([np.hypot(*np.diff(xy, axis=0).T).sum() for xy in seg_xy])
    need = np.array([int(f[1:-1].sum()) + 1 for f in seg_fixed], dtype=np.int64)
    sides = np.array([[r[0] for r in patch] for patch in patches], np.int64).reshape(-1, 4)
    fine = np.zeros(len(patches), dtype=np.int64)  # 1: the first side fine, 2: the last
    if transitions and size is not None:
        own = (np.bincount(sides.ravel(), minlength=n_seg)[sides] == 1) & (need[sides] > 1)
        fine = own[:, 0] + 2 * own[:, 3]
    if transitions and not fine.any():
        return None
    label, n_classes, rows = _tied(n_seg, patches, fine)
    stretches = (None,) if levels is not None else STRETCH
    # the first within MOST_COUNT, else the last (with transitions: else none)
    for stretch in stretches:
        if stretch is None:
            count = np.full(n_classes, 2 ** int(levels), dtype=np.int64)
        else:
            # the mean length of a class: its sides' points come out about `size` apart on
            # average (the largest would multiply the count along chains of classes)
            mean = np.bincount(label, length, n_classes) / np.bincount(label, None, n_classes)
            with np.errstate(over="ignore"):  # tiny sizes: inf, clipped (no int overflow)
                count = np.clip(np.round(mean / (stretch * size)), 1, MAX_QUADS + 1)
            count = count.astype(np.int64)
            # enough points for every input vertex of a side (a polygon covered exactly)
            np.maximum.at(count, label, need)
            rows_cls = np.column_stack([label[rows[:, :2]], rows[:, 2]])
            _transition_counts(count, rows_cls, need[rows[:, 0]])
        n_of = count[label]
        n_f, n_o = n_of[rows[:, 0]], n_of[rows[:, 1]]  # a template: 4 quads for 1
        total = int((n_of[sides[:, 2]] * n_of[sides[:, 1]]).sum() + 3 * (n_f - n_o).sum() // 2)
        within = stretch is None or total * size * size <= MOST_COUNT * part.axis.domain.area
        if not within and stretch != stretches[-1]:
            continue
        if not within and only_within:  # the fill would only add quads (_opened)
            return None
        if total > MAX_QUADS:
            raise InputError(
                f"this would make {total:,} quads; at most {MAX_QUADS:,}: ask for a larger "
                "size or fewer levels",
                loc=("size" if size is not None else "levels",),
                code="too_many_quads",
            )
        uniq, quads, corner_ids = _filled(seg_xy, seg_fixed, n_of, patches)
        uniq, quads, opened = _opened(uniq, quads)
        uniq, quads, flowers = _flowered(uniq, quads)
        # the quads opened at wide reflex corners count too (a star: 1.49x -> 1.51x)
        if stretch is None or len(quads) * size * size <= MOST_COUNT * part.axis.domain.area:
            break
    info = {
        "coarse_quads": len(patches),
        "stretch": stretch,
        "transitions": int((n_f - n_o).sum() // 2),
        "side_classes": int(n_classes),
        "opened": opened,
        "o_grids": flowers,
    }
    return uniq, quads, corner_ids, info


def quads_on(
    part: Partition,
    size: float | None,
    levels: int | None,
    whole: bool = False,
    transitions: bool = False,
    four: bool = False,
):
    """Midpoint subdivision and transfinite fill of a partition's regions, then
    smoothing; the mesh and its counts (``invalid``: quads of area <= 0).
    ``whole``: every region has four sides and is one patch (no subdivision); so too,
    with ``size``, when every region has four corners, the sharp input corners
    (:data:`SHARP_TURN`) counted (an annulus: its rings' regions one patch each, so
    that one quad across each ring is possible: the midpoint subdivision made at
    least two, 1.76x area / size**2 at size 0.15). ``four`` (with ``size``): every
    region of four corners within :data:`WHOLE_ANGLES` is one patch, cut across into
    two or four where a neighbour halves a side of it (:func:`_halved`), the others
    get the midpoint subdivision; None where that halves every side (the fill
    without ``four``) or passes the count at every stretch (such a fill is not kept:
    it is not made). Every quad lies in the domain, its
    boundary points on the input boundary and the input vertices mesh points where the
    counts allow (module docstring); folded quads are counted, not refused (§9.7.2,
    §8.5.3). ``transitions`` (with ``size``, whatever ``whole``; for a partition whose
    sides tied pass :data:`MOST_COUNT` x area / size**2 at every stretch): a boundary side
    with input vertices inside is not tied to its opposite side (:func:`_transition`);
    None where no side is so (the tied fill is the fill) or the count still passes at
    every stretch (the fill would only add quads: it is not made)."""
    ax = part.axis
    points = part.points
    p = len(ax.samples)
    is_corner = np.zeros(len(points), dtype=bool)
    is_corner[:p] = at_input_vertex(ax)

    # a sharp convex input corner is a corner of the midpoint subdivision: one coarse
    # quad there (as a side point it got two of half its angle)
    sharp = np.zeros(len(points), dtype=bool)
    sharp[:p] = turns(ax) > SHARP_TURN
    with_sharp = not whole
    regions = []  # per region: its vertices from a corner, corner positions, sides
    for verts, corner in zip(part.cycles, part.corners, strict=True):
        if with_sharp:
            corner = corner | sharp[verts]
        ci = np.flatnonzero(corner)
        verts = np.roll(verts, -ci[0])
        ci = ci - ci[0]
        bounds = np.append(ci, len(verts))
        sides = []  # (key: the chain's bytes, the chain from its first vertex, ccw or
        # reversed, flipped?)
        for j in range(len(ci)):
            side = np.append(verts[bounds[j] : bounds[j + 1]], verts[bounds[j + 1] % len(verts)])
            flipped = not (side[0] < side[-1] or (side[0] == side[-1] and side[1] < side[-2]))
            canon = side[::-1] if flipped else side
            sides.append((canon.tobytes(), canon, flipped))
        ring = points[verts]
        nxt, prv = ring[(ci + 1) % len(verts)] - ring[ci], ring[ci - 1] - ring[ci]
        cos_sin = ((nxt * prv).sum(axis=1), nxt[:, 0] * prv[:, 1] - nxt[:, 1] * prv[:, 0])
        alpha = np.degrees(np.mod(np.arctan2(cos_sin[1], cos_sin[0]), 2 * np.pi))
        regions.append((verts, ci, sides, alpha))
    sides = [r[2] for r in regions]
    if four:  # the four-sided regions of corners within WHOLE_ANGLES
        one = [
            len(a) == 4 and ((a >= WHOLE_ANGLES[0]) & (a <= WHOLE_ANGLES[1])).all()
            for *_, a in regions
        ]
    else:  # every region or none (whole: every one; with size: where all have four sides)
        one = [whole or (size is not None and all(len(r) == 4 for r in sides))] * len(sides)
    halved = _halved(sides, one)
    if four and all(halved.values()):  # no region is one patch: the fill without four
        return None
    got = _counted(part, regions, halved, size, levels, is_corner, transitions, transitions or four)
    if got is None:
        return None
    uniq, quads, corner_ids, info = got
    info["one_patch"] = sum(not any(halved[key] for key, *_ in r) for r in sides)
    before = _corner_areas(uniq, quads).min(axis=1)
    boundary = topology.boundary(Mesh(uniq, (CellBlock("quad", quads),))).cells[0].data
    fixed = np.zeros(len(uniq), dtype=bool)
    fixed[boundary.ravel()] = True
    uniq = _smoothed(uniq, quads, fixed, SMOOTHING_SWEEPS)
    turned, closed = _closed(uniq, quads)
    if closed:  # kept when the smoothing opens what the turned edges bent
        again = _smoothed(uniq, turned, fixed, SMOOTHING_SWEEPS)
        if (folded(again, turned) > 0).sum() <= (folded(uniq, quads) > 0).sum():
            uniq, quads = again, turned
        else:
            closed = 0
    corner = np.zeros(len(uniq), dtype=bool)
    corner[np.asarray(corner_ids, np.int64)] = True
    uniq, relaxed = _relaxed(uniq, quads, corner & fixed, ax)
    mesh = Mesh(uniq, (CellBlock("quad", quads),))
    area = quality.signed_area(uniq, quads, "quad")
    stats = {
        "quads": int(len(quads)),
        "points": int(len(uniq)),
        **info,
        "regions": len(part.regions),
        "area": float(area.sum()),
        "not_convex_before_smoothing": int((before <= 0).sum()),
        "relaxed": relaxed,
        "closed": closed,
        "invalid": int((area <= 0).sum()),
        "slits": sum(len(topology.unique_ints(c)) < len(c) for c in part.cycles),
        "not_convex": int((folded(uniq, quads) > 0).sum()),
        "domain_area": ax.domain.area,
    }
    return mesh, stats
