"""Delaunay-admissible boundary discretizations (methods text §9.1.2-§9.1.5).

A set of segments is *Delaunay-admissible* when every segment is an edge of
the Delaunay triangulation of the segments' endpoints (§9.1). Given a
boundary discretization that is not, :func:`make_admissible` (on a
:class:`~meshcore.domain.planar.Domain`) and :func:`admissible_segments` (on raw
arrays, for the triangulator) split the offending segments until it is, and
:func:`make_admissible` also returns the "empty" Delaunay triangulation of
the domain (§9.4.1: no vertex inside, only boundary points).

Algorithm (§9.1.4), in rounds, each one vectorized over the segments it
splits:

1. Triangulate the input points with :func:`meshcore.delaunay.kernel2d.delaunay`
   (our exact kernel) and look every segment up among its edges (a
   compiled, linear-time scan of the vertex adjacency). Stop when all are
   there. Otherwise the rounds go on in one
   :class:`~meshcore.delaunay.kernel2d.IncrementalDelaunay`: each round
   inserts its split points (the same triangles as triangulating anew: the
   kernel's ties depend only on the point set) and finds the pieces that
   are no longer edges from what each insertion logged: a new piece is
   missing when its later end went in without the other end among its
   neighbours, an older one when an insertion removed it (flipped it away:
   an edge once removed comes back only at an insertion of one of its
   ends). The last triangulation is made anew from the final
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
Cases are reported for the input and for the output. Only segments that
are not Delaunay edges in a round are split, so a Case 2 segment whose
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
  so that segments that are Delaunay stay whole). The safe bound is
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
* **Termination guard.** Rounds stop with
  :class:`~meshcore.errors.AlgorithmError` after :data:`MAX_ROUNDS` rounds
  or when the points added exceed :data:`MAX_ADDED_FACTOR` times the input
  size plus :data:`MAX_ADDED_BASE`, each with its own message: crossing
  segments (not a planar straight-line graph) get there, and so do valid
  inputs whose close features need more points than the limit (a random
  star of 30,000 vertices needs 4.6M).

Frames and ties. The rounds run in a frame centred on the first input
point when that shift is exact (:func:`_local_origin`): an input moved by an
exact translation then makes bit-identical constructions and decisions.
Back in the input's frame, the added points are rounded once more, and the
rounds continue there until every segment is an edge again (normally no
round at all): the guarantee is always checked on the returned coordinates.
Projections make right angles, so the output may hold exactly co-circular
quadrilaterals around a segment; the segment is then an edge of our
kernel's triangulation (its exact tie-breaking), and a Delaunay code with
other tie-breaking may need a swap to show it (§9.1.3, footnote 4);
floating-point codes such as Qhull may take either diagonal.

Cost: a round costs time in the pieces it splits and checks (insertions,
lens searches, split points and the pieces' bookkeeping in
compiled code), not in all points, plus one whole triangulation at the
start and, when it is read, one at the end. Rounds are few on the test
polygons (2 to 8). A random star of ``n`` vertices (``benchmarks/admissible.py``)
is ``n`` spikes about ``2 pi / n`` wide, and the added points grow about as
``n ** 1.8`` (9,291 at 1,000 vertices, 67,859 at 3,000, 603,670 at 10,000,
spread evenly along the segments: on the 3,000-vertex star the median
piece is 11 times its distance to the nearest other segment, the pieces of
neighbouring segments lining up in rungs). The measurements point to the
input more than to the rule: Triangle's full conforming Delaunay (``pcD``)
adds 6 to 11 times more; on a 200-vertex star a greedy pass that drops
added points one at a time while every segment stays a Delaunay edge drops
only 9 % of them, and splitting one segment per round instead of all saves
7 %; the near-end clamp's constants move the count by under 10 %. Two
"concentric shell" rules at acute ends were tried and add more points
(3,000-vertex star, 67,859 now): a split at the encroaching point's
distance from the apex (the two sides of a wedge then split alike) 79,234,
and Ruppert's power-of-two distances (quarter powers) 121,726. The
10,000-vertex star takes 146 rounds (each spike's chain of splits is
sequential) and about 1.7 CPU s (2.0 before the compiled searches and
insertions prefetched; 2.7 before the insertions logged the edges they
remove; 5.5 before the searches stopped at the crossed triangles), per
added point: the insertion about 1 µs (5 walk steps, 12 to 18 in-circle
tests), the widest-angle search 0.75 (6 to 22 triangles), the pieces'
bookkeeping, protection radii and Python 1.1, mostly waiting on memory;
126 s when every round re-triangulated everything. The case counts of
the result are computed when first read.

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

from meshcore.delaunay.admissible_pieces import (
    _ball_radii,
    _grid_reach,
    _Pieces,
    _projection_points,
    _split_points,
    _State,
    _unresolvable,
    _widest_angle_points,
    located_in_domain,
)
from meshcore.delaunay.kernel2d import (
    IncrementalDelaunay,
    Triangulation,
    delaunay,
)
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
#: At most this many rounds.
MAX_ROUNDS = 2000
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
        Triangulation rounds run (the last one finds nothing to split).
    protected : (k,) int64
        The acute vertices that were protected (Exercises 9.2-9.4).
    protection_radius : (k,) float64
        Their protection radii: every protected segment piece at such a
        vertex has this length.
    delaunay : Triangulation
        The Delaunay triangulation of :attr:`points` (all of the convex hull),
        made on first read when the rounds added points.
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
        Triangulation rounds run.
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
    try:
        S = np.array(segments, dtype=np.int64)
    except (TypeError, ValueError) as exc:
        raise InputError(
            "segments must be an (m, 2) integer array", loc=("segments",), code="bad_shape"
        ) from exc
    if S.size == 0:
        S = S.reshape(0, 2)
    if S.ndim != 2 or S.shape[1] != 2:
        raise InputError(
            f"segments must have shape (m, 2), got {S.shape}", loc=("segments",), code="bad_shape"
        )
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
# Split points
# ---------------------------------------------------------------------------


def _on_circle(M: np.ndarray, circ: np.ndarray) -> np.ndarray:
    """Points M moved radially onto their circles (rows of (cx, cy, r))."""
    c = circ[:, :2]
    d = M - c
    norm = np.hypot(d[:, 0], d[:, 1])
    return c + d * (circ[:, 2] / norm)[:, None]


def _protection_on_circle(apex, far, radius, cc) -> np.ndarray:
    """Protection points of curved segments: on their circles (rows of
    ``cc``), at chord distance ``radius`` from the apex, toward ``far``."""
    centre, R = cc[:, :2], cc[:, 2]
    u = apex - centre
    u = u * (R / np.hypot(u[:, 0], u[:, 1]))[:, None]
    w = far - centre
    turn = np.sign(u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0])
    phi = 2.0 * np.arcsin(np.minimum(radius / (2.0 * R), 1.0)) * turn
    cos, sin = np.cos(phi), np.sin(phi)
    return centre + np.column_stack([cos * u[:, 0] - sin * u[:, 1], sin * u[:, 0] + cos * u[:, 1]])


def _choose_encroachers(missing, st: _Pieces, scale, tol):
    """Per missing piece, the point of its closed diametral ball with the
    largest angle APB (ties within ``angle_tie``: smallest index), found by
    :func:`_widest_angle_points` in the rounds' triangulation; and whether
    it lies on the piece (collinear). The searches go along the chains
    (:meth:`_Pieces.along`): consecutive ones then meet the same triangles
    (each choice is independent of the order; 40 % less time on the
    10,000-vertex star than in piece order)."""
    seq, sa, sb, radii = st.along(missing, *_enlargement(scale, tol))
    pts, V, A, vt, order, _ = st.dt.arrays()
    if len(st.tstamp) < len(V) // 3 or len(st.vstamp) < len(pts):
        st.tstamp = np.zeros(len(V) // 3, np.int64)
        st.vstamp = np.zeros(len(pts), np.int64)
        st.counter[0] = 0
    choice, on_segment = _widest_angle_points(
        pts,
        V,
        A,
        vt,
        order,
        sa,
        sb,
        radii,
        tol.angle_tie,
        st.tstamp,
        st.vstamp,
        st.counter,
        st.work,
    )
    if (choice < 0).any():
        i = int(missing[seq[np.flatnonzero(choice < 0)[0]]])
        raise AlgorithmError(
            f"piece {i} is not a Delaunay edge yet its closed diametral ball is empty "
            "(inconsistent predicates)"
        )
    out, flat = np.empty_like(choice), np.empty_like(on_segment)
    out[seq], flat[seq] = choice, on_segment
    return out, flat


# ---------------------------------------------------------------------------
# The rounds
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
        ``progress(fraction, message)`` after each round; it may raise to
        cancel. The fraction is a heuristic (the number of rounds is not
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
        More than :data:`MAX_ROUNDS` rounds or too many added points (an
        input that is not a planar straight-line graph), or a segment too
        short to split in float64.

    References
    ----------
    Methods text §9.1.2-§9.1.5, Exercises 9.2-9.5.
    """
    P, S = _validated(points, segments)
    m0, n0 = len(S), len(P)
    if circles is None:
        circles = np.zeros((0, 3))
    circles = np.asarray(circles, dtype=np.float64).reshape(-1, 3)
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
        # rounds go on there until every segment is an edge again.
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
    """Rounds of §9.1.4 until every segment is an edge; the last triangulation.

    The first check runs on a whole triangulation (``first``, or one made
    here); if segments are missing, the rounds go on incrementally
    (:func:`_incremental_rounds`) and None is returned: the last
    triangulation is then made anew from the final points when first read
    (:attr:`AdmissibleSegments.delaunay`: the one :func:`delaunay` gives;
    the triangulator does not read it).
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
    if _report(budget, st, missing, progress):
        return tri
    _incremental_rounds(st, budget, missing, circles, tol, progress)
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


def _report(budget, st, missing, progress) -> bool:
    """Progress of a round; True when nothing is missing; the guard."""
    added = len(st.P) - budget.n0
    if progress is not None:
        progress(
            budget.rounds / (budget.rounds + 4.0),
            f"round {budget.rounds}: {missing.size} segment(s) not Delaunay, "
            f"{added} point(s) added",
        )
    if missing.size == 0:
        return True
    if added > budget.max_added:
        raise AlgorithmError(
            f"no Delaunay-admissible discretization within {budget.max_added} added points "
            f"(the limit, {MAX_ADDED_FACTOR} x (points + segments) + {MAX_ADDED_BASE}): "
            f"{added} added in {budget.rounds} rounds, {missing.size} segments still missing; "
            "the boundary's close features need more points than that"
        )
    if budget.rounds >= MAX_ROUNDS:
        raise AlgorithmError(
            f"no Delaunay-admissible discretization after {budget.rounds} rounds and "
            f"{added} added points ({missing.size} segments still missing): "
            "do segments cross?"
        )
    return False


def _incremental_rounds(st, budget, missing, circles, tol, progress) -> None:
    """Split rounds on one triangulation that grows by insertion.

    Each round inserts its split points into the triangulation
    (:class:`~meshcore.delaunay.kernel2d.IncrementalDelaunay`: the same
    triangles as triangulating anew) and finds the pieces that are no
    longer edges from the neighbours of each inserted point
    (:meth:`_Pieces.missing`); ball and nearest-point queries walk the triangulation. The
    decisions are those of whole-array rounds, in time proportional to the
    pieces split and checked.
    """
    scale = _scale(st.P)
    pc = _Pieces(st, IncrementalDelaunay(st.P))
    while True:
        _split_round(pc, missing, scale, circles, tol, budget.rounds)
        budget.rounds += 1
        missing = pc.missing()
        if _report(budget, pc, missing, progress):
            break
    pc.to_state(st)


def _split_round(st: _Pieces, missing, scale, circles, tol, round_no) -> None:
    """One round of splits of the missing segments (§9.1.4, Exercises 9.2-9.4).

    Each missing segment gets its projection split point ``M``, nearer its
    end ``E``. A segment of an acute cluster at ``E`` may be split near
    ``E`` by projection once; a second time, the chase of Exercise 9.3 may
    have begun and ``E`` is protected: its radius is fixed, the projection
    distance ``|EM|`` when that is within the safe bound
    (:func:`_protection_bounds`), the bound otherwise. From then on every
    missing piece of its cluster is split at exactly that distance from
    ``E`` (and gets no projection split that round).
    """
    # The missing pieces' own rows: a round costs time in them, not in all.
    P = st.P
    enc, on_segment = _choose_encroachers(missing, st, scale, tol)
    if on_segment.any():
        _not_planar(st, missing[on_segment][0], enc[on_segment][0])
    M, near, again = _projection_points(
        st.xy, st.a, st.b, missing, enc, st.acute, st.done, st.near, st.radius
    )
    curved = np.flatnonzero(st.circ[missing] >= 0) if len(circles) else ()
    if len(curved):
        M[curved] = _on_circle(M[curved], circles[st.circ[missing[curved]]])
    if again.any():
        # A second projection split near the same acute vertex on the same
        # segment: the chase of Exercise 9.3 may have begun; protect the vertex.
        rows = np.flatnonzero(again.any(axis=1))
        E = np.where(near[rows] == 0, st.a[missing[rows]], st.b[missing[rows]])
        x = np.hypot(M[rows, 0] - P[E, 0], M[rows, 1] - P[E, 1])
        verts, inv = np.unique(E, return_inverse=True)
        # Nearest other point (a Delaunay neighbour), nearest missing piece,
        # nearest piece that is an edge (an edge of a triangle meeting the
        # disc of that radius).
        reach = st.dt.nearest_distance(verts)
        reach = _segment_reach(st, missing, reach, verts, scale, tol)
        q, near_rows = st.edge_pieces_near(verts, reach)
        if q.size:
            d = point_segment_distance(P[verts[q]], P[st.a[near_rows]], P[st.b[near_rows]])[0]
            np.minimum.at(reach, q, d)
        r = _protection_bounds(P, *st.end_pieces(verts), reach, verts)
        np.minimum.at(r, inv, x)
        st.radius[verts] = r
    rows, xy, t, protect_side, near_side, near_vertex, bad = _split_points(
        st.xy, st.a, st.b, missing, M, near, enc, st.acute, st.done, st.radius, st.work
    )
    if len(curved):
        _curved_split_points(st, circles, rows, xy, protect_side, near_vertex, bad)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        if near_side[i] >= 0:  # a projection that rounds onto an end of the piece
            x = int(enc[np.searchsorted(missing, rows[i])])
            e = int(st.a[rows[i]] if near_side[i] == 0 else st.b[rows[i]])
            if x < st.n0:  # x within rounding of the piece
                _unresolvable(P, int(st.source[rows[i]]), x)
            if e < st.n0:  # x, on another segment, within rounding of the end e
                _unresolvable(P, int(st.src[st.right[x]]), e)
        a, b = P[st.a[rows[i]]], P[st.b[rows[i]]]
        raise AlgorithmError(
            f"cannot split the segment from {a.tolist()} to {b.tolist()}: it is too "
            "short for float64 at that distance from the origin (or segments cross there)"
        )
    # A new point that coincides with another point, new or old (segments
    # that cross or touch would share it), is found by the insertion.
    st.split(rows, t, xy, protect_side, near_side, near_vertex, round_no)


def _curved_split_points(st: _Pieces, circles, rows, xy, protect_side, near_vertex, bad):
    """The protection points of curved pieces moved onto their circles
    (the projections were moved already), and their check redone: every
    split point must lie strictly inside its piece's diametral ball (so it
    differs from both ends); this fails only for segments too short for
    float64 at their distance from the origin."""
    circ = st.circ[rows]
    fix = np.flatnonzero((circ >= 0) & (protect_side >= 0))
    if fix.size:
        e = near_vertex[fix]
        f = np.where(protect_side[fix] == 0, st.b[rows[fix]], st.a[rows[fix]])
        xy[fix] = _protection_on_circle(st.xy[e], st.xy[f], st.radius[e], circles[circ[fix]])
    curved = np.flatnonzero(circ >= 0)
    a, b = st.xy[st.a[rows[curved]]], st.xy[st.b[rows[curved]]]
    bad[curved] = dot2d(a, b, xy[curved]) >= 0


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
