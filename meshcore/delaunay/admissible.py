"""Delaunay-admissible boundary discretizations (methods text §9.1.2-§9.1.5).

A set of segments is *Delaunay-admissible* when every segment is an edge of
the Delaunay triangulation of the segments' endpoints (§9.1). Given a
boundary discretization that is not, :func:`make_admissible` (on a
:class:`~meshcore.domain.planar.Domain`) and :func:`admissible_segments` (on raw
arrays, for the triangulator) split the offending segments until it is, and
:func:`make_admissible` also returns the "empty" Delaunay triangulation of
the domain (§9.4.1: no vertex inside, only boundary points).

Algorithm (§9.1.4), one missing piece at a time:

1. Triangulate the input points with :func:`meshcore.delaunay.kernel2d.delaunay`
   (our exact kernel) and look every segment up among its edges (a
   compiled, linear-time scan of the vertex adjacency). Stop when all are
   there. Otherwise the missing segments go on a work stack, and one
   compiled loop (:func:`~meshcore.delaunay.admissible_loop._split_loop`)
   takes them one at a time: a piece that is an edge by now is dropped;
   any other is split (steps 2 and 3), its split point inserted into one
   growing :class:`~meshcore.delaunay.kernel2d.IncrementalDelaunay` (the
   same triangles as triangulating anew: the kernel's ties depend only on
   the point set), and the new pieces and the pieces whose edges that
   insertion removed (read off the insertion's log) are pushed, to be
   checked next while they are in cache. A piece stops being an edge only
   when an insertion removes it (an edge once removed comes back only at
   an insertion of one of its ends), so when the stack is empty every
   piece is an edge. The last triangulation is made anew from the final
   points when first read, so that it is the one :func:`delaunay` gives.
2. For each missing segment ``f = AB`` find the point of its closed
   diametral ball (the exact predicate
   :func:`~meshcore.geometry.predicates.dot2d` decides membership) with the
   largest angle ``APB`` (§9.1.2): a compiled walk over the triangles the
   segment crosses, whose vertices hold the widest point of each side
   (the proof of Case 1 in §9.1.3: that point's circle through ``A`` and
   ``B`` is empty on its side); a search over the triangles meeting the
   ball, narrowed to the lens of the points that could still beat the best
   angle found, only when rounding stopped the walk.
3. Split ``f`` at the projection of ``P`` on ``f`` (§9.1.4, Figure 9.4), or,
   for a segment of a ring that declares a circle, at that projection moved
   radially onto the circle (§9.1.5). Segments meeting at an acute angle
   are first *protected* (below).

Classification (§9.1.2) is exact: Case 0 (one open half-plane of the
segment's line holds no point: the segment lies on a straight run of the
convex hull, found with :func:`~meshcore.geometry.predicates.orient2d`),
Case 1 (the open diametral ball holds no point,
:func:`~meshcore.geometry.predicates.indiametral`), Case 2 otherwise.
Cases are reported for the input and for the output. Only pieces that
are not Delaunay edges when taken are split, so a Case 2 segment whose
triangle ``fP`` is Delaunay (§9.1.3) stays whole, and Case 0 segments (hull
edges, and the added points never leave the hull) are never split. A Case 1
segment stays whole unless added points enter its diametral ball: that
happens next to acute Case 2 neighbours, whose splits land near the shared
vertex (the coupling of Exercise 9.2); on random stars a few Case 1
segments are split so, on the comb, the L-shape and the grid of the tests
none is.

Choices where the text leaves freedom
-------------------------------------
* **Closed balls (Exercise 9.5).** A missing segment is split even when its
  encroaching points lie only *on* its diametral circle: the kernel breaks
  co-circular ties by symbolic perturbation, and the tie may have gone
  against the segment. Projecting such a point strictly separates it from
  both halves, so this costs nothing elsewhere.
* **Which encroaching point.** The largest angle ``APB`` (§9.1.2), computed
  in floating point: any encroaching point gives a valid split (Remark
  9.4), so this is a choice, not a sign decision. Angles within
  :attr:`Tolerances.angle_tie` of the largest are tied and the point of
  smallest index wins, so that translated or exactly scaled inputs make the
  same choices. Ties are looked for among the vertices of the triangles
  the segment crosses (where the widest point is): a point of another
  triangle on (or within the tie of) the same circle is not a candidate.
  On the test polygons and the random stars up to 10,000 vertices this
  picks the same points as a search of the whole lens of tied angles, in
  a third of the triangles.
* **Input that is not a planar straight-line graph.** A point found
  strictly inside a segment (collinear, angle 180°) is refused: an input
  point raises :class:`~meshcore.errors.InputError` (``point_on_segment``),
  an added one means two segments cross, and the splits, converging on the
  crossing, stop with :class:`~meshcore.errors.AlgorithmError` naming both
  (or when the points reach float64 resolution there). An input point
  that lies within float64 rounding of a segment (a valid polygon in
  floating point, e.g. a spike whose sides nearly overlap: a lattice vertex
  that is on the segment in exact rationals, off it by rounding) cannot be
  resolved: the projection split rounds onto the point itself, or onto an
  end of the piece, or the splits of both sides meet at one added point
  next to it (within ``TOUCH``, 2**-40 of the largest coordinate magnitude,
  of an end of one of the two segments; crossing segments meet away from
  their ends); that is refused with
  :class:`~meshcore.errors.InputError` ``point_near_segment``, naming the
  segment and the point.
* **Acute angles and non-manifold vertices (Exercises 9.2-9.4).** Two
  segments meeting at a vertex ``E`` at an angle below 90° (exact sign of
  ``(X - E).(Y - E)``, on the input segments) form an *acute cluster* at
  ``E`` (all segments of ``E`` in such a pair, any number of them: a
  non-manifold vertex is no special case). Their splits are coupled: a
  split near ``E`` on one may encroach another, and the projections can
  chase each other into ``E`` (Exercise 9.3). In exact arithmetic the
  projection of one segment's end onto the other lands exactly on the
  other's diametral circle, so one step ends the chase; rounding can
  restart it, and more encroaching points can feed it. So a projection
  split near ``E`` is allowed once per cluster segment; the second time
  (on the same segment's piece at ``E``) ``E`` is *protected*: its radius
  ``r_E`` is fixed, the projection distance ``|EM|`` when that is within a
  safe bound, else the bound, and from then on each missing piece of the
  cluster at ``E`` is split at exactly ``r_E`` from ``E`` (Exercise 9.4's
  "points at a common distance on all edges emanating from A", made lazily
  so that segments that are Delaunay stay whole). A piece that needs
  ``E`` protected waits until the loop's stack is empty; then all such
  vertices are protected at once (:func:`_protect`), and their pieces go
  back on the stack. The safe bound is
  :data:`PROTECT_FRACTION` (0.9) times the distance from ``E`` to its
  nearest other point and to its nearest non-incident segment, and
  :data:`SHARE_FRACTION` (0.45) times its shortest cluster segment (so the
  protection points of a segment's two ends stay apart). Then the pieces
  ``[E, M]`` all have length ``r_E`` and nothing ever enters their closed
  diametral balls (those lie in the disk of radius ``r_E`` around ``E``:
  later splits on non-incident segments are farther, the other protected
  pieces end at exactly ``r_E``, pieces at 90° or more from them stay in
  the closed half-plane behind ``E``, and unprotected cluster pieces are
  longer than ``2 r_E`` until they are split at ``r_E``), so they are
  Delaunay for good and the chase cannot reach ``E``. Measured on the test
  polygons this safety net costs a few points in all (4% on a set of random
  stars), where protecting every acute vertex up front doubled the count.
* **Near-endpoint projections.** When ``P`` lies almost above an endpoint
  ``E``, its projection falls extremely close to ``E``: a subsegment far
  shorter than the local feature size (``|EP|``), inviting cascades. A
  projection closer to ``E`` than ``NEAR_END_TRIGGER`` (1/8, in ``admissible_pieces``) of
  ``|EP|`` is replaced by the point at :data:`NEAR_END_FRACTION` (1/2) of
  ``|EP|`` from ``E``. It still separates ``P`` from both halves: the ball of
  ``[E, M]`` lies within distance ``|EM| < |EP|`` of ``E``, and ``P``
  projects on ``[E, M]``'s side of ``M``, outside the ball of ``[M, F]``.
  The trigger is low on purpose: a clamp at every projection closer than
  ``|EP| / 2`` made thin 5° wedges cost four times more points.
* **Ties of the projection.** The projection ``M`` of ``P`` makes a right
  angle at ``M``, so ``M`` lies exactly on the diametral circle of ``[E, P]``
  (Thales), which is a segment whenever ``P`` is joined to the end ``E``
  (acute corners, thin spikes). That tie would be decided by the rounding
  of ``M``, differently at different distances from the origin. So ``M``
  moves away from its nearer end ``E`` by :data:`NUDGE` (2**-20) of
  ``|EM|``, at most half of the room that keeps ``P`` outside the ball of
  ``[E, M]``: the tie is decided, the same way everywhere. (On the test
  polygons this also made the comb's and the star's results identical
  under exact translations, and saved a point on the comb.)
* **Curves (§9.1.5).** A ring may declare the circle it samples; its new
  points are the chord split points moved radially onto the circle (on the
  minor arc between the segment's ends), protection points are placed on
  the circle at chord distance ``r_A``. The domain is assumed to be sampled
  finely enough that the arcs meet no other segment.
* **Which missing piece first.** The last pushed: the pieces a split made
  or disturbed are checked right after it, so each split sees the points
  added before it (a split that resolves a neighbour's encroachment saves
  that neighbour's split). Splitting all missing pieces of a triangulation
  at once, in rounds, added more points: 603,670 instead of 476,241 on the
  10,000-vertex star, 9,291 instead of 8,018 at 1,000 vertices.
* **Termination guard.** The splits stop with
  :class:`~meshcore.errors.AlgorithmError` when the points added exceed
  :data:`MAX_ADDED_FACTOR` times the input size plus
  :data:`MAX_ADDED_BASE`: valid inputs whose close features need more
  points than the limit get there; crossing segments (not a planar
  straight-line graph) stop earlier, when a split point lands on a
  segment or on a point.

Frames and ties. The splits run in a frame centred on the first input
point when that shift is exact (:func:`_local_origin`): an input moved by an
exact translation then makes bit-identical constructions and decisions.
Back in the input's frame, the added points are rounded once more, and the
splits continue there until every segment is an edge again (normally none
is missing): the guarantee is always checked on the returned coordinates.
Projections make right angles, so the output may hold exactly co-circular
quadrilaterals around a segment; the segment is then an edge of our
kernel's triangulation (its exact tie-breaking), and a Delaunay code with
other tie-breaking may need a swap to show it (§9.1.3, footnote 4);
floating-point codes such as Qhull may take either diagonal.

Cost: time in the pieces split and checked (for each, a turn around
one end to see whether it is an edge, the widest-angle search, the
insertion and the bookkeeping, all in the compiled loop), not in all
points, plus one whole triangulation at the start and, when it is read,
one at the end. A random star of ``n`` vertices (``benchmarks/admissible.py``)
is ``n`` spikes about ``2 pi / n`` wide, and the added points grow about as
``n ** 1.8`` (8,018 at 1,000 vertices, 56,682 at 3,000, 476,241 at 10,000,
spread evenly along the segments: the pieces of neighbouring segments line
up in rungs). The measurements point to the input more than to the rule:
Triangle's full conforming Delaunay (``pcD``) adds 6 to 11 times more
(than the rounds' counts); on a 200-vertex star a greedy pass that drops
added points one at a time while every segment stays a Delaunay edge
dropped only 9 % of the rounds' points; the near-end clamp's constants
move the count by under 10 %. Two "concentric shell" rules at acute ends
were tried (with the rounds) and add more points (3,000-vertex star:
67,859 then): a split at the encroaching point's distance from the apex
(the two sides of a wedge then split alike) 79,234, and Ruppert's
power-of-two distances (quarter powers) 121,726. The 10,000-vertex star
takes about 0.8 CPU s on a loaded machine (load 7; 85 % in the compiled
loop, 1.7 µs per added point), where the rounds took 1.5 (146 rounds over
the missing pieces, 0.85 µs per point for the insertions alone and 0.7
for the searches of 10,000-piece rounds, whose pieces were far apart in
memory) and 126 s when every round re-triangulated everything. The case
counts of the result are computed when first read.

The restricted triangulation (:func:`restricted_triangles`) keeps the
triangles reached by a flood fill across non-segment edges from the left
side of every boundary segment (both sides of an interior constraint):
regions, never centroid tests.

References
----------
Methods text §9.1 (all of it, Exercises 9.2-9.5), §9.4.1 (the empty
Delaunay triangulation of a domain); DESIGN.md "Geometry robustness".
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from numba import njit
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from meshcore.delaunay.admissible_loop import (
    BAD_SPLIT,
    BUDGET,
    DONE,
    DUPLICATE,
    ON_SEGMENT,
    PROTECT,
    ROOM,
    TICK,
    TICK_POINTS,
    _split_loop,
)
from meshcore.delaunay.admissible_pieces import (
    _ball_radii,
    _grid_reach,
    _Pieces,
    _State,
    _unresolvable,
    located_in_domain,
)
from meshcore.delaunay.kernel2d import (
    IncrementalDelaunay,
    Triangulation,
    delaunay,
)
from meshcore.domain.numbers import refuse_non_numbers
from meshcore.domain.planar import Domain
from meshcore.errors import AlgorithmError, InputError
from meshcore.geometry.constructions import point_segment_distance
from meshcore.geometry.predicates import dot2d, orient2d
from meshcore.mesh import CellBlock, Mesh
from meshcore.mesh.topology import edge_keys

__all__ = [
    "AdmissibleBoundary",
    "AdmissibleSegments",
    "Tolerances",
    "admissible_segments",
    "circles_of",
    "classify_segments",
    "located_in_domain",
    "make_admissible",
    "restricted_triangles",
]

Progress = Callable[[float, str], None]

#: Protection radius of an acute vertex: at most this fraction of the distance
#: to its nearest other point or non-incident segment (below 1, see above) ...
PROTECT_FRACTION = 0.9
#: ... and at most this fraction of its shortest acute-cluster segment (below 1/2).
SHARE_FRACTION = 0.45
#: Added points allowed: this factor times (points + segments) of the input ...
MAX_ADDED_FACTOR = 64
#: ... plus this many.
MAX_ADDED_BASE = 10_000


@dataclass(frozen=True)
class Tolerances:
    """Every tolerance of this module; none of them decides a sign.

    Attributes
    ----------
    ball_slack : float
        Relative enlargement of the ball queries (times the ball's radius):
        the candidate set only grows, the exact predicate decides.
    coordinate_slack : float
        Absolute enlargement of the ball queries, times the largest
        coordinate magnitude (rounding of midpoints far from the origin).
    angle_tie : float
        Radians: encroaching points whose angles ``APB`` are within this of
        the largest are tied; the smallest point index wins.
    curve_fit : float
        How far, times the domain's diameter, a ring's points may lie from
        the circle the ring declares.
    """

    ball_slack: float = 2.0**-30
    coordinate_slack: float = 2.0**-40
    angle_tie: float = 2.0**-30
    curve_fit: float = 1e-6


TOLERANCES = Tolerances()


@dataclass(frozen=True, eq=False)
class AdmissibleSegments:
    """A Delaunay-admissible set of segments (result of :func:`admissible_segments`).

    Attributes
    ----------
    points : (n, 2) float64
        The input points first, indices unchanged, then the added points.
    segments : (m, 2) int64
        The output segments, each an edge of :attr:`delaunay`. The pieces of
        input segment ``i`` are consecutive rows, in order from its first
        to its second endpoint, and keep its direction.
    source : (m,) int64
        The input segment each output segment comes from (non-decreasing).
    cases_before, cases_after : dict
        Counts of Case 0, 1 and 2 segments (§9.1.2) among the input and the
        output segments, keys ``"case0"``, ``"case1"``, ``"case2"``
        (classified on first access: the triangulator does not ask).
    added : int
        Number of points added (Steiner points).
    rounds : int
        Passes: the first check of the input, then each run of the compiled
        loop (it pauses to grow its arrays, to protect acute vertices and to
        report progress); 1 when the input was admissible.
    protected : (k,) int64
        The acute vertices that were protected (Exercises 9.2-9.4).
    protection_radius : (k,) float64
        Their protection radii: every protected segment piece at such a
        vertex has this length.
    delaunay : Triangulation
        The Delaunay triangulation of :attr:`points` (all of the convex hull),
        made on first read when points were added.
    """

    points: np.ndarray
    segments: np.ndarray
    source: np.ndarray
    added: int
    rounds: int
    protected: np.ndarray
    protection_radius: np.ndarray
    _delaunay: Triangulation | None = field(repr=False)  # None: made on first read
    _input: tuple = field(repr=False)  # (points, segments, their triangulation)
    _tolerances: Tolerances = field(repr=False)

    @cached_property
    def delaunay(self) -> Triangulation:
        if self._delaunay is not None:
            return self._delaunay
        # (a writable copy: numba compiles read-only arrays as another type)
        return delaunay(np.array(self.points))

    @cached_property
    def cases_before(self) -> dict[str, int]:
        P, S, tri = self._input
        return _counts(classify_segments(P, S, triangulation=tri, tolerances=self._tolerances))

    @cached_property
    def cases_after(self) -> dict[str, int]:
        return _counts(
            classify_segments(
                self.points, self.segments, triangulation=self.delaunay, tolerances=self._tolerances
            )
        )


@dataclass(frozen=True, eq=False)
class AdmissibleBoundary:
    """A Delaunay-admissible boundary of a domain and its empty triangulation.

    Attributes
    ----------
    points : (n, 2) float64
        The domain's points first (``domain.points``, indices unchanged),
        then the added points.
    segments : (m, 2) int64
        Output segments, domain on the left for boundary pieces; the pieces
        of input segment ``i`` are consecutive, in order along it.
    source : (m,) int64
        Input segment id per output segment: ids below
        ``len(domain.segments)`` are boundary segments, the others
        constraint ``id - len(domain.segments)``.
    cases_before, cases_after : dict
        Per-case counts (§9.1.2) of the input and output segments.
    added : int
        Points added.
    rounds : int
        Passes (:attr:`AdmissibleSegments.rounds`).
    protected : (k,) int64
        The acute vertices protected (Exercises 9.2-9.4).
    triangulation : Mesh
        The empty Delaunay triangulation of the domain (§9.4.1): the
        Delaunay triangles of :attr:`points` inside the domain, a
        ``triangle`` block, counter-clockwise.
    """

    points: np.ndarray
    segments: np.ndarray
    source: np.ndarray
    cases_before: dict[str, int]
    cases_after: dict[str, int]
    added: int
    rounds: int
    protected: np.ndarray
    triangulation: Mesh


# ---------------------------------------------------------------------------
# Small helpers
# ---------------------------------------------------------------------------


@njit(cache=True)
def _fans(triangles, n):
    """Vertex adjacency in CSR form (counting sort, linear time): for vertex
    ``v`` and ``j`` in ``start[v]:start[v + 1]``, ``(v, nxt[j], prv[j])`` is
    one of its triangles, counter-clockwise."""
    start = np.zeros(n + 1, np.int64)
    for t in range(triangles.shape[0]):
        for i in range(3):
            start[triangles[t, i] + 1] += 1
    for v in range(n):
        start[v + 1] += start[v]
    fill = start[:-1].copy()
    nxt = np.empty(3 * triangles.shape[0], np.int64)
    prv = np.empty(3 * triangles.shape[0], np.int64)
    for t in range(triangles.shape[0]):
        for i in range(3):
            v = triangles[t, i]
            nxt[fill[v]] = triangles[t, (i + 1) % 3]
            prv[fill[v]] = triangles[t, (i + 2) % 3]
            fill[v] += 1
    return start, nxt, prv


@njit(cache=True)
def edges_present(triangles, n, segments):
    """Whether each segment is an edge of the triangles: vertex adjacency in
    CSR form (counting sort, linear time), then a scan of each segment's
    first vertex's neighbours (a sequential compiled loop)."""
    start, nxt, prv = _fans(triangles, n)
    out = np.zeros(segments.shape[0], np.bool_)
    for k in range(segments.shape[0]):
        a = segments[k, 0]
        b = segments[k, 1]
        for j in range(start[a], start[a + 1]):
            if nxt[j] == b or prv[j] == b:
                out[k] = True
                break
    return out


@njit(cache=True)
def _edge_apexes(triangles, n, segments):
    """Per segment ``a -> b``: the third vertex of the triangle on its left
    and of the one on its right (-1: none, a hull edge); -2 for both when
    the segment is not an edge (vertex adjacency in CSR form, as
    :func:`edges_present`)."""
    start, nxt, prv = _fans(triangles, n)
    out = np.full((segments.shape[0], 2), -1, np.int64)
    for k in range(segments.shape[0]):
        a = segments[k, 0]
        b = segments[k, 1]
        edge = False
        for j in range(start[a], start[a + 1]):
            if nxt[j] == b:
                out[k, 0] = prv[j]
                edge = True
            elif prv[j] == b:
                out[k, 1] = nxt[j]
                edge = True
        if not edge:
            out[k, 0] = out[k, 1] = -2
    return out


def _present(tri: Triangulation, segments: np.ndarray) -> np.ndarray:
    """(m,) bool: which segments are edges of the triangulation."""
    return edges_present(tri.triangles, len(tri.points), segments)


def _ball_pairs(tree: cKDTree, centers: np.ndarray, radii: np.ndarray):
    """(query, point) index pairs of the points within ``radii`` of ``centers``."""
    if len(centers) == 0:
        empty = np.zeros(0, dtype=np.int64)
        return empty, empty
    lists = tree.query_ball_point(centers, radii)
    counts = np.fromiter(map(len, lists), dtype=np.int64, count=len(lists))
    flat = np.fromiter(
        itertools.chain.from_iterable(lists), dtype=np.int64, count=int(counts.sum())
    )
    return np.repeat(np.arange(len(centers), dtype=np.int64), counts), flat


def _enlargement(scale: float, tol: Tolerances) -> tuple[float, float]:
    """``(grow, pad)``: a query of radius ``r`` searches ``r * grow + pad``
    (:attr:`Tolerances.ball_slack` relative, :attr:`Tolerances.coordinate_slack`
    times the largest coordinate magnitude ``scale``)."""
    return 1.0 + tol.ball_slack, tol.coordinate_slack * scale


def _closed_ball_members(P, tree, a, b, scale, tol):
    """Pairs (segment row, point) with the point in the closed diametral ball.

    Returns the rows, the points and their exact :func:`dot2d` signs (-1
    strictly inside, 0 on the circle); the endpoints themselves excluded.
    """
    A, B = P[a], P[b]
    radii = _ball_radii(P, a, b, *_enlargement(scale, tol))
    q, p = _ball_pairs(tree, 0.5 * (A + B), radii)
    keep = (p != a[q]) & (p != b[q])
    q, p = q[keep], p[keep]
    d = dot2d(A[q], B[q], P[p]) if len(q) else np.zeros(0, dtype=np.int8)
    inside = d <= 0
    return q[inside], p[inside], d[inside]


def _hull_case0(P: np.ndarray, tri: Triangulation, segments: np.ndarray) -> np.ndarray:
    """Case 0 of §9.1.2: the segment lies on a straight run of the convex hull.

    One open half-plane of the segment's line is empty iff the line supports
    the point set, iff both ends are hull vertices and the second lies on
    the line of a hull edge at the first (exact orient2d).
    """
    n = len(P)
    t, nb = tri.triangles, tri.neighbors
    rows, cols = np.nonzero(nb < 0)
    u = t[rows, (cols + 1) % 3]  # hull edge u -> v, counter-clockwise
    v = t[rows, (cols + 2) % 3]
    nxt = np.full(n, -1, dtype=np.int64)
    prv = np.full(n, -1, dtype=np.int64)
    nxt[u] = v
    prv[v] = u
    a, b = segments[:, 0], segments[:, 1]
    on_hull = (nxt[a] >= 0) & (nxt[b] >= 0)
    out = np.zeros(len(segments), dtype=bool)
    idx = np.flatnonzero(on_hull)
    if idx.size:
        ai, bi = a[idx], b[idx]
        along_out = orient2d(P[ai], P[nxt[ai]], P[bi]) == 0
        along_in = orient2d(P[prv[ai]], P[ai], P[bi]) == 0
        out[idx] = along_out | along_in
    return out


def _scale(P: np.ndarray) -> float:
    return float(np.abs(P).max()) if len(P) else 0.0


def _counts(cases: np.ndarray) -> dict[str, int]:
    c = np.bincount(cases, minlength=3)
    return {"case0": int(c[0]), "case1": int(c[1]), "case2": int(c[2])}


# ---------------------------------------------------------------------------
# Classification
# ---------------------------------------------------------------------------


def classify_segments(
    points,
    segments,
    *,
    triangulation: Triangulation | None = None,
    tolerances: Tolerances = TOLERANCES,
) -> np.ndarray:
    """Case 0 / 1 / 2 of each segment (§9.1.2), decided by exact predicates.

    Parameters
    ----------
    points : (n, 2) float64
        The point set :math:`\\mathcal{S}`.
    segments : (m, 2) int64
        Segments as point indices.
    triangulation : Triangulation, optional
        The Delaunay triangulation of ``points`` if already at hand (its
        convex hull gives Case 0).

    Returns
    -------
    (m,) int8
        0 where one open half-plane of the segment's line holds no point, 1
        where the open diametral ball holds no point (and not Case 0), 2
        otherwise.

    References
    ----------
    Methods text §9.1.2 (classification), §9.1.3.
    """
    P, S = _validated(points, segments)
    tri = triangulation if triangulation is not None else delaunay(P)
    cases = np.full(len(S), 2, dtype=np.int8)
    # A Delaunay edge's open diametral ball is empty iff neither triangle on
    # it has its third vertex strictly inside (that half of the ball lies in
    # the triangle's empty circumdisk otherwise); other segments: ball query.
    apex = _edge_apexes(tri.triangles, len(P), S)
    edge = np.flatnonzero(apex[:, 0] != -2)
    inside = np.zeros(len(edge), dtype=bool)
    for side in range(2):
        has = np.flatnonzero(apex[edge, side] >= 0)
        e = edge[has]
        inside[has] |= dot2d(P[S[e, 0]], P[S[e, 1]], P[apex[e, side]]) < 0
    cases[edge[~inside]] = 1
    other = np.flatnonzero(apex[:, 0] == -2)
    if other.size:
        a, b = S[other, 0], S[other, 1]
        q, _, d = _closed_ball_members(P, cKDTree(P), a, b, _scale(P), tolerances)
        strictly = np.bincount(q[d < 0], minlength=len(other))
        cases[other[strictly == 0]] = 1
    cases[_hull_case0(P, tri, S)] = 0
    return cases


# ---------------------------------------------------------------------------
# Validation of raw arrays
# ---------------------------------------------------------------------------


def _validated(points, segments) -> tuple[np.ndarray, np.ndarray]:
    refuse_non_numbers(points, ("points",), code="bad_shape")  # numpy reads "1.5" and True
    try:
        P = np.array(points, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(
            "points must be an (n, 2) array", loc=("points",), code="bad_shape"
        ) from exc
    if P.ndim != 2 or P.shape[1] != 2:
        raise InputError(
            f"points must have shape (n, 2), got {P.shape}", loc=("points",), code="bad_shape"
        )
    bad = np.flatnonzero(~np.isfinite(P).all(axis=1))
    if bad.size:
        raise InputError(
            f"point {int(bad[0])} has a non-finite coordinate",
            loc=("points", int(bad[0])),
            code="non_finite",
        )
    refuse_non_numbers(segments, ("segments",), code="bad_shape")
    try:
        raw = np.asarray(segments)
    except (TypeError, ValueError) as exc:
        raise InputError(
            "segments must be an (m, 2) integer array", loc=("segments",), code="bad_shape"
        ) from exc
    if raw.size == 0:
        raw = raw.reshape(0, 2)
    if raw.ndim != 2 or raw.shape[1] != 2:
        raise InputError(
            f"segments must have shape (m, 2), got {raw.shape}",
            loc=("segments",),
            code="bad_shape",
        )
    if raw.dtype.kind == "f":  # numpy would truncate 1.5 to the index 1
        frac = np.flatnonzero((~np.isfinite(raw) | (raw != np.round(raw))).any(axis=1))
        if frac.size:
            i = int(frac[0])
            raise InputError(
                f"segment {i} has an index that is not an integer: {raw[i].tolist()}",
                loc=("segments", i),
                code="bad_shape",
            )
    try:
        S = raw.astype(np.int64)
    except (TypeError, ValueError, OverflowError) as exc:
        raise InputError(
            "segments must be an (m, 2) integer array", loc=("segments",), code="bad_shape"
        ) from exc
    out = np.flatnonzero(((S < 0) | (S >= len(P))).any(axis=1))
    if out.size:
        i = int(out[0])
        raise InputError(
            f"segment {i} has an index out of range [0, {len(P)})",
            loc=("segments", i),
            code="index_out_of_range",
        )
    same = np.flatnonzero((S[:, 0] == S[:, 1]) | (P[S[:, 0]] == P[S[:, 1]]).all(axis=1))
    if same.size:
        i = int(same[0])
        raise InputError(
            f"segment {i} has zero length", loc=("segments", i), code="degenerate_segment"
        )
    keys = edge_keys(S[:, 0], S[:, 1], len(P))
    order = np.argsort(keys, kind="stable")
    dup = np.flatnonzero(keys[order][1:] == keys[order][:-1])
    if dup.size:
        i, j = sorted((int(order[dup[0]]), int(order[dup[0] + 1])))
        raise InputError(
            f"segments {i} and {j} join the same points",
            loc=("segments", j),
            code="duplicate_segment",
        )
    return P, S


# ---------------------------------------------------------------------------
# Acute clusters and protection radii (Exercises 9.2-9.4)
# ---------------------------------------------------------------------------


def _acute_ends(P: np.ndarray, S: np.ndarray) -> np.ndarray:
    """(m, 2) bool: the segment makes an angle below 90° with another at that end.

    Raises InputError for two segments overlapping from a common vertex.
    """
    m = len(S)
    vert = S.ravel()  # end e = 2 * segment + side
    other = S[:, ::-1].ravel()
    order = np.argsort(vert, kind="stable")
    vs = vert[order]
    acute = np.zeros(2 * m, dtype=bool)
    k = 1
    while k < len(vs):
        same = np.flatnonzero(vs[k:] == vs[:-k])
        if same.size == 0:
            break
        e1, e2 = order[same], order[same + k]
        apex = P[vert[e1]]
        x1, x2 = P[other[e1]], P[other[e2]]
        sharp = dot2d(x1, x2, apex) > 0
        if sharp.any():
            overlap = sharp & (orient2d(apex, x1, x2) == 0)
            if overlap.any():
                i = int(np.flatnonzero(overlap)[0])
                s1, s2 = sorted((int(e1[i] // 2), int(e2[i] // 2)))
                raise InputError(
                    f"segments {s1} and {s2} overlap from their common point "
                    f"{P[vert[e1[i]]].tolist()}",
                    loc=("segments", s2),
                    code="overlapping_segments",
                )
            acute[e1[sharp]] = True
            acute[e2[sharp]] = True
        k += 1
    return acute.reshape(m, 2)


def _segment_reach(st: _Pieces, rows, reach, verts, scale, tol) -> np.ndarray:
    """``reach`` lowered to the distance from each vertex to the nearest
    piece of ``rows`` not incident to it, where that is closer.

    The pieces are those :func:`_grid_reach` meets in cells about as many
    as the vertices, each vertex filed in those its disc of radius
    ``reach``, padded, meets (``scale``: the largest coordinate magnitude):
    every piece closer than ``reach`` is measured. (A search by length
    class in k-d trees of midpoints met a million pairs of long pieces and
    vertices near them on a 10,000-vertex star.)
    """
    X = st.xy[verts]
    grow, pad = _enlargement(scale, tol)
    padded = reach * grow + pad
    ex, ey = (X.max(axis=0) - X.min(axis=0)).tolist()
    cell = max(math.sqrt(ex * ey / len(X)), max(ex, ey) / len(X), float(np.median(padded)))
    return _grid_reach(st.xy, st.a, st.b, rows, verts, reach, padded, cell)


def _protection_bounds(P, S, acute, reach, verts) -> np.ndarray:
    """Largest safe protection radius of each vertex (Exercise 9.4).

    The smallest of: :data:`PROTECT_FRACTION` times ``reach`` (k,), the
    distance to the nearest other point or segment not incident to the
    vertex, and :data:`SHARE_FRACTION` times the shortest segment of the
    vertex's acute cluster (so that the protection points of both ends of a
    segment stay apart). ``verts`` are sorted; ``S`` and ``acute`` hold at
    least the segments with an acute end at one of them.
    """
    ends = np.flatnonzero(acute.ravel())
    end_vertex = S.ravel()[ends]
    pos = np.minimum(np.searchsorted(verts, end_vertex), len(verts) - 1)
    mine = verts[pos] == end_vertex
    seg = ends[mine] // 2
    d = P[S[seg, 1]] - P[S[seg, 0]]
    shortest = np.full(len(verts), np.inf)
    np.minimum.at(shortest, pos[mine], np.hypot(d[:, 0], d[:, 1]))
    return np.minimum(PROTECT_FRACTION * reach, SHARE_FRACTION * shortest)


# ---------------------------------------------------------------------------
# The splits
# ---------------------------------------------------------------------------


def admissible_segments(
    points,
    segments,
    *,
    circles=None,
    segment_circle=None,
    progress: Progress | None = None,
    tolerances: Tolerances = TOLERANCES,
) -> AdmissibleSegments:
    """Split segments until every one is an edge of the Delaunay triangulation.

    The raw-array entry point of §9.1.4 (the triangulator calls it); see
    the module documentation for the algorithm and its choices.

    Parameters
    ----------
    points : (n, 2) float64
        Distinct finite points, not all collinear.
    segments : (m, 2) int64
        A planar straight-line graph: segments meet only at common
        endpoints, no point lies inside a segment (one that does is used as
        the split point), no two segments join the same points.
    circles : (k, 3) float64, optional
        Circles ``(cx, cy, r)`` that some segments sample (§9.1.5).
    segment_circle : (m,) int64, optional
        Per segment, the index of the circle it samples, or -1 (straight).
        Its new points are placed on the circle.
    progress : callable, optional
        ``progress(fraction, message)`` after each pass; it may raise to
        cancel. The fraction is a heuristic (the number of passes is not
        known in advance).
    tolerances : Tolerances, optional

    Returns
    -------
    AdmissibleSegments

    Raises
    ------
    InputError
        Bad shapes, non-finite points, indices out of range, zero-length,
        duplicate or overlapping segments; what :func:`delaunay` refuses
        (duplicate or all-collinear points); ``point_near_segment`` (located
        at the segment and at the point) for an input point within float64
        rounding of a segment it does not end (valid in floating point, but
        a split point between them rounds onto the point or onto an end).
    AlgorithmError
        Too many added points (:data:`MAX_ADDED_FACTOR`), segments that
        cross (not a planar straight-line graph), or a segment too short to
        split in float64.

    References
    ----------
    Methods text §9.1.2-§9.1.5, Exercises 9.2-9.5.
    """
    P, S = _validated(points, segments)
    m0, n0 = len(S), len(P)
    if circles is None:
        circles = np.zeros((0, 3))
    circles = np.ascontiguousarray(circles, dtype=np.float64).reshape(-1, 3)
    if segment_circle is None:
        segment_circle = np.full(m0, -1, dtype=np.int64)
    segment_circle = np.asarray(segment_circle, dtype=np.int64).reshape(-1)
    if (
        len(segment_circle) != m0
        or ((segment_circle < -1) | (segment_circle >= len(circles))).any()
    ):
        raise InputError(
            "segment_circle must give, per segment, a circle index or -1",
            loc=("segment_circle",),
            code="bad_shape",
        )
    bad = np.flatnonzero(~np.isfinite(circles).all(axis=1) | ~(circles[:, 2] > 0))
    if bad.size:
        raise InputError(
            f"circle {int(bad[0])} must have a finite centre and a positive radius",
            loc=("circles", int(bad[0])),
            code="bad_curve",
        )
    # Work in a frame centred on the first point when that shift is exact:
    # the same input translated by any exact amount then makes the same
    # constructions, hence the same decisions (see _local_origin).
    origin = _local_origin(P)
    local_circles = circles - np.array([origin[0], origin[1], 0.0])
    st = _State(
        P=P - origin,
        S=S,
        source=np.arange(m0, dtype=np.int64),
        seg_circle=segment_circle,
        acute=_acute_ends(P, S),
        done=np.zeros((m0, 2), dtype=bool),
        radius=np.full(n0, np.nan),
        near=np.zeros((m0, 2), dtype=np.int64),
        n0=n0,
    )
    budget = _Budget(n0=n0, max_added=MAX_ADDED_FACTOR * (n0 + m0) + MAX_ADDED_BASE)
    tri = first = delaunay(P)
    if origin.any() and not _present(tri, S).all():
        # An exact translation changes no triangle (the kernel's ties depend
        # on the point set alone), so the first check reuses ``tri``; the
        # last triangulation is made in the input's frame only.
        _rounds(st, budget, local_circles, tolerances, progress, first=tri)
        # Back to the input's frame: the input points come back exactly; the
        # added ones are rounded, which may (rarely) undo a near tie, so the
        # splits go on there until every segment is an edge again.
        st.P = st.P + origin
        st.P[:n0] = P
        tri = None
    else:
        st.P = P
    tri = _rounds(st, budget, circles, tolerances, progress, first=tri)
    protected = np.flatnonzero(~np.isnan(st.radius))
    radius = st.radius[protected]
    for arr in (st.P, st.S, st.source, protected, radius):
        arr.flags.writeable = False
    return AdmissibleSegments(
        points=st.P,
        segments=st.S,
        source=st.source,
        added=len(st.P) - n0,
        rounds=budget.rounds,
        protected=protected,
        protection_radius=radius,
        _delaunay=tri,
        _input=(P, S, first),
        _tolerances=tolerances,
    )


def _local_origin(P: np.ndarray) -> np.ndarray:
    """The first point if subtracting it from every point is exact, else 0.

    Exactness is checked with the two-sum error of each difference (zero
    for all of them). Boundary samples far from the origin (translated by
    1e6) pass: their differences are small multiples of the coordinates'
    common ulp.
    """
    if not len(P):
        return np.zeros(2)
    o = P[0]
    d = P - o
    bv = P - d
    err = (P - (d + bv)) + (bv - o)
    return o.copy() if not err.any() else np.zeros(2)


@dataclass
class _Budget:
    n0: int
    max_added: int
    rounds: int = 0


def _rounds(st, budget, circles, tol, progress, first=None) -> Triangulation | None:
    """Split until every segment is an edge (§9.1.4); the last triangulation.

    The first check runs on a whole triangulation (``first``, or one made
    here); if segments are missing, the splits go on in one growing
    triangulation (:func:`_split_until_edges`) and None is returned: the
    last triangulation is then made anew from the final points when first
    read (:attr:`AdmissibleSegments.delaunay`: the one :func:`delaunay`
    gives; the triangulator does not read it).
    """
    try:
        tri = first if first is not None else delaunay(st.P)
    except InputError as exc:
        if exc.code != "duplicate_points" or first is not None:
            raise
        _coinciding(st)  # an added point rounded onto another back in the input's frame
        raise
    budget.rounds += 1
    missing = np.flatnonzero(~_present(tri, st.S))
    _report(budget, st, missing.size, progress)
    if missing.size == 0:
        return tri
    _split_until_edges(st, budget, missing, circles, tol, progress)
    return None


def _coinciding(st: _State) -> None:
    """Raise for an added point that coincides with another point: with an
    input point, that point is within rounding of the added point's segment
    (:func:`_unresolvable`); with an added one, two segments cross or touch."""
    order = np.lexsort((st.P[:, 1], st.P[:, 0]))
    same = np.flatnonzero((st.P[order[1:]] == st.P[order[:-1]]).all(axis=1))
    for k in same:
        a, b = sorted((int(order[k]), int(order[k + 1])))
        if b < st.n0:
            continue
        src = int(st.source[np.flatnonzero((st.S == b).any(axis=1))[0]])
        if a < st.n0:
            _unresolvable(st.P, src, a)
        other = int(st.source[np.flatnonzero((st.S == a).any(axis=1))[0]])
        raise AlgorithmError(
            f"segments {min(src, other)} and {max(src, other)} cross or touch near "
            f"{st.P[a].tolist()}: segments may meet only at their endpoints"
        )


def _report(budget, st, pending: int, progress) -> None:
    """Progress after the first check and after each pass of the loop."""
    if progress is not None:
        added = len(st.P) - budget.n0
        progress(
            budget.rounds / (budget.rounds + 4.0),
            f"pass {budget.rounds}: {pending} piece(s) to check, {added} point(s) added",
        )


def _split_until_edges(st, budget, missing, circles, tol, progress) -> None:
    """Split the missing pieces until every piece is an edge (§9.1.4).

    One triangulation grows by insertion
    (:class:`~meshcore.delaunay.kernel2d.IncrementalDelaunay`: the same
    triangles as triangulating anew) and the compiled loop
    (:func:`~meshcore.delaunay.admissible_loop._split_loop`) takes the
    pieces one at a time from a work stack, splits those that are not
    edges and pushes the new pieces and those the insertions removed. It
    comes back here to grow its arrays, to report progress, and, when its
    stack is empty, to protect the acute vertices its deferred pieces wait
    for (:func:`_protect`); the errors it finds are raised here.
    """
    scale = _scale(st.P)
    grow, pad = _enlargement(scale, tol)
    pc = _Pieces(st, IncrementalDelaunay(st.P))
    stack, sp = missing[::-1].astype(np.int64), len(missing)  # the first piece on top
    deferred = (np.empty(16, np.int64), np.empty(16, np.int64), np.empty(16), 0)
    n_stop = budget.n0 + budget.max_added
    while True:
        kernel = pc.dt.insertion_arrays(2)
        pc.reserve(2, 2)
        status, stack, sp, deferred, pc.m, pc.n, info = _split_loop(
            kernel,
            (pc.a, pc.b, pc.nxt, pc.src, pc.circ, pc.acute, pc.done, pc.near, pc.head, pc.tail),
            (pc.xy, pc.radius, pc.left, pc.right, pc.beside),
            (pc.end_start, pc.end_chain, pc.end_side),
            circles,
            (stack, sp),
            deferred,
            (pc.m, pc.n, pc.n0, n_stop, pc.n + TICK_POINTS),
            (pc.dt.scale, grow, pad, tol.angle_tie),
            pc.stamps(),
        )
        pc.dt.grown_to(pc.n)
        budget.rounds += 1
        _report(budget, pc, sp + deferred[3], progress)
        if status == DONE:
            break
        if status == PROTECT:
            rows, vert, dist, nd = deferred
            _protect(pc, rows[:nd], vert[:nd], dist[:nd], scale, tol)
            stack = np.unique(rows[:nd])[::-1].copy()  # back on the stack, the first on top
            sp, deferred = len(stack), (rows, vert, dist, 0)
        elif status not in (ROOM, TICK):
            _loop_error(pc, status, info, budget, sp + deferred[3])
    pc.to_state(st)


def _protect(pc: _Pieces, rows, E, x, scale, tol) -> None:
    """Protection radii of the acute vertices ``E`` (Exercises 9.2-9.4):
    the deferred pieces ``rows`` had a second projection split near them,
    at distance ``x``; the chase of Exercise 9.3 may have begun. The
    radius is the smallest ``x`` at the vertex when that is within the safe
    bound (:func:`_protection_bounds`), else the bound. The deferred pieces
    are all the missing ones now (the loop's stack is empty), so the
    nearest non-incident piece is among them or among the edges near the
    vertex."""
    P = pc.P
    verts, inv = np.unique(E, return_inverse=True)
    # Nearest other point (a Delaunay neighbour), nearest missing piece,
    # nearest piece that is an edge (an edge of a triangle meeting the disc
    # of that radius).
    reach = pc.dt.nearest_distance(verts)
    reach = _segment_reach(pc, rows, reach, verts, scale, tol)
    q, near_rows = pc.edge_pieces_near(verts, reach)
    if q.size:
        d = point_segment_distance(P[verts[q]], P[pc.a[near_rows]], P[pc.b[near_rows]])[0]
        np.minimum.at(reach, q, d)
    r = _protection_bounds(P, *pc.end_pieces(verts), reach, verts)
    np.minimum.at(r, inv, x)
    pc.radius[verts] = r


def _loop_error(pc: _Pieces, status, info, budget, pending) -> None:
    """Raise the error the loop stopped at (``info``: the piece, the points)."""
    r, x = int(info[0]), int(info[1])
    P = pc.P
    if status == BUDGET:
        added = pc.n - budget.n0
        raise AlgorithmError(
            f"no Delaunay-admissible discretization within {budget.max_added} added points "
            f"(the limit, {MAX_ADDED_FACTOR} x (points + segments) + {MAX_ADDED_BASE}): "
            f"{added} added, {pending} pieces still to check; "
            "the boundary's close features need more points than that"
        )
    if status == ON_SEGMENT:
        _not_planar(pc, r, x)
    if status == DUPLICATE:
        p, last = int(info[2]), int(info[3])
        if x < pc.n0:
            _unresolvable(pc.xy, int(pc.src[r]), x)
        pc.touching(int(pc.src[r]), int(pc.src[pc.right[x]]), x)
        raise AlgorithmError(
            f"cannot split the segment from {P[pc.a[r]].tolist()} to {P[pc.b[last]].tolist()}: "
            f"the split point {P[p].tolist()} is an existing point (do segments cross or touch?)"
        )
    if status == BAD_SPLIT:
        side = int(info[2])
        if side >= 0:  # a projection that rounds onto an end of the piece
            e = int(pc.a[r] if side == 0 else pc.b[r])
            if x < pc.n0:  # x within rounding of the piece
                _unresolvable(P, int(pc.src[r]), x)
            if e < pc.n0:  # x, on another segment, within rounding of the end e
                _unresolvable(P, int(pc.src[pc.right[x]]), e)
        raise AlgorithmError(
            f"cannot split the segment from {P[pc.a[r]].tolist()} to {P[pc.b[r]].tolist()}: it "
            "is too short for float64 at that distance from the origin (or segments cross there)"
        )
    raise AlgorithmError(
        f"piece {r} is not a Delaunay edge yet its closed diametral ball is empty "
        "(inconsistent predicates)"
    )


def _not_planar(st: _State, row: int, point: int) -> None:
    """Raise for a point found strictly inside a segment (not a PSLG)."""
    src = int(st.source[row])
    xy = st.P[point].tolist()
    if point < st.n0:
        raise InputError(
            f"point {point} {xy} lies inside segment {src}: segments may meet only at "
            "their endpoints",
            loc=("segments", src),
            code="point_on_segment",
        )
    other = int(st.source[np.flatnonzero((st.S == point).any(axis=1))[0]])
    raise AlgorithmError(
        f"segments {min(src, other)} and {max(src, other)} cross near {xy}: segments may "
        "meet only at their endpoints"
    )


# ---------------------------------------------------------------------------
# The empty triangulation of the domain (§9.4.1)
# ---------------------------------------------------------------------------


def restricted_triangles(tri: Triangulation, segments, two_sided=None) -> np.ndarray:
    """The triangles of ``tri`` inside the domain the segments bound.

    A flood fill over the triangles, across edges that are not segments,
    from the triangle on the left of every segment (and on its right too
    where ``two_sided``): regions, never centroid tests.

    Parameters
    ----------
    tri : Triangulation
        A triangulation having every segment as an edge.
    segments : (m, 2) int64
        Boundary segments oriented with the domain on their left, and
        interior constraints.
    two_sided : (m,) bool, optional
        True for interior constraints (domain on both sides).

    Returns
    -------
    (k,) int64
        Indices of the triangles inside, increasing.

    Raises
    ------
    InputError
        ``not_an_edge`` if a segment is not an edge of ``tri``,
        ``inconsistent_orientation`` if a segment has no triangle on its
        left or the fill reaches both sides of a one-sided segment.

    References
    ----------
    Methods text §9.4.1 (the Delaunay triangulation of the domain whose sole
    vertices are the boundary points).
    """
    S = np.asarray(segments, dtype=np.int64).reshape(-1, 2)
    two = np.zeros(len(S), dtype=bool) if two_sided is None else np.asarray(two_sided, bool)
    t, nb = tri.triangles, tri.neighbors
    n = len(tri.points)
    nt = len(t)
    # Directed edge (a -> b) of triangle row, counter-clockwise: opposite vertex i.
    ea = np.concatenate([t[:, (i + 1) % 3] for i in range(3)])
    eb = np.concatenate([t[:, (i + 2) % 3] for i in range(3)])
    owner = np.tile(np.arange(nt, dtype=np.int64), 3)
    across = np.concatenate([nb[:, i] for i in range(3)])
    directed = ea * np.int64(n) + eb
    order = np.argsort(directed)
    dsorted = directed[order]

    def left_of(a, b):
        key = a * np.int64(n) + b
        pos = np.minimum(np.searchsorted(dsorted, key), len(dsorted) - 1)
        hit = dsorted[pos] == key
        return np.where(hit, owner[order[pos]], -1)

    left = left_of(S[:, 0], S[:, 1])
    right = left_of(S[:, 1], S[:, 0])
    absent = np.flatnonzero((left < 0) & (right < 0))
    if absent.size:
        i = int(absent[0])
        raise InputError(
            f"segment {i} is not an edge of the triangulation",
            loc=("segments", i),
            code="not_an_edge",
        )
    no_side = np.flatnonzero((left < 0) | (two & (right < 0)))
    if no_side.size:
        i = int(no_side[0])
        raise InputError(
            f"segment {i} has no triangle on its domain side: is the boundary oriented "
            "with the domain on the left?",
            loc=("segments", i),
            code="inconsistent_orientation",
        )
    seeds = np.concatenate([left, right[two]])
    barrier = np.isin(edge_keys(ea, eb, n), edge_keys(S[:, 0], S[:, 1], n))
    link = (across >= 0) & ~barrier
    graph = coo_matrix(
        (np.ones(int(link.sum()), dtype=np.int8), (owner[link], across[link])), shape=(nt, nt)
    )
    _, labels = connected_components(graph, directed=False)
    inside = np.isin(labels, labels[seeds])
    leak = right[~two]
    if (leak >= 0).any() and inside[leak[leak >= 0]].any():
        raise InputError(
            "the segments do not bound a region consistently: the fill from their left "
            "sides reaches the right side of a boundary segment",
            loc=("segments",),
            code="inconsistent_orientation",
        )
    return np.flatnonzero(inside)


# ---------------------------------------------------------------------------
# Domains and curves
# ---------------------------------------------------------------------------


def circles_of(
    domain: Domain, curves: Sequence[Mapping] | None, tolerances: Tolerances = TOLERANCES
) -> tuple[np.ndarray, np.ndarray]:
    """Validated circle curves of a domain's rings (§9.1.5).

    Parameters
    ----------
    domain : Domain
    curves : list of mappings, optional
        ``{"ring": k, "type": "circle", "center": [x, y], "radius": r}``;
        rings are numbered in the order of the geometry (``Domain`` ring
        numbering).

    Returns
    -------
    circles : (k, 3) float64
        ``(cx, cy, r)`` per curve.
    segment_circle : (m,) int64
        Per boundary segment then constraint segment of the domain, its
        circle index or -1.

    Raises
    ------
    InputError
        With ``loc`` ``("curves", i, field)``: a ring index that does not
        exist or is declared twice, a type other than ``"circle"``, a
        non-finite centre, a radius that is not positive, or a ring whose
        points are farther than ``curve_fit`` times the domain's diameter
        from the circle (naming the vertex).
    """
    m = len(domain.segments) + len(domain.constraints)
    seg_circle = np.full(m, -1, dtype=np.int64)
    if not curves:
        return np.zeros((0, 3)), seg_circle
    if not isinstance(curves, Sequence) or isinstance(curves, str):
        raise InputError(
            f"curves must be a list of curve objects, got {type(curves).__name__}",
            loc=("curves",),
            code="bad_curve",
        )
    n_rings = len(domain.ring_offsets) - 1
    rows = []
    seen: dict[int, int] = {}
    for i, curve in enumerate(curves):
        if not isinstance(curve, Mapping):
            raise InputError("a curve must be an object", loc=("curves", i), code="bad_curve")
        kind = curve.get("type", "circle")
        if kind != "circle":
            raise InputError(
                f"curve {i}: unknown type {kind!r} (only 'circle')",
                loc=("curves", i, "type"),
                code="bad_curve",
            )
        ring = curve.get("ring")
        if (
            isinstance(ring, bool)
            or not isinstance(ring, int | np.integer)
            or not (0 <= ring < n_rings)
        ):
            raise InputError(
                f"curve {i}: ring {ring!r} does not exist (the domain has {n_rings} ring(s), "
                "numbered from 0 in the order of the geometry)",
                loc=("curves", i, "ring"),
                code="bad_curve",
            )
        ring = int(ring)
        if ring in seen:
            raise InputError(
                f"curve {i}: ring {ring} already has curve {seen[ring]}",
                loc=("curves", i, "ring"),
                code="bad_curve",
            )
        seen[ring] = i
        try:
            centre = np.asarray(curve.get("center"), dtype=np.float64).reshape(2)
        except (TypeError, ValueError):
            centre = np.array([np.nan, np.nan])
        if not np.isfinite(centre).all():
            raise InputError(
                f"curve {i}: center must be two finite numbers",
                loc=("curves", i, "center"),
                code="bad_curve",
            )
        radius = curve.get("radius")
        if (
            isinstance(radius, bool)
            or not isinstance(radius, int | float | np.number)
            or not math.isfinite(radius)
            or radius <= 0
        ):
            raise InputError(
                f"curve {i}: radius must be a positive number, got {radius!r}",
                loc=("curves", i, "radius"),
                code="bad_curve",
            )
        lo, hi = int(domain.ring_offsets[ring]), int(domain.ring_offsets[ring + 1])
        pts = domain.points[lo:hi]
        off = np.abs(np.hypot(pts[:, 0] - centre[0], pts[:, 1] - centre[1]) - radius)
        allowed = tolerances.curve_fit * domain.diameter
        worst = int(np.argmax(off))
        if off[worst] > allowed:
            raise InputError(
                f"curve {i}: vertex {worst} of ring {ring} at {pts[worst].tolist()} is "
                f"{off[worst]:.3g} away from the circle (center {centre.tolist()}, radius "
                f"{radius}); allowed: {allowed:.3g} ({tolerances.curve_fit:g} times the "
                "domain's diameter)",
                loc=("curves", i, "radius"),
                code="curve_mismatch",
            )
        seg_circle[lo:hi] = len(rows)
        rows.append([centre[0], centre[1], float(radius)])
    return np.asarray(rows, dtype=np.float64), seg_circle


def make_admissible(
    domain: Domain,
    curves: Sequence[Mapping] | None = None,
    progress: Progress | None = None,
) -> AdmissibleBoundary:
    """A Delaunay-admissible discretization of a domain's boundary (§9.1.5).

    Parameters
    ----------
    domain : Domain
        From :func:`meshcore.domain.planar.parse_domain`; its boundary segments and
        interior constraints are made admissible together.
    curves : list of mappings, optional
        Circles that rings sample, ``{"ring": k, "type": "circle",
        "center": [x, y], "radius": r}`` (see :func:`circles_of`): new points
        on that ring are placed on the circle.
    progress : callable, optional
        ``progress(fraction, message)``; it may raise to cancel.

    Returns
    -------
    AdmissibleBoundary
        The new discretization and the empty Delaunay triangulation of the
        domain (§9.4.1). Without curves its triangles' areas add up to the
        domain's area; with curves, new points lie on the circles, so the
        area is that of the refined polygon.

    Raises
    ------
    InputError
        Bad curves (:func:`circles_of`); as :func:`admissible_segments`,
        located at the domain's vertices (:meth:`Domain.vertex_loc`).
    AlgorithmError
        As :func:`admissible_segments`.

    References
    ----------
    Methods text §9.1.2-§9.1.5, §9.4.1; Exercises 9.2-9.5.
    """
    circles, seg_circle = circles_of(domain, curves)
    segments = np.concatenate([domain.segments, domain.constraints]).astype(np.int64)
    try:
        result = admissible_segments(
            domain.points,
            segments,
            circles=circles,
            segment_circle=seg_circle,
            progress=progress,
        )
    except InputError as exc:
        raise located_in_domain(exc, domain, segments) from None
    two_sided = result.source >= len(domain.segments)
    inside = restricted_triangles(result.delaunay, result.segments, two_sided)
    mesh = Mesh(result.points, (CellBlock("triangle", result.delaunay.triangles[inside]),))
    return AdmissibleBoundary(
        points=result.points,
        segments=result.segments,
        source=result.source,
        cases_before=result.cases_before,
        cases_after=result.cases_after,
        added=result.added,
        rounds=result.rounds,
        protected=result.protected,
        triangulation=mesh,
    )
