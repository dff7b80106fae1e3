"""Delaunay-admissible closed surfaces in 3D (methods text §9.2, §9.3, §9.3.5).

A set of triangular faces is *Delaunay-admissible* when every face is a
face of a Delaunay tetrahedralization of the faces' vertices (§9.3; where
points are co-spherical there are several, and a face of any of them is
Delaunay: its vertices' Voronoï cells meet, §9.2).
:func:`make_admissible_surface` takes a closed surface
(:func:`meshcore.domain.surface.parse_surface`), refines it with points ON
the surface until it is, and returns the refined surface (each output
triangle lies in one *facet*: an input triangle, or a maximal set of
exactly coplanar input triangles joined across edges) and the *empty* Delaunay
tetrahedralization of the inside (only surface points: the starting point
of §9.5).

Algorithm
---------
The state is our kernel's tetrahedralization
(:class:`meshcore.delaunay.kernel3d.IncrementalDelaunay3d`), only ever grown
by point insertion (never rebuilt), and the subsegments and subfaces of
:mod:`meshcore.tets.refinement`'s builder: each input edge cut into
subsegments, each facet (the input triangles joined across edges whose
four corners are exactly coplanar, ``orient3d == 0``, form one, whose
inner input edges are no constraints: "it is possible to achieve a
Delaunay triangulation by means of edge swapping", §9.3.2) triangulated
in its plane by the 2D Delaunay triangulation (kernel2d) of its corners
and of the points added on its boundary edges and inside it (the input
triangles while none is added). That 2D Delaunay triangulation is what
makes the great circles ``gc_f`` empty (the reduced classification of
§9.3.2: the in-plane swaps). Rounds, each vectorized over all missing pieces:

1. **Coplanar swaps** (Pébay's second heuristic, §9.3.4): a subface that is
   not a face of the tetrahedralization, whose neighbour in the same facet
   forms with it a convex quadrilateral whose other diagonal gives two
   faces of the tetrahedralization, is swapped (a facet's input triangles
   on a diagonal the 3D kernel does not hold, co-circular squares, nearly
   co-circular points whose diagonal the 3D kernel decides differently
   from the 2D one).
2. **Edges first** (§9.3.4 (A), §9.2): every subface edge that is not an
   edge of the tetrahedralization is split at the projection onto it of
   the point ``P`` of its closed diametral ball ``B_AB`` with the largest
   angle ``APB`` (exact membership by
   :func:`~meshcore.geometry.predicates3d.dot3d`). The projection rules of
   the 2D module apply unchanged (:data:`~meshcore.delaunay.admissible_pieces.NEAR_END_TRIGGER`,
   ``NEAR_END_FRACTION``, ``NUDGE``): the balls of the two halves lie in
   ``B_AB`` and miss ``P`` (Relationship 9.2).
3. **Then faces** (§9.3.4, face enforcement): every subface still missing
   (its edges all present) gets the point ``P`` of its closed ball
   ``B_f^min`` with the largest solid angle over ``f``; ``P``'s projection
   ``M`` onto the facet's plane is a candidate when it lies inside ``f``,
   and so are the projections of ``P`` onto the edges of ``f`` (and points
   spread over them, the look-ahead's); the
   candidate whose insertion leaves the fewest pieces missing (the
   look-ahead below) wins, and among
   those the one whose split of ``f`` has the largest least angle
   (Pébay's first heuristic).

Each round looks every subsegment, subface edge and subface up in the grown
tetrahedralization (sorted integer keys of all its edges and faces: one
vectorized pass, no re-tetrahedralization), splits the missing ones, and
re-triangulates only the facets whose points changed.

**Ties** (Remark 9.6: "the solution may be obtained after a swap"). Where
points are exactly co-spherical (boxes, grids, any planar quadrilateral
with its corners on a circle), the kernel's symbolic perturbation picks one
of several Delaunay tetrahedralizations, and a subface whose diagonal it
rejects is missing from it but not from another one. Each round, before
splitting, every missing subface edge that is the diagonal of such a
quadrilateral (its two subfaces) is given its cells' other Delaunay
tetrahedralization when one holds it
(:class:`~meshcore.delaunay.ties3d.TieFlips`, on a copy of the kernel's
tetrahedra: the kernel keeps its own, and the flips are made anew from it
each round). The output's ``tetrahedra`` are the flipped ones.
With every input triangle a facet of its own, the flips took the unit
cube from 6 points to 0, boxes of n x n squares a face (n = 2 to 8) to 0
(36 and 120 before for n = 2, 3), a box with a box-shaped cavity 42 -> 0,
the L-block 10 -> 7, the benchmark's slab 168 -> 0, but a 4 x 2 x 1 box
with n = 6 and the slab with n = 8 kept 24 points each. With the facets
of coplanar triangles, the coplanar swaps of step 1 give each of these
surfaces the diagonals the kernel holds: all of them, the L-block too,
need no point and no flip. The flips remain for a planar quadrilateral
(only those are noted: exact ``orient3d == 0``) that cuts a cell of
co-spherical points, when the kernel holds one triangle of its other
diagonal but not both, so that no swap applies (two shells with all their
corners on one sphere, the pyramid's base cutting the cell: the tests);
a quadrilateral that is not planar is never flipped.

Choices that save points (measured on the benchmark's 4,000-vertex bumpy
sphere: 641 points when every missing edge of a round is split at the plain
projection, 578 with the first two, 539 with the look-ahead; on the random
star polyhedra of seeds 1-40 / 41-240, 134 / 501 points without the
look-ahead, 97 / 441 with it):

* **Common interval.** Every encroaching point ``Q`` of a missing edge
  ``AB`` is outside both halves' balls when the split parameter lies in an
  interval ``[t1, t2]`` (Thales); where the intervals of all of the edge's
  encroachers meet, the split moves into their common part
  (:data:`COMMON_MARGIN` of its length away from its ends), so that one
  split clears them all.
* **Look-ahead on the cavity** (:class:`~meshcore.delaunay.cavities3d.Cavities`).
  Inserting a point removes the tetrahedra whose circumsphere holds it (its
  cavity) and joins it to the cavity's boundary: a subface or subface edge
  all of whose tetrahedra go (unless on the hull) is no longer a face or
  edge, and a new piece at the point (an edge to a vertex, a subface on an
  edge) is made only if that vertex or edge is on the cavity's boundary.
  The look-ahead counts, per candidate point, the pieces its insertion
  would leave missing that way (float circumspheres: a choice). An edge's
  split tries :data:`LOOK_AHEAD` points spread over its common interval, or
  where its encroachers' intervals do not meet, over the interval of the
  one of widest angle, and :data:`LOOK_WIDE` points spread over the whole
  edge (all kept :data:`LOOK_END` of the edge away from its ends: a split
  near an end leaves a long piece whose ball catches more points) besides
  the point above, and takes the one leaving the fewest missing (ties: the
  nearest to it); a face's split takes, among the candidates of step 3 and
  :data:`LOOK_WIDE` points spread over each of its edges, the one leaving
  the fewest, then Pébay's (the spread points last). The points of the
  intervals clear what the text's point clears (every encroacher of the
  edge, or the widest one from both halves' balls, §9.2); the spread points
  need not, and are taken only where the count says they leave fewer
  pieces missing (the next round splits what they leave). Counting the new
  pieces, leaving the hull out and the spread points took the bumpy sphere
  from 539 to 497 points, star seeds 1-40 from 95 to 82 and 1-3,000 from
  6,816 to 5,450 (521 seeds fewer, 44 more).
* **Concentric shells** (Ruppert's and Shewchuk's protection of small input
  angles, §9.1.5 in 3D). An edge's split within :data:`SHELL_END` of its
  length from an input vertex is moved out to the vertex's next shell (its
  shortest input edge times a power of two) where the shell still clears
  the encroachers, and the look-ahead takes it on ties: the near-end splits
  of the edges around a sharp vertex then meet on common spheres instead
  of cascading (star seeds 1-3,000: 6,887 -> 6,816 points, 24 seeds fewer,
  6 one or two more; the table's other inputs unchanged).
* **Search by rollouts** (:func:`_search`, surfaces of at most
  :data:`SEARCH_VERTICES` vertices). The look-ahead sees one insertion, not
  what the next rounds will need: on star seed 50 every split of a missing
  edge left 3 pieces missing, the one nearest the text's point was near a
  sharp vertex, and the vertex's other edges went missing in turn (6 points,
  TetGen ``-pD`` 5). Each round is made on a copy noting each choice's
  options (one per set of pieces left missing, by its signature; those
  within :data:`SEARCH_SLACK` of the best count, where the best leaves some
  missing); each is judged by its rollout (the round made with it, then the
  look-ahead alone until nothing is missing) and the round of the fewest
  points in all is kept. The look-ahead's own rollout is one of them, so the
  search never adds more points than the look-ahead alone; its rollouts stop
  after :data:`SEARCH_WORK` (rounds times points). Star seed 50: 6 -> 5,
  seeds 1-3,000: 5,450 -> 5,135 (124 seeds fewer, none more; TetGen ``-pD``
  5,485), the torus 39 -> 37 (at least 32: its 32 input edges missing at
  the start each need a point, as adding points makes no missing edge present).
* **Postponed splits.** The round's edge splits are taken longest first
  (lengths equal to 1e-6 tie, then the widest encroaching angle first), and
  a split is postponed to the next round when a split point already taken
  lies in its edge's closed diametral ball: that point may make it present.

Choices where the text leaves freedom
-------------------------------------
* **Split points yield to subsegments** (Ruppert's rule, as in Delaunay
  refinement): a point chosen for a missing face, or for a missing edge
  inside a facet, that lies in the closed diametral ball of a subsegment on
  its facet's boundary (a piece of an input edge, exact
  :func:`~meshcore.geometry.predicates3d.dot3d`; the longest such) is
  replaced by that subsegment's midpoint. Without it, two facets meeting at
  a sharp edge handed split points back and forth ever nearer their common
  edge until none could be added: 68 of 19,500 random star polyhedra (the
  tests' family, seeds 1-19,500 of ``benchmarks/robustness3d.py``) failed
  so, none of them after.
* **New points on the surface (§9.3.5)** are constructed from the *input*
  coordinates: a point on input edge ``E0 E1`` is ``E0 + s (E1 - E0)``
  (``s`` its parameter along the edge, kept), a point inside a facet is
  ``A + u (B - A) + v (C - A)`` (``ABC`` its first input triangle). They
  lie on the input edge / facet up to the rounding of those few operations, not exactly:
  a float point exactly on a general plane (``orient3d == 0``) does not
  exist in general. Their distance to the input plane is checked in the
  tests (a few ulps of the coordinates).
* **Which points.** The largest angle / solid angle is computed in floating
  point: any encroaching point gives a valid split, so it is a choice, not
  a sign decision. Ball memberships for the candidates of faces are float
  (with a relative slack of 1e-9; the points on the sphere count).
* **Case 0 and Case 1 faces.** Only missing subfaces are split. A face whose
  closed half-space (all points but its corners strictly on one side) is
  empty is a hull facet and stays a face whatever is added inside the
  hull: it is never split (its edges are never offered to Pébay's edge
  candidates either). A Case 1 face (empty ball) is a face at the start; it
  is split only if points added for its neighbours enter its ball (the
  coupling of §9.3, Figure 9.6): on the fixed test surfaces none is, on 40
  random star polyhedra 24 of 1,261 strictly Case 1 faces are.
* **Termination.** The text postulates convergence for faces (§9.3.4); the
  rounds stop with :class:`~meshcore.errors.AlgorithmError`
  (``recovery_failed``) after :data:`MAX_ROUNDS` rounds or
  :data:`MAX_ADDED_FACTOR` times the input's vertices plus
  :data:`MAX_ADDED_BASE` points.

Classification (:func:`classify_faces`, §9.3.2, Table 9.2) uses the text's
open sets: Case 0 (one open half-space of the face's plane holds no point,
exact ``orient3d``), Case 1 (the open ball ``B_f^min``, whose great circle is
the face's circumcircle, holds no point), Case 2 otherwise; faces whose
open great disc ``gc_f`` holds a point are counted as well. The ball test
is a float filter whose uncertain cases are decided exactly with rationals.

References
----------
Methods text §9.2 (segments in 3D, the ball B_AB, the point of maximal
angle), §9.3.1-§9.3.4 (Table 9.2, the classification, edges then faces,
Pébay's heuristics), §9.3.5 (new points on the surface Σ), §9.5 (the
empty tetrahedralization); P. P. Pébay, "Planar quadrangle quality
measures" and "A priori Delaunay-conformity" (1998).
"""

from __future__ import annotations

import copy
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from meshcore.delaunay.admissible_pieces import NEAR_END_FRACTION, NEAR_END_TRIGGER, NUDGE
from meshcore.delaunay.cavities3d import Cavities, split_pieces
from meshcore.delaunay.hashgrid import _find_all, _table, ball_pairs
from meshcore.delaunay.kernel3d import delaunay3d
from meshcore.delaunay.recovery3d import (
    KNOBS,
    TET_EDGES,
    TET_FACES,
    SurfaceRecovery,
    face_keys,
    member,
    packed_edge_keys,
)
from meshcore.delaunay.regions3d import regions
from meshcore.delaunay.ties3d import Reflipped, TieFlips, flip_ties
from meshcore.domain.surface import Surface, as_surface
from meshcore.errors import AlgorithmError
from meshcore.geometry.predicates3d import dot3d, orient3d
from meshcore.mesh import CellBlock, Mesh
from meshcore.mesh.topology import group_slots

__all__ = ["AdmissibleSurface", "classify_faces", "make_admissible_surface"]

Progress = Callable[[float, str], None]

#: At most this many rounds.
MAX_ROUNDS = 500
#: Added points allowed: this factor times the input's vertices ...
MAX_ADDED_FACTOR = 64
#: ... plus this many.
MAX_ADDED_BASE = 10_000
#: Relative slack of the float ball queries (candidates only; see the docstring).
BALL_SLACK = 1e-9
#: A face split point inside the subface must have barycentric coordinates
#: above this (else only the edge candidates are considered).
INSIDE_MARGIN = 1e-3
#: An edge split moved into the common interval of its encroachers stays this
#: fraction of the interval's length away from its ends.
COMMON_MARGIN = 0.05
#: Split points of a missing edge tried along its common interval (look-ahead).
LOOK_AHEAD = 9
#: The look-ahead's points stay this fraction of the edge's length away from its ends.
LOOK_END = 0.2
#: ... and are tried where that interval is longer than this fraction of the edge.
LOOK_ROOM = 0.05
#: Split points tried along the whole of a missing edge, and of each edge of a missing
#: face (look-ahead).
LOOK_WIDE = 7
#: A split within this fraction of an edge's length from an input vertex is tried
#: on the vertex's next concentric shell (:func:`_shell`).
SHELL_END = 0.1
#: Surfaces of at most this many vertices get the search (:func:`_search`) ...
SEARCH_VERTICES = 1000
#: ... its rollouts' rounds in all, each counted as the points it starts with, at most
#: this (a budget of work: 100 rounds of 64 points) ...
SEARCH_WORK = 6_400
#: ... and options leaving at most this many more pieces missing than the look-ahead's.
SEARCH_SLACK = 1


@dataclass(frozen=True, eq=False)
class AdmissibleSurface:
    """A Delaunay-admissible closed surface and its empty tetrahedralization.

    Attributes
    ----------
    points : (n, 3) float64
        The input points first (all of them, indices unchanged, unused ones
        included), then the added points.
    triangles : (m, 3) int64
        The output triangles, oriented outward like the surface; each is a
        face of :attr:`tetrahedra`, a Delaunay tetrahedralization of
        :attr:`points`' used points.
    source : (m,) int64
        The input triangle holding each output triangle's centroid: the
        output triangle lies in its facet (the input triangle, or the
        exactly coplanar input triangles joined to it across edges, whose
        triangulation the in-plane swaps of §9.3.2 may change).
    cases_before, cases_after : dict
        :func:`classify_faces` counts of the input and of the output.
    added_on_edges, added_on_faces : int
        Points added on input edges between facets and inside facets.
    rounds : int
        Rounds run (the last one finds nothing missing).
    swaps : int
        Coplanar swaps made in the last round's surface.
    mesh : Mesh
        The empty Delaunay tetrahedralization of the inside: the Delaunay
        tetrahedra of the surface points (input and added) inside the
        surface, one ``tetra`` block, positively oriented (meshio order),
        cell sets ``region_k``.
    tetrahedra : (k, 4) int64
        A Delaunay tetrahedralization of the output's surface points (no
        point strictly inside any circumsphere, exact) holding every output
        triangle, positively oriented (meshio order): the kernel's, after
        its cells of co-spherical points re-tetrahedralized (:attr:`tie_flips`).
    inside : (j,) int64
        The rows of :attr:`tetrahedra` inside the surface, increasing: the
        tetrahedra of :attr:`mesh`, in its order.
    tie_tetrahedra : (i,) int64
        The rows of :attr:`tetrahedra` made by those re-tetrahedralizations
        (each on its cell's empty sphere), increasing; empty without ties.
    tie_flips : int
        Cells of co-spherical points re-tetrahedralized in the last round, so
        that exactly co-circular quadrilaterals get their missing diagonal
        without a point (see :class:`~meshcore.delaunay.ties3d.TieFlips`); with
        none, :attr:`tetrahedra` is the kernel's (symbolic perturbation).
    timings : dict
        Seconds per phase.
    """

    points: np.ndarray
    triangles: np.ndarray
    source: np.ndarray
    cases_before: dict[str, int]
    cases_after: dict[str, int]
    added_on_edges: int
    added_on_faces: int
    rounds: int
    swaps: int
    mesh: Mesh
    tetrahedra: np.ndarray
    inside: np.ndarray
    tie_tetrahedra: np.ndarray
    tie_flips: int
    timings: dict = field(default_factory=dict)


# ---------------------------------------------------------------------------
# Classification (§9.3.2, Table 9.2)
# ---------------------------------------------------------------------------


def _circumcentres(P: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centres and radii of the faces' great circles (float)."""
    a = P[F[:, 0]]
    b = P[F[:, 1]] - a
    c = P[F[:, 2]] - a
    n = np.cross(b, c)
    nn = np.einsum("ij,ij->i", n, n)
    off = (
        np.einsum("ij,ij->i", b, b)[:, None] * np.cross(c, n)
        + np.einsum("ij,ij->i", c, c)[:, None] * np.cross(n, b)
    ) / (2.0 * nn)[:, None]
    return a + off, np.linalg.norm(off, axis=1)


def _as_integers(X: np.ndarray) -> np.ndarray:
    """The coordinates times one common power of two: exact Python integers (object array)."""
    ratios = [v.as_integer_ratio() for v in X.ravel().tolist()]
    den = max((d for _, d in ratios), default=1)
    return np.array([n * (den // d) for n, d in ratios], dtype=object).reshape(X.shape)


def _in_ball_exact(P: np.ndarray, F: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Exact signs of ``|X - O|^2 - R^2`` for the faces' balls, and whether X lies in
    the face's plane (integer arithmetic on the coordinates scaled to integers).

    With ``b, c, x`` the corners and the point relative to ``A``, ``n = b x c``
    and ``W = |b|^2 (c x n) + |c|^2 (n x b)`` the centre is ``A + W / (2 |n|^2)``,
    so the sign is that of ``2 |n|^2 |x|^2 - 2 x.W``.
    """
    rows = np.concatenate([F, x[:, None]], axis=1)
    used, inv = np.unique(rows, return_inverse=True)
    Z = _as_integers(P[used])[inv.reshape(rows.shape)]  # (k, 4, 3) objects
    A = Z[:, 0]
    b, c, v = Z[:, 1] - A, Z[:, 2] - A, Z[:, 3] - A

    def cross(u, w):
        return np.stack(
            [
                u[:, 1] * w[:, 2] - u[:, 2] * w[:, 1],
                u[:, 2] * w[:, 0] - u[:, 0] * w[:, 2],
                u[:, 0] * w[:, 1] - u[:, 1] * w[:, 0],
            ],
            axis=1,
        )

    def dot(u, w):
        return u[:, 0] * w[:, 0] + u[:, 1] * w[:, 1] + u[:, 2] * w[:, 2]

    n = cross(b, c)
    W = dot(b, b)[:, None] * cross(c, n) + dot(c, c)[:, None] * cross(n, b)
    s = 2 * dot(n, n) * dot(v, v) - 2 * dot(v, W)
    sign = np.array([(t > 0) - (t < 0) for t in s.tolist()], dtype=np.int64)
    planar = np.array([t == 0 for t in dot(v, n).tolist()], dtype=bool)
    return sign, planar


def classify_faces(points, faces) -> dict[str, int]:
    """Counts of the faces of each case of §9.3.2 (Table 9.2) against a point set.

    Parameters
    ----------
    points : (n, 3) float64
        Coordinates; the point set 𝓢 is the faces' vertices (rows no face
        uses are ignored).
    faces : (m, 3) int64
        The face set 𝓕, rows of point indices.

    Returns
    -------
    dict
        ``case0`` (one open half-space of the face's plane is empty, exact
        ``orient3d``), ``case1`` (not Case 0, and the open ball ``B_f^min``
        whose great circle is the face's circumcircle is empty), ``case2``
        (the others), and ``great_circle`` (faces whose open great disc
        ``gc_f`` holds a point: Cases 0.2 and 2.2 of the text, which the
        in-plane swaps remove).

    Notes
    -----
    Case 0 is looked for among the faces whose corners are all on the
    boundary of the convex hull (from our kernel's tetrahedralization of the
    faces' vertices), against the hull's vertices: a float filter with a
    generous error band, the points in the band decided by exact
    ``orient3d``; the ball
    tests take candidates from a hash grid (:func:`~meshcore.delaunay.hashgrid.ball_pairs`)
    with a relative slack of 1e-9,
    decide the clear ones in floating point and the others exactly with
    integers. Only the faces' vertices count as 𝓢.

    References
    ----------
    Methods text §9.3.1 (Table 9.2), §9.3.2.
    """
    case, _, disc = _classify(np.asarray(points, dtype=np.float64), faces)
    return _counts(case, disc)


def _counts(case: np.ndarray, disc: np.ndarray) -> dict[str, int]:
    return {
        "case0": int((case == 0).sum()),
        "case1": int((case == 1).sum()),
        "case2": int((case == 2).sum()),
        "great_circle": int(disc.sum()),
    }


def _classify(P: np.ndarray, faces) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per face: its case (0, 1, 2), whether it is in *strict* Case 0 (every
    other point strictly on one side: a hull facet in every triangulation),
    and whether its open great disc holds a point (see :func:`classify_faces`)."""
    F = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    m = len(F)
    # Case 0: the face's plane supports the hull, so its corners lie on the hull's
    # boundary, all of whose points are vertices of the hull facets of our kernel's
    # tetrahedralization; only the hull's vertices can then be on the other side.
    used = np.unique(F)
    hull = used[np.unique(delaunay3d(P[used]).hull_facets)]
    on_hull = np.zeros(len(P), dtype=bool)
    on_hull[hull] = True
    cand = np.flatnonzero(on_hull[F].all(axis=1))
    centre = P[hull].mean(axis=0)
    Q = P[hull] - centre
    case0 = np.zeros(m, dtype=bool)
    strict = np.zeros(m, dtype=bool)
    chunk = max(1, min(len(cand), 2_000_000 // len(hull)))
    for lo in range(0, len(cand), chunk):
        rows = cand[lo : lo + chunk]
        f = F[rows]
        a, b, c = (P[f[:, k]] - centre for k in range(3))
        n = np.cross(b - a, c - a)
        d = Q @ n.T - np.einsum("ij,ij->i", a, n)[None, :]  # (hull, k)
        reach = np.abs(Q).max(axis=1)[:, None] + np.abs(a).max(axis=1)[None, :]
        band = 1e-12 * np.linalg.norm(n, axis=1)[None, :] * (reach + 1e-300)
        pos = (d > band).any(axis=0)
        neg = (d < -band).any(axis=0)
        near = np.flatnonzero(~(pos & neg))  # faces near Case 0: decide the band exactly
        xi, ji = np.nonzero(np.abs(d[:, near]) <= band[:, near])
        xi, ji = hull[xi], near[ji]
        other = (xi != f[ji, 0]) & (xi != f[ji, 1]) & (xi != f[ji, 2])
        xi, ji = xi[other], ji[other]
        s_ = -orient3d(P[f[ji, 0]], P[f[ji, 1]], P[f[ji, 2]], P[xi])
        p_ = pos.copy()
        q_ = neg.copy()
        p_[ji[s_ > 0]] = True
        q_[ji[s_ < 0]] = True
        case0[rows] = ~(p_ & q_)
        zero = np.zeros(len(f), dtype=bool)
        zero[ji[s_ == 0]] = True
        strict[rows] = case0[rows] & ~zero
    centres, R = _circumcentres(P, F)
    xi, fi = ball_pairs(P[used], centres, R * (1 + BALL_SLACK))
    xi = used[xi]
    other = (xi != F[fi, 0]) & (xi != F[fi, 1]) & (xi != F[fi, 2])
    fi, xi = fi[other], xi[other]
    d2 = np.einsum("ij,ij->i", P[xi] - centres[fi], P[xi] - centres[fi])
    r2 = R[fi] ** 2
    sign = np.where(
        d2 < r2 * (1 - 4 * BALL_SLACK), -1, np.where(d2 > r2 * (1 + 4 * BALL_SLACK), 1, 0)
    )
    planar = np.zeros(len(fi), dtype=bool)
    near = np.flatnonzero(sign == 0)  # near the sphere: exact, integers
    if near.size:
        sign[near], planar[near] = _in_ball_exact(P, F[fi[near]], xi[near])
    inside = sign < 0
    fi, xi, planar = fi[inside], xi[inside], planar[inside]
    clear = np.flatnonzero(~planar)
    planar[clear] = (
        orient3d(P[F[fi[clear], 0]], P[F[fi[clear], 1]], P[F[fi[clear], 2]], P[xi[clear]]) == 0
    )
    in_ball = np.zeros(m, dtype=bool)
    in_ball[fi] = True
    in_disc = np.zeros(m, dtype=bool)
    in_disc[fi[planar]] = True
    case = np.where(case0, 0, np.where(in_ball, 2, 1))
    return case, strict, in_disc


# ---------------------------------------------------------------------------
# The state: the tets builder plus the points' positions on the input
# ---------------------------------------------------------------------------


class _State:
    """The builder (kernel, subsegments, subfaces) and each added point's
    parameter on its input edge (points on edges) or barycentric
    coordinates in its input triangle (points inside)."""

    def __init__(self, surface: Surface) -> None:
        self.b = SurfaceRecovery(surface, KNOBS)
        self.P0 = self.b.P.copy()  # the surface's vertices (input coordinates)
        #: Per surface vertex, its shortest input edge: the unit of its shells.
        E = self.b.edges
        length = np.linalg.norm(self.P0[E[:, 1]] - self.P0[E[:, 0]], axis=1)
        self.unit = np.full(self.b.n_surface, np.inf)
        np.minimum.at(self.unit, E.reshape(-1), np.repeat(length, 2))
        #: Per facet, its first input triangle: the plane new points are put in.
        self.plane = self.b.facets[[int(t[0]) for t in self.b.group_tris]]
        self.s = np.full(self.b.n, np.nan)  # parameter along the input edge
        self.added_on_edges = 0
        self.added_on_faces = 0
        #: Edge keys of the strict Case 0 input faces (never split).
        self.protected = np.zeros(0, dtype=np.int64)
        #: The search's choices for a round (:func:`_search`): per missing edge
        #: ("edge", key) its split parameter, per missing face ("face", key) its
        #: candidate's row; and, while the search looks, the options of each.
        self.force: dict[tuple[str, int], float | int] = {}
        self.options: dict[tuple[str, int], list] | None = None
        #: While the search tries a round's options: the look-ahead's counts of that
        #: round, shared by its trials (made from the same state: the same counts).
        self.looked: dict[str, tuple] | None = None
        # The facets' subface edges are kept consistent by retriangulate.

    # -- positions ----------------------------------------------------------

    def edge_param(self, v: np.ndarray, e: np.ndarray) -> np.ndarray:
        """Parameter of vertices ``v`` along input edges ``e`` (0 at ``edges[e, 0]``)."""
        E = self.b.edges[e]
        return np.where(v == E[:, 0], 0.0, np.where(v == E[:, 1], 1.0, self.s[v]))

    def on_edge(self, e: np.ndarray, s: np.ndarray) -> np.ndarray:
        E = self.b.edges[e]
        a, c = self.P0[E[:, 0]], self.P0[E[:, 1]]
        return a + s[:, None] * (c - a)

    def in_facet(self, f: np.ndarray, X: np.ndarray) -> np.ndarray:
        """``X`` moved onto facet ``f``'s plane: ``A + u (B - A) + v (C - A)`` (its
        first input triangle ``ABC``) with ``(u, v)`` from the orthogonal projection."""
        T = self.plane[f]
        a = self.P0[T[:, 0]]
        u = self.P0[T[:, 1]] - a
        w = self.P0[T[:, 2]] - a
        x = X - a
        uu = np.einsum("ij,ij->i", u, u)
        ww = np.einsum("ij,ij->i", w, w)
        uw = np.einsum("ij,ij->i", u, w)
        xu = np.einsum("ij,ij->i", x, u)
        xw = np.einsum("ij,ij->i", x, w)
        det = uu * ww - uw * uw
        s = (xu * ww - xw * uw) / det
        t = (xw * uu - xu * uw) / det
        return a + s[:, None] * u + t[:, None] * w

    def choose(self, key: tuple[str, int], count, sig, values: list) -> None:
        """Note, when the search looks, the options of one choice: ``values`` in the
        look-ahead's order of preference, with their counts of pieces left missing
        and signatures (:meth:`~meshcore.delaunay.cavities3d.Cavities.missing`); one
        value per signature."""
        if self.options is None:
            return
        seen: set[int] = set()
        mine = []
        for c, g, v in zip(count.tolist(), sig.tolist(), values, strict=True):
            if g not in seen:
                seen.add(g)
                mine.append((c, v))
        self.options[key] = mine

    def look(self, kind: str, count: Callable[[], tuple]) -> tuple:
        """``count()``, the look-ahead's (:meth:`Cavities.missing`), or its result of
        another trial of the same round (:func:`_search`)."""
        if self.looked is None:
            return count()
        if kind not in self.looked:
            self.looked[kind] = count()
        return self.looked[kind]

    # -- insertion ----------------------------------------------------------

    def add(self, X, edge, s, facet) -> int:
        """Insert points (on input ``edge`` at parameter ``s``, or inside ``facet``),
        update the subsegments and re-triangulate the facets touched."""
        b = self.b
        if len(X) == 0:
            return 0
        ids = b.add(X, edge, facet)
        ok = ids >= 0
        ids, edge, s, facet = ids[ok], edge[ok], s[ok], facet[ok]
        self.s = np.concatenate([self.s, np.full(len(ok.nonzero()[0]), np.nan)])
        on = edge >= 0
        self.s[ids[on]] = s[on]
        self.added_on_edges += int(on.sum())
        self.added_on_faces += int((~on).sum())
        touched = [facet[~on]]
        if on.any():
            # Split the subsegments the new edge points fall in (by parameter).
            for v, e, sv in zip(ids[on].tolist(), edge[on].tolist(), s[on].tolist(), strict=True):
                rows = np.flatnonzero(b.seg_edge == e)
                seg = b.seg[rows]
                lo = self.edge_param(seg[:, 0], np.full(len(rows), e))
                hi = self.edge_param(seg[:, 1], np.full(len(rows), e))
                inside = np.flatnonzero((np.minimum(lo, hi) < sv) & (sv < np.maximum(lo, hi)))
                r = int(rows[inside[0]])
                a, c = b.seg[r]
                b.seg[r] = [a, v]
                b.seg = np.concatenate([b.seg, [[v, c]]])
                b.seg_edge = np.concatenate([b.seg_edge, [e]])
            touched.append(b.edge_groups[edge[on]].reshape(-1))
        b.retriangulate(np.unique(np.concatenate(touched)))
        return int(ok.sum())


# ---------------------------------------------------------------------------
# One round
# ---------------------------------------------------------------------------


class _Present:
    """Which edges and faces belong to tetrahedra ``T``: hash tables of their keys
    (:mod:`~meshcore.delaunay.hashgrid`), built once a round."""

    def __init__(self, T: np.ndarray) -> None:
        self.edge_table = _table(packed_edge_keys(T[:, TET_EDGES].reshape(-1, 2)))
        self.face_table = _table(face_keys(T[:, TET_FACES].reshape(-1, 3)))

    def edges(self, E: np.ndarray) -> np.ndarray:
        return _find_all(*self.edge_table, packed_edge_keys(E)) >= 0

    def faces(self, F: np.ndarray) -> np.ndarray:
        return _find_all(*self.face_table, face_keys(F)) >= 0


def _subface_edges(sub: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unique edges of the subfaces ([lo, hi] rows) and, per edge, one subface holding it."""
    e = np.concatenate([sub[:, [0, 1]], sub[:, [1, 2]], sub[:, [2, 0]]])
    e.sort(axis=1)
    owner = np.tile(np.arange(len(sub)), 3)
    _, first = np.unique(packed_edge_keys(e), return_index=True)
    return e[first], owner[first]


def _coplanar_swaps(st: _State, present: _Present) -> int:
    """Swap the missing subfaces whose quad's other diagonal is present (Pébay).

    A loop over the missing subfaces (few): each one's neighbour across each
    edge in the same facet; if both triangles of the other diagonal are faces
    of the tetrahedralization and positively oriented in the facet's frame,
    the pair is replaced.
    """
    b = st.b
    swaps = 0
    by_facet, bounds = group_slots(b.sub_facet, len(b.group_tris))  # each facet's rows
    for _ in range(4):
        missing = np.flatnonzero(~present.faces(b.sub))
        if missing.size == 0:
            break
        done = False
        origin, e1, e2 = b.frame
        pieces = np.bincount(b.sub_facet, minlength=len(b.group_tris))
        for r in missing[pieces[b.sub_facet[missing]] > 1].tolist():  # missing subfaces
            f = int(b.sub_facet[r])
            same = by_facet[bounds[f] : bounds[f + 1]]
            tri = b.sub[r]
            for k in range(3):
                p, q, a = int(tri[k]), int(tri[(k + 1) % 3]), int(tri[(k + 2) % 3])
                # neighbour holding edge q -> p
                nb = same[((b.sub[same] == q) & (np.roll(b.sub[same], -1, axis=1) == p)).any(1)]
                if nb.size == 0:
                    continue
                g = int(nb[0])
                c = int(np.setdiff1d(b.sub[g], [p, q])[0])
                new = np.array([[a, p, c], [a, c, q]], dtype=np.int64)
                if not present.faces(new).all():
                    continue
                uv = np.stack(
                    [(b.P[new] - origin[f]) @ e1[f], (b.P[new] - origin[f]) @ e2[f]], axis=-1
                )
                d = uv[:, 1] - uv[:, 0]
                w = uv[:, 2] - uv[:, 0]
                if ((d[:, 0] * w[:, 1] - d[:, 1] * w[:, 0]) <= 0).any():
                    continue
                b.sub[r] = new[0]
                b.sub[g] = new[1]
                swaps += 1
                done = True
                break
        if not done:
            break
    return swaps


def _angles_min(uv: np.ndarray) -> np.ndarray:
    """Least angle (radians) of triangles given as (k, 3, 2) coordinates."""
    out = np.full(len(uv), np.pi)
    for i in range(3):
        u = uv[:, (i + 1) % 3] - uv[:, i]
        v = uv[:, (i + 2) % 3] - uv[:, i]
        cross = u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]
        ang = np.arctan2(np.abs(cross), np.einsum("ij,ij->i", u, v))
        out = np.minimum(out, np.where(cross > 0, ang, 0.0))
    return out


def _project_on_segment(P, A, B):
    """Projection parameter of ``P`` on ``AB`` with the 2D module's near-end rules."""
    d = B - A
    L2 = np.einsum("ij,ij->i", d, d)
    t = np.einsum("ij,ij->i", P - A, d) / L2
    t = np.clip(t, 0.0, 1.0)
    near_a = t <= 0.5
    te = np.where(near_a, t, 1.0 - t)  # fraction from the nearer end E
    L = np.sqrt(L2)
    ep = np.linalg.norm(P - np.where(near_a[:, None], A, B), axis=1)
    close = te * L < NEAR_END_TRIGGER * ep
    te = np.where(close, np.minimum(NEAR_END_FRACTION * ep / L, 0.5), te)
    te = np.minimum(te * (1.0 + NUDGE), 0.5)
    return np.where(near_a, te, 1.0 - te)


def _split_edges(st: _State, E: np.ndarray, holder: np.ndarray, cav: Cavities) -> int:
    """Split the missing subface edges ``E`` at the projection of their point
    of largest angle in the closed diametral ball (§9.2), or where the
    look-ahead on the round's cavities ``cav`` finds better."""
    b = st.b
    A, B = b.P[E[:, 0]], b.P[E[:, 1]]
    mid = 0.5 * (A + B)
    L = np.linalg.norm(B - A, axis=1)
    half = 0.5 * L
    pi, ei = ball_pairs(b.P, mid, half * (1 + BALL_SLACK))
    keep = (pi != E[ei, 0]) & (pi != E[ei, 1])
    ei, pi = ei[keep], pi[keep]
    inside = dot3d(A[ei], B[ei], b.P[pi]) <= 0
    ei, pi = ei[inside], pi[inside]
    u = A[ei] - b.P[pi]
    v = B[ei] - b.P[pi]
    ang = np.arctan2(np.linalg.norm(np.cross(u, v), axis=1), np.einsum("ij,ij->i", u, v))
    best = np.full(len(E), -1, dtype=np.int64)
    widest = np.zeros(len(E))
    order = np.lexsort((pi, -ang, ei))  # per edge: largest angle, then smallest index
    w = order[np.unique(ei[order], return_index=True)[1]]  # per edge, its widest encroacher
    best[ei[w]] = pi[w]
    widest[ei[w]] = ang[w]
    X = np.where(best[:, None] >= 0, b.P[np.maximum(best, 0)], mid)
    t = np.where(best >= 0, _project_on_segment(X, A, B), 0.5)
    # Every encroacher Q leaves both halves' balls for t in [t1, t2] (Thales:
    # (A - Q).(M - Q) >= 0 and (M - Q).(B - Q) >= 0); where the intervals of all
    # of an edge's encroachers meet, the split is moved into their common part
    # (float: a choice, the next round checks), so one split clears them all.
    d = B[ei] - A[ei]
    a = A[ei] - b.P[pi]
    bq = B[ei] - b.P[pi]
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = -np.einsum("ij,ij->i", a, bq) / np.einsum("ij,ij->i", d, bq)
        t2 = np.einsum("ij,ij->i", a, a) / -np.einsum("ij,ij->i", a, d)
    lo = np.zeros(len(E))
    hi = np.ones(len(E))
    np.maximum.at(lo, ei, np.nan_to_num(t1, nan=1.0))
    np.minimum.at(hi, ei, np.nan_to_num(t2, nan=0.0))
    room = hi - lo
    common = (best >= 0) & (room > 0)
    margin = COMMON_MARGIN * room
    t = np.where(common, np.clip(t, lo + margin, hi - margin), t)
    # Without a common interval, the look-ahead tries the widest encroacher's own.
    alone = ~common[ei[w]]
    lo[ei[w][alone]] = np.nan_to_num(t1[w][alone], nan=1.0)
    hi[ei[w][alone]] = np.nan_to_num(t2[w][alone], nan=0.0)
    margin = COMMON_MARGIN * (hi - lo)
    lo, hi = lo + margin, hi - margin
    shell = _shell(st, E, L, t, lo, hi)
    lo, hi = np.maximum(lo, LOOK_END), np.minimum(hi, 1.0 - LOOK_END)
    t = _look_ahead(st, cav, E, A, B, shell, t, lo, hi, best >= 0)
    # Longest first (lengths equal to 1e-6 relative tie), then widest angle.
    length = np.round(np.log2(half) * 2.0**20)
    keep = _independent(A + t[:, None] * (B - A), mid, half, (-widest, -length))
    X = (A + t[:, None] * (B - A))[keep]
    E, holder, t = E[keep], holder[keep], t[keep]
    for r in np.flatnonzero(
        ~member(packed_edge_keys(E), np.sort(packed_edge_keys(b.seg)))
    ).tolist():
        # A split point inside a facet that would encroach one of its subsegments
        # yields to it (as a face's point does in _split_faces).
        seg = _encroached_subsegment(st, int(b.sub_facet[holder[r]]), X[r])
        if seg is not None:
            E[r], t[r] = seg, 0.5
    _, first = np.unique(packed_edge_keys(E), return_index=True)
    return _insert_on_edges(st, E[first], b.sub_facet[holder[first]], t[first])


def _shell(st: _State, E: np.ndarray, L: np.ndarray, t, lo, hi) -> np.ndarray:
    """``t`` moved out to the next concentric shell of the input vertex at the nearer
    end of edge ``E`` of length ``L`` (a distance from the vertex of its shortest input
    edge times a power of two) where ``t`` lies within :data:`SHELL_END` of that end and
    the shell lies in ``[lo, hi]`` (else ``t``): near-end splits of the edges at a sharp vertex
    then meet on common spheres and protect each other, as Ruppert's and Shewchuk's
    concentric shells do for small input angles (§9.1.5's protection of sharp
    vertices, in 3D)."""
    b = st.b
    near_a = t <= 0.5
    end = np.where(near_a, E[:, 0], E[:, 1])
    vertex = (end < b.n_surface) & (np.minimum(t, 1.0 - t) < SHELL_END)
    unit = st.unit[np.where(vertex, end, 0)]
    with np.errstate(divide="ignore", invalid="ignore"):
        d = unit * 2.0 ** np.ceil(np.log2(np.minimum(t, 1.0 - t) * L / unit)) / L
    shell = np.where(near_a, d, 1.0 - d)
    ok = vertex & (d > 0) & (d <= 0.5) & (shell >= lo) & (shell <= hi)
    return np.where(ok, shell, t)


def _look_ahead(st: _State, cav: Cavities, E, A, B, t, t0, lo, hi, known) -> np.ndarray:
    """Per edge ``E`` = ``AB`` where ``known`` (an encroacher is known): among ``t``
    (its shell point, :func:`_shell`), ``t0`` (the point before it), :data:`LOOK_AHEAD`
    points spread over ``[lo, hi]`` where it is longer than :data:`LOOK_ROOM`, and
    :data:`LOOK_WIDE` points spread over the edge (:data:`LOOK_END` away from its
    ends), the split leaving the fewest pieces missing (:meth:`Cavities.missing`;
    ties: the nearest to ``t``), unless the search chose another (:func:`_search`)."""
    rows = np.flatnonzero(known)
    if rows.size == 0:
        return t
    cand = np.repeat(t[rows, None], LOOK_AHEAD + 2, axis=1)
    cand[:, 1] = t0[rows]
    spread = lo[rows, None] + np.linspace(0.0, 1.0, LOOK_AHEAD) * (hi - lo)[rows, None]
    cand[:, 2:] = np.where((hi - lo > LOOK_ROOM)[rows, None], spread, t[rows, None])
    wide = np.linspace(LOOK_END, 1.0 - LOOK_END, LOOK_WIDE)
    cand = np.concatenate([cand, np.broadcast_to(wide, (len(rows), LOOK_WIDE))], axis=1)
    # Each distinct (edge, parameter) judged once.
    pairs = np.column_stack([np.repeat(rows, cand.shape[1]), cand.reshape(-1)])
    pairs, again = np.unique(pairs, axis=0, return_inverse=True)
    r, s = pairs[:, 0].astype(np.int64), pairs[:, 1]
    count, sig = st.look(
        "edges",
        lambda: cav.missing(A[r] + s[:, None] * (B - A)[r], *split_pieces(st.b.sub, E[r])),
    )
    count, sig = count[again].reshape(cand.shape), sig[again].reshape(cand.shape)
    dist = np.abs(cand - t[rows, None])
    pick = np.argmin(count + dist / 2.0, axis=1)  # dist < 1: the count first
    out = t.copy()
    out[rows] = cand[np.arange(len(rows)), pick]
    if st.options is None and not st.force:
        return out  # not searching (:func:`_search`)
    for i, k in enumerate(packed_edge_keys(E[rows]).tolist()):  # a loop over this round's edges
        order = np.lexsort((dist[i], count[i]))
        st.choose(("edge", k), count[i, order], sig[i, order], cand[i, order].tolist())
        out[rows[i]] = st.force.get(("edge", k), out[rows[i]])
    return out


def _independent(X: np.ndarray, centres: np.ndarray, radii: np.ndarray, key) -> np.ndarray:
    """Rows of the split points to insert this round, greedily in increasing ``key``
    (a tuple of keys, the last one primary, as :func:`numpy.lexsort`):
    a split is postponed when a split point already taken lies in its piece's
    closed ball (that point may make the piece present; the next round sees).
    Fewer points than splitting every missing piece at once, for one more round."""
    order = np.lexsort(key)
    tree = cKDTree(X)
    taken = np.zeros(len(X), dtype=bool)
    hits = tree.query_ball_point(centres[order], radii[order] * (1 + BALL_SLACK))
    for i, h in zip(order.tolist(), hits, strict=True):  # a loop over this round's splits
        if not taken[h].any():
            taken[i] = True
    return np.flatnonzero(taken)


def _insert_on_edges(st: _State, E, facet, t) -> int:
    """Insert the points at parameter ``t`` of subface edges ``E``: on the input
    edge when ``E`` is a subsegment, else inside input triangle ``facet``."""
    b = st.b
    seg_rows = _match_rows(packed_edge_keys(E), packed_edge_keys(b.seg))
    is_seg = seg_rows >= 0
    e = np.where(is_seg, b.seg_edge[np.maximum(seg_rows, 0)], -1)
    s0 = st.edge_param(E[:, 0], np.maximum(e, 0))
    s1 = st.edge_param(E[:, 1], np.maximum(e, 0))
    s = s0 + t * (s1 - s0)
    f = np.where(is_seg, -1, facet)
    X = b.P[E[:, 0]] + t[:, None] * (b.P[E[:, 1]] - b.P[E[:, 0]])
    X[is_seg] = st.on_edge(e[is_seg], s[is_seg])
    X[~is_seg] = st.in_facet(f[~is_seg], X[~is_seg])
    crowded = b.crowded(X, np.linalg.norm(b.P[E[:, 1]] - b.P[E[:, 0]], axis=1))
    keep = ~crowded
    return st.add(X[keep], e[keep], s[keep], f[keep])


def _match_rows(keys: np.ndarray, table: np.ndarray) -> np.ndarray:
    """Row of ``table`` holding each key, -1 where none."""
    order = np.argsort(table, kind="stable")
    st = table[order]
    if st.size == 0:
        return np.full(len(keys), -1, dtype=np.int64)
    pos = np.minimum(np.searchsorted(st, keys), len(st) - 1)
    return np.where(st[pos] == keys, order[pos], -1)


def _split_faces(st: _State, rows: np.ndarray, tree: cKDTree, cav: Cavities) -> int:
    """Split the missing subfaces ``rows`` (§9.3.4 face enforcement, Pébay)."""
    b = st.b
    F = b.sub[rows]
    f = b.sub_facet[rows]
    centres, R = _circumcentres(b.P, F)
    hits = tree.query_ball_point(centres, R * (1 + BALL_SLACK))
    origin, e1, e2 = b.frame
    # Per missing subface, its candidate splits: (least angle, 3D point, kind, data).
    options: list[list[tuple[float, np.ndarray, str, object]]] = []
    for j, h in enumerate(hits):  # a loop over the missing subfaces (few per round)
        cand = np.array([x for x in h if x not in F[j]], dtype=np.int64)
        fj = int(f[j])
        tri = F[j]
        if cand.size:
            a, bb, c = (b.P[tri[k]] - b.P[cand] for k in range(3))
            num = np.abs(np.einsum("ij,ij->i", a, np.cross(bb, c)))
            la, lb, lc = (np.linalg.norm(x, axis=1) for x in (a, bb, c))
            den = (
                la * lb * lc
                + np.einsum("ij,ij->i", a, bb) * lc
                + np.einsum("ij,ij->i", a, c) * lb
                + np.einsum("ij,ij->i", bb, c) * la
            )
            solid = 2.0 * np.arctan2(num, den)
            p = int(cand[np.lexsort((cand, -solid))[0]])
            X = b.P[p]
        else:  # ties broken against the face: its centre is a fine wall
            X = centres[j]
        frame = np.stack([e1[fj], e2[fj]], axis=1)
        uv = (b.P[tri] - origin[fj]) @ frame
        m = (X - origin[fj]) @ frame
        # Candidates: the projection M inside f, and the projections on the edges.
        mine: list[tuple[float, np.ndarray, str, object]] = []
        T = np.array([uv[[1, 2]], uv[[2, 0]], uv[[0, 1]]])  # sub-triangles with M
        lam = _angles_min(np.concatenate([T, np.broadcast_to(m, (3, 1, 2))], axis=1))
        bary = _barycentric(uv, m)
        if bary.min() > INSIDE_MARGIN:
            mine.append(_face_point(st, fj, tri, float(lam.min()), origin[fj] + frame @ m))
        # Edges: every edge but those of a whole strict Case 0 input face.
        own_keys = packed_edge_keys(np.stack([tri, np.roll(tri, -1)], axis=1))
        for k in np.flatnonzero(~np.isin(own_keys, st.protected)).tolist():
            i, jj = tri[k], tri[(k + 1) % 3]
            t0 = float(_project_on_segment(X[None], b.P[i][None], b.P[jj][None])[0])
            ts = np.array([t0, *np.linspace(LOOK_END, 1.0 - LOOK_END, LOOK_WIDE).tolist()])
            x = uv[k] + ts[:, None] * (uv[(k + 1) % 3] - uv[k])
            pa, pb, pc = (np.broadcast_to(uv[r % 3], x.shape) for r in (k, k + 1, k + 2))
            two = np.stack([np.stack([pa, x, pc], 1), np.stack([x, pb, pc], 1)], 1)
            x3 = b.P[i] + ts[:, None] * (b.P[jj] - b.P[i])
            # The spread points after every text's point on ties (angles < pi).
            least = _angles_min(two.reshape(-1, 3, 2)).reshape(-1, 2).min(axis=1)
            angle = least - np.where(ts != t0, np.pi, 0.0)
            mine.extend(
                (a, y, "edge", (i, jj, t))
                for a, y, t in zip(angle.tolist(), x3, ts.tolist(), strict=True)
            )
        if not mine:  # every edge protected and M outside f: its centroid
            mine.append(_face_point(st, fj, tri, 0.0, origin[fj] + frame @ uv.mean(axis=0)))
        options.append(mine)
    # Look-ahead: the split leaving the fewest subfaces and subface edges missing in the
    # tetrahedralization, then the largest least angle (Pébay's heuristic).
    flat = [o for mine in options for o in mine]
    V = np.full((len(flat), 4), -1, dtype=np.int64)
    base = np.full((len(flat), 4, 2), -1, dtype=np.int64)
    split = [k for k, o in enumerate(flat) if o[2] == "edge"]
    if split:
        E = np.array([o[3][:2] for o in (flat[k] for k in split)], dtype=np.int64)
        V[split], base[split] = split_pieces(b.sub, E)
    for k, o in enumerate(flat):
        if o[2] == "face":
            V[k, :3] = o[3]
            base[k, :3] = np.stack([o[3], np.roll(o[3], -1)], axis=1)
    removed, sig = st.look("faces", lambda: cav.missing(np.array([o[1] for o in flat]), V, base))
    pts_edge: list[tuple[np.ndarray, int, float]] = []
    pts_face: list[tuple[int, np.ndarray, float]] = []
    seen_edges: set[tuple[int, int]] = set()
    at = 0
    face_key = face_keys(F).tolist()
    for j, mine in enumerate(options):  # a loop over the missing subfaces
        order = sorted(range(len(mine)), key=lambda k: (removed[at + k], -mine[k][0]))
        key = ("face", face_key[j])
        rows = at + np.array(order)
        st.choose(key, removed[rows], sig[rows], order)
        at += len(mine)
        _, M, kind, data = mine[st.force.get(key, order[0])]
        fj = int(f[j])
        if kind == "face":
            pts_face.append((fj, M, float(R[j])))
            continue
        i, jj, t = data
        key = (min(i, jj), max(i, jj))
        if key in seen_edges:
            continue
        seen_edges.add(key)
        pts_edge.append((np.array([i, jj]), fj, t))
    added = 0
    if pts_face:
        ff = np.array([x[0] for x in pts_face], dtype=np.int64)
        X = st.in_facet(ff, np.array([x[1] for x in pts_face]))
        keep = ~b.crowded(X, np.array([x[2] for x in pts_face]))
        X, ff = X[keep], ff[keep]
        added += st.add(X, np.full(len(X), -1), np.full(len(X), np.nan), ff)
    if pts_edge:
        E = np.array([x[0] for x in pts_edge], dtype=np.int64)
        facet = np.array([x[1] for x in pts_edge], dtype=np.int64)
        t = np.array([x[2] for x in pts_edge])
        added += _insert_on_edges(st, E, facet, t)
    return added


def _face_point(st: _State, facet: int, tri: np.ndarray, angle: float, M: np.ndarray) -> tuple:
    """The candidate split at ``M`` inside subface ``tri`` of ``facet``: (least angle,
    3D point, kind, data: ``tri`` or a subsegment's ends and 0.5).
    A point that would encroach a subsegment of its facet yields to it: that
    subsegment's midpoint instead (Ruppert's rule; else two facets meeting at a sharp
    edge hand split points back and forth ever nearer their edge), and the
    look-ahead judges that midpoint."""
    seg = _encroached_subsegment(st, facet, M)
    if seg is None:
        return angle, M, "face", tri
    i, j = int(seg[0]), int(seg[1])
    return angle, 0.5 * (st.b.P[i] + st.b.P[j]), "edge", (i, j, 0.5)


def _encroached_subsegment(st: _State, facet: int, X: np.ndarray) -> np.ndarray | None:
    """The longest subsegment on the boundary of facet ``facet``, not an
    edge of a strict Case 0 face, whose closed diametral ball holds ``X`` (exact
    :func:`~meshcore.geometry.predicates3d.dot3d`), as its two vertices; None if
    there is none."""
    b = st.b
    rows = np.flatnonzero((b.edge_groups[b.seg_edge] == facet).any(axis=1))
    S = b.seg[rows]
    S = S[~np.isin(packed_edge_keys(S), st.protected)]
    A, B = b.P[S[:, 0]], b.P[S[:, 1]]
    hit = np.flatnonzero(dot3d(A, B, np.broadcast_to(X, A.shape)) <= 0)
    if hit.size == 0:
        return None
    return S[hit[np.argmax(np.linalg.norm(B[hit] - A[hit], axis=1))]]


def _barycentric(uv: np.ndarray, m: np.ndarray) -> np.ndarray:
    a, b_, c = uv
    d = (b_[0] - a[0]) * (c[1] - a[1]) - (b_[1] - a[1]) * (c[0] - a[0])
    l1 = ((m[0] - a[0]) * (c[1] - a[1]) - (m[1] - a[1]) * (c[0] - a[0])) / d
    l2 = ((b_[0] - a[0]) * (m[1] - a[1]) - (b_[1] - a[1]) * (m[0] - a[0])) / d
    return np.array([1.0 - l1 - l2, l1, l2])


# ---------------------------------------------------------------------------
# Entry point
# ---------------------------------------------------------------------------


def _step(st: _State) -> tuple[int, TieFlips, int]:
    """One round: the coplanar swaps, the tie flips, then the missing subface edges
    split, or if none the missing subfaces: (the points added, 0 if nothing is
    missing; the tie flips; the swaps)."""
    b = st.b
    slots, T = b.tets()
    present = _Present(T)
    swaps = _coplanar_swaps(st, present)
    edges, holder = _subface_edges(b.sub)
    missing_e = np.flatnonzero(~present.edges(edges))
    ties = flip_ties(b.P, T, b.sub, edges[missing_e])
    if ties.cones:
        present = _Present(ties.tets())
        missing_e = np.flatnonzero(~present.edges(edges))
    missing_f = np.flatnonzero(~present.faces(b.sub))
    if missing_e.size == 0 and missing_f.size == 0:
        return 0, ties, swaps
    cav = Cavities(b, slots, T, edges)  # the look-ahead's
    if missing_e.size:
        added = _split_edges(st, edges[missing_e], holder[missing_e], cav)
    else:
        added = _split_faces(st, missing_f, cKDTree(b.P), cav)
    if added == 0:
        raise AlgorithmError(
            f"the surface could not be made Delaunay-admissible: {missing_e.size} edges "
            f"and {missing_f.size} triangles are missing and no point could be added "
            "(points at float64 resolution)",
            code="recovery_failed",
        )
    return added, ties, swaps


def _search(st: _State, budget: int, cap: int) -> tuple[_State, tuple, int]:
    """One round (as :func:`_step`) with its splits chosen by rollouts: the state
    after it (``st`` is left as it was), the round's result, the budget left.

    The round is made on a copy of the state, noting each choice's options
    (:meth:`_State.choose`): one per signature, those leaving at most
    :data:`SEARCH_SLACK` more pieces missing than the look-ahead's choice, only
    for the choices where that one leaves some missing. Each option, one choice
    after the other (the better ones found kept), is judged by its *rollout*:
    the round made with it on another copy, then the rounds of the look-ahead
    alone until nothing is missing; the round whose rollout adds the fewest
    points in all is kept (ties: the look-ahead's). The look-ahead's own
    rollout is among those judged, and the round kept is the one judged, so
    the search never adds more points than the look-ahead alone would from the
    same state (and so on every input, round after round). Each rollout round
    costs its points from ``budget``; with none left, the options left unjudged
    keep the look-ahead's choice.
    """
    looked: dict[str, tuple] = {}  # the round's look-ahead, the same in each trial
    kept = copy.deepcopy(st)
    kept.options, kept.looked = {}, looked
    result = _step(kept)
    kept.looked = None
    tries = [
        (key, value)
        for key, mine in kept.options.items()
        if mine[0][0] > 0
        for count, value in mine[1:]
        if count <= mine[0][0] + SEARCH_SLACK
    ]
    kept.options = None
    if not tries or result[0] == 0:
        return kept, result, budget
    best, budget = _rollout(copy.deepcopy(kept), budget, cap)
    chosen: dict[tuple[str, int], float | int] = {}
    for key, value in tries:  # a loop over the round's options (few)
        if budget <= 0:
            break
        trial = copy.deepcopy(st)
        trial.force, trial.looked = {**chosen, key: value}, looked
        try:
            got = _step(trial)
        except AlgorithmError:
            continue
        force, trial.force, trial.looked = trial.force, {}, None
        added, budget = _rollout(copy.deepcopy(trial), budget, cap)
        if added < best:
            best, chosen, kept, result = added, force, trial, got
    return kept, result, budget


def _rollout(st: _State, budget: int, cap: int) -> tuple[float, int]:
    """The points added in all once the rounds of the look-ahead alone (on ``st``,
    changed) leave nothing missing (inf if they fail, pass ``cap`` or run out of
    ``budget``, which each round takes its points from), and the budget left."""
    while budget > 0 and st.b.n - st.b.n_surface <= cap:
        budget -= st.b.n
        try:
            if _step(st)[0] == 0:
                return st.b.n - st.b.n_surface, budget
        except AlgorithmError:
            break
    return np.inf, budget


def make_admissible_surface(surface, progress: Progress | None = None) -> AdmissibleSurface:
    """A Delaunay-admissible refinement of a closed surface (§9.2, §9.3, §9.3.5).

    Parameters
    ----------
    surface : Surface or dict
        A validated surface (:func:`meshcore.domain.surface.parse_surface`)
        or ``{"points": ..., "triangles": ...}`` (parsed here).
    progress : callable, optional
        ``progress(fraction, message)``; it may raise to cancel.

    Returns
    -------
    AdmissibleSurface
        Every output triangle is a face of the result's ``tetrahedra``, a
        Delaunay tetrahedralization of the output's surface points (exact:
        no point strictly inside any circumsphere): our kernel's (symbolic
        perturbation), changed only where points are exactly co-spherical
        (``tie_flips``); the output triangles of each facet (an input
        triangle, or exactly coplanar ones joined across edges) tile it
        (their areas add up to its area, up to rounding); every added point
        lies on an input edge or inside a facet (up to rounding, see the
        module docstring); input faces whose other points all lie strictly
        on one side of their plane get no point.

    Raises
    ------
    InputError
        An invalid surface (as :func:`parse_surface`, located under
        ``surface``).
    AlgorithmError
        ``recovery_failed`` if the rounds or points cap is reached.

    References
    ----------
    Methods text §9.2, §9.3.2-§9.3.5, §9.5.
    """
    t0 = time.perf_counter()
    surface = as_surface(surface)
    timings: dict[str, float] = {}
    st = _State(surface)
    b = st.b
    timings["delaunay"] = time.perf_counter() - t0
    t1 = time.perf_counter()
    case, strict0, disc = _classify(b.P, b.facets)
    cases_before = _counts(case, disc)
    F0 = b.facets[strict0]
    st.protected = np.unique(
        packed_edge_keys(np.concatenate([F0[:, [0, 1]], F0[:, [1, 2]], F0[:, [2, 0]]]))
    )
    timings["classify"] = time.perf_counter() - t1
    t2 = time.perf_counter()
    cap = MAX_ADDED_FACTOR * b.n_surface + MAX_ADDED_BASE
    budget = SEARCH_WORK if b.n_surface <= SEARCH_VERTICES else 0
    for rounds in range(1, MAX_ROUNDS + 1):
        if budget > 0:
            st, (added, ties, swaps), budget = _search(st, budget, cap)
        else:
            added, ties, swaps = _step(st)
        if added == 0 or st.b.n - st.b.n_surface > cap:
            break
        if progress is not None:
            progress(min(0.9, 0.05 + 0.01 * rounds), f"round {rounds}: {added} points added")
    else:
        rounds = MAX_ROUNDS + 1
    b = st.b  # the search's rounds are made on copies
    if rounds > MAX_ROUNDS or b.n - b.n_surface > cap:
        raise AlgorithmError(
            f"the surface could not be made Delaunay-admissible within {MAX_ROUNDS} rounds "
            f"and {cap} added points",
            code="recovery_failed",
        )
    timings["enforcement"] = time.perf_counter() - t2
    t3 = time.perf_counter()
    slots, T = b.tets()
    tie_rows = np.zeros(0, dtype=np.int64)
    if ties.cones:
        T = ties.tets()
        tie_rows = ties.cone_rows()
        region = regions(Reflipped(b, T), np.arange(len(T)), T)
    else:
        region = regions(b, slots, T)
    keep = region >= 0
    tetra, region = T[keep][:, [0, 1, 3, 2]], region[keep]
    timings["regions"] = time.perf_counter() - t3
    t4 = time.perf_counter()
    case, _, disc = _classify(b.P, b.sub)
    cases_after = _counts(case, disc)
    timings["classify"] += time.perf_counter() - t4
    # Output numbering: every input point (unused ones too), then the added ones.
    n_in = len(surface.points)
    out_index = np.concatenate([b.source, n_in + np.arange(b.n - b.n_surface)])
    points = np.concatenate([np.asarray(surface.points, dtype=np.float64), b.P[b.n_surface :]])
    cell_sets = {f"region_{r}": [np.flatnonzero(region == r)] for r in range(surface.region_count)}
    mesh = Mesh(points, (CellBlock("tetra", out_index[tetra]),), cell_sets=cell_sets)
    timings["total"] = time.perf_counter() - t0
    return AdmissibleSurface(
        points=points,
        triangles=out_index[b.sub],
        source=b.sources(),
        cases_before=cases_before,
        cases_after=cases_after,
        added_on_edges=st.added_on_edges,
        added_on_faces=st.added_on_faces,
        rounds=rounds,
        swaps=swaps,
        mesh=mesh,
        tetrahedra=out_index[T[:, [0, 1, 3, 2]]],
        inside=np.flatnonzero(keep),
        tie_tetrahedra=tie_rows,
        tie_flips=ties.cones,
        timings=timings,
    )
