"""Domain partitions from the medial axis and all-quad meshes on them (§9.7.1, §9.7.2, §8.5.3).

:func:`partition` splits a domain into polygonal regions along *cut lines*
derived from its medial axis (:func:`meshcore.medial.axis.medial_axis`, Voronoi
approximation); :func:`quad_medial` meshes those regions with quads.

Partition (§9.7.1). The regions are the faces of the planar graph made of
the boundary pieces, some axis edges and straight cuts from axis nodes to
the boundary samples their maximal circles touch (the radii of an empty
circle, so they stay inside the domain). Faces are traced with half-edges
sorted by angle around each vertex (floating-point angles: these are
constructions between distinct points, no sign decision); the faces of
positive area are the regions. A region's *corners* are the vertices where
three or more of these edges meet; its sides are the chains between
corners, so a run of boundary pieces between two cuts is one side, as the
text counts it.

* ``method="terminal"`` (the first method of the text): the cut lines are
  the axis itself, followed from each terminal node (the apex of a Type 2
  triangle) through Type 1 and Type 0 triangles to the next terminal; a
  region lies between the path joining two consecutive terminals and the
  boundary between them, with (Type 0 nodes on the path) + 2 sides. A leaf
  that does not reach a corner (the end of a smooth convex part) is joined
  to the sample its circle touches.
* ``method="critical"`` (the second method, Figure 9.13): each Type 0 node
  is joined to the vertices of its triangle (to all the co-circular
  vertices of its node), and consecutive Type 0 nodes are joined along the
  axis; terminal branches are not cuts. Regions are triangles (a cut, the
  boundary around a terminal branch, a cut) and quads (cut, boundary, cut,
  axis), as the text says.

Choices where the text leaves freedom ("numerous variations can be used in
order to optimize such a partition"): the branches that regions lie along
(those between junctions, loops, and an axis that is a single path) get
*cross-sections*, the two radii from a regular node to the two samples of
the Delaunay edge the axis crosses there, evenly spaced about one local
width (twice the mean radius) apart, so that regions are about as long as
they are wide and close to convex (a crescent along a hole's loop would
make inverted quads). At least four go on a closed loop with no junction
(an annulus: eight quads), two on a branch that leaves and returns to the
same junction, one on every branch of a loop for ``terminal`` (so each
hole is reached by a cut), and one on an axis that is a single path
between two terminals: so every region is simply connected and has at
least three sides.

Degenerate axes (smooth shapes). Where the axis of a disk is one node and
an ellipse's a short segment between co-circular fans, the cut lines give
regions of fewer than three sides, or many thin ones. Two partitions of the
text's idea ("regions with a simple geometry ... that can be covered by
quads") come first, each used when it applies and its fill is valid:

* a domain of one convex ring with exactly four corners (boundary turns
  above 40 degrees) is one four-sided region: the algebraic method alone,
  so a rectangle gives the structured grid (quality 1.0);
* a *smooth* domain of one ring (no turn above 75 degrees,
  :data:`BUTTERFLY_TURN`: disks, ellipses, stadiums, rounded rectangles,
  regular polygons of 5 sides or more, nearly round stars), star-shaped from
  its area centroid, gets the "butterfly": a central quad
  along the principal directions of the ring, in a band of one thickness
  (half the least distance from the centroid to the boundary along those
  directions, or 0.4 of it when the count would pass 1.5x area / size**2:
  :data:`INNER_FRACTIONS`), and four sectors cut from each of its corners to
  the nearest boundary sample (cuts about normal to the boundary).
  Its central quad carries the boundary's count both ways: where that passes
  :data:`MOST_COUNT` x area / size**2 (a gear: 1.88x at size 0.1, 1.84x at
  0.05) the medial partition is meshed instead when it keeps the count (1.49x
  and 1.37x; least quality 0.46 -> 0.44 and 0.43 -> 0.33, mean 0.83 -> 0.77
  and 0.86 -> 0.84: the count is the issue's promise).

Four-sided regions are one patch each (§9.7.2: "if the polygon is not a
quad itself, the midpoint subdivision completes"); the others get the
medial partition below.

Quads (§9.7.2, §8.5.3). With ``size``, a partition whose regions all have four
corners (an annulus: the regions between its loop's cross-sections and the two
rings) is filled one patch per region, as the text's "if the polygon is not a quad
itself": the midpoint subdivision put two quads at least across each ring (1.76x
area / size**2 at size 0.15; one patch each: 0.88x, least quality 0.80). Otherwise
every region is split by midpoint subdivision (a
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
``size`` then raises the count)
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
(:func:`meshcore.quads.optimization.relax_quads`: the regularized condition
number of every corner minimized, which untangles and smooths at once),
with the coarse corners on the boundary and the input vertices fixed, the
other boundary points sliding along their input segment and the interior
coarse corners free (the butterfly's valence-3 corners open from 90/135/135
to about 120 degrees); kept when it leaves fewer folded corners, or as many
and a better least quality. Last, the mesh is optimized as any all-quad mesh
(§8.4.3, :func:`_optimized`): the quad operators and smoothing of
:func:`meshcore.quads.optimization.optimize_quads`, then the corner angles
relaxed with the boundary points sliding (kept when the mean rises), then once
more with the power :data:`LEAST_POWER` over the quads under 0.5 and their
neighbours (kept when the least corner quality away from input vertices rises).
Where a border vertex's corners average more than :data:`OPEN_ANGLE` (125
degrees) the fill gets one quad more there (:func:`_opened`, before the
smoothing). The relaxation's untangling rounds shrink Escobar's
regularization each round, so that a fold among corners far smaller than
the median (a reflex input corner next to a short piece) is not lost in
it, and a sliding point stays between the midpoints to its neighbours (it
can neither collapse onto an input corner nor pass another point).

Spikes and crowded reflex corners (:mod:`meshcore.medial.regions`). An input
corner under 45 degrees inside a larger region is cut off by a chord between the
region corners around it (:func:`partition`), and its triangle's subdivision is a
small kite at the tip (side points :data:`KITE_SIDE` x size from it, the inner
point just past them) and two strips along its sides; ``quad_medial`` keeps
``ceil(angle / 135) - 1`` of the cuts at a reflex input corner, merging the
regions on both sides of the others. On 32 random stars of the issue's kind (5-60
vertices, radial jitter 10-80 %, every other one with a star-shaped hole) at size
0.1, away from the quads at input corners under 45 degrees (forced: such a corner
is held by one quad): corners in [30, 150] degrees on 26 (was 21), least quality
0.3 on 27 (was 25) and 0.5 on 11 (was 9; two more since the quad operators of
:func:`_optimized` are dropped when they take a quad from an input corner: a
collapse undid the opened reflex corners), least 0.07-0.58 (was 0.03-0.58); quads
under 0.5 there 290 (was 647: 199 -> 77 at reflex corners, 311 -> 153 in
triangle regions, 137 -> 49 in four-sided ones); the count 0.92-1.72x area /
size**2 (was 0.97-1.63x; over 1.5x on two stars as before, one of them
60 vertices with spikes and input vertices
closer than ``size``). What is left under 0.5: quads next to the kites of the
thinnest spikes (2-10 degrees) and to reflex corners, and thin regions of the
``critical`` partition around its Type 0 nodes (the text's midpoint subdivision
of a triangle region with a corner of 10-30 degrees at an axis node).
Every job succeeds and every quad is strictly convex (``stats["not_convex"]``
counts them, exact). On 150 random star polygons the ``critical``
partition so gives only valid quads; the ``terminal`` one's 5- and 6-sided
regions around reflex corners still folded on 19 of them, so when it does
the mesh is made on the ``critical`` partition instead (said in
``stats["fallback"]``); so too when one of its regions passes a vertex twice (a
dead-end cut inside it, a slit: its fill left a sliver hole along the slit).

Translation and scale: areas and centroids relative to a vertex; rounding ties
decided by rules (a sample count within 1e-7 above an integer is that integer, no
principal direction: the x and y axes, an eigenvector's largest component positive,
the first sample within 1e-9 of the least distance; fill points numbered by first
occurrence): the same cells at +1e6 and x1e-6. The ``terminal`` method also made regions of 7 sides
on 2 of those 150 (footnote 12 of the text presumes 6 at most).

References
----------
Methods text §9.7.1 (domain partitioning, Figure 9.13), §9.7.2 (quad mesh
construction, Figure 9.14), §8.5.3 (medial axis, midpoint subdivision,
algebraic method and its consistency constraints).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from meshcore.domain.planar import Domain
from meshcore.errors import AlgorithmError, InputError
from meshcore.geometry.predicates import orient2d
from meshcore.medial.axis import DEFAULT_PRUNE, MedialAxis, _classes, _csr, _cycles, medial_axis
from meshcore.medial.regions import (
    _AXIS,
    _BOUNDARY,
    _CUT,
    KITE_ANGLE,
    input_fans,
    input_index,
    reflex_merged,
    spike_chords,
    turns,
)
from meshcore.mesh import CellBlock, Mesh, quality, topology
from meshcore.quads.combination import TOL
from meshcore.quads.optimization import optimize_quads, relax_quads, sliding_nodes

__all__ = ["Partition", "QuadMedial", "partition", "quad_medial"]

Progress = Callable[[float, str], None]

#: Most quads a ``quad_medial`` job may make.
MAX_QUADS = 4_000_000
#: Gauss-Seidel smoothing sweeps after the transfinite fill (at most).
SMOOTHING_SWEEPS = 50
#: A boundary turn above this (radians) is a corner of the domain: 40 degrees,
#: so a regular polygon of 9 or more sides is smooth (butterfly) and a rectangle
#: has four corners (one patch).
SMOOTH_TURN = math.radians(40.0)
#: The butterfly is tried on a star-shaped ring with no turn above this (radians):
#: 75 degrees, so that nearly round stars get it too. At 40 a random 31-gon star
#: (jitter 0.19, size 0.1) got 36 thin critical regions: 558 quads (1.75x area /
#: size**2), least quality 0.08; the butterfly 344 quads (1.08x), least 0.59 after
#: :func:`_optimized`. At 120 degrees 4 of 24 stars came out better, 4 worse.
BUTTERFLY_TURN = math.radians(75.0)
#: The butterfly's band around its central quad is of one thickness, ``1 - f`` of
#: the least distance from the centroid to the boundary along the principal
#: directions, for the first ``f`` of these whose count stays within
#: :data:`MOST_COUNT` x area / size**2 (else the one of fewest quads). One thickness
#: all round (rather than a fraction of each direction's distance, 0.5 before) took
#: the 4:1 ellipse at size 0.1 from 2.10x to 1.06x (least quality 0.28 -> 0.49) and
#: a stadium from 1.74x to 1.29x; 0.6 is reached on a 64-gon disk at 0.1 (1.57x
#: at 0.5, 1.36x at 0.6, mean quality 0.932 -> 0.914).
INNER_FRACTIONS = (0.5, 0.6)
#: A convex input corner turning by more than this (radians; an interior angle under
#: 120 degrees) is a corner of its region's midpoint subdivision (one quad there, not
#: two of half its angle).
SHARP_TURN = math.radians(60.0)
#: The count promised: at most this times area / size**2 where the partition allows.
MOST_COUNT = 1.5
#: A border vertex whose quads' corners there average more than this (degrees) gets
#: one quad more (:func:`_opened`).
OPEN_ANGLE = 125.0
#: The kite at a spike's tip (:data:`meshcore.medial.regions.KITE_ANGLE`): the points of
#: its two sides this times size from the tip (at most a third of the side), its inner
#: point tried at :data:`KITE_PAST` times their distance past their middle.
KITE_SIDE = 1.0
#: The kite's inner point is tried this many times the distance of its two side points
#: past their middle (away from the tip).
KITE_PAST = (0.05, 0.1, 0.2, 0.35, 0.5, 0.8)
#: The last relaxation (:func:`_optimized`) minimizes the summed (1 / sin angle) ** this
#: over the quads under quality 0.5 and their neighbours: the worst corners weigh most.
LEAST_POWER = 8.0

#: Where the count passes :data:`MOST_COUNT` x area / size**2, the classes' counts are
#: taken again for ``size`` times each of these in turn (the input vertices' counts
#: still bind): rounding each class up and the ring of an annulus carrying the outer
#: circle's count inwards made 1.68x at size 0.1.
STRETCH = (1.0, 1.15, 1.3, 1.5)
#: The final corner relaxation (:func:`_optimized`) may lower the least quality by this
#: for a higher mean: on the benchmark's spiky star at size 0.1, with a reflex corner
#: opened, it took the mean from 0.778 to 0.836 and the least from 0.486 to 0.481, and
#: was refused (mean 0.84 without the opening).
LEAST_GIVE = 0.01


@dataclass(frozen=True, eq=False)
class Partition:
    """Regions of a domain cut along its medial axis.

    Attributes
    ----------
    regions : list of dict
        GeoJSON Polygons (counter-clockwise closed ring), each with the
        foreign members ``sides`` (its side count) and ``area``.
    cuts : (c, 2, 2) float64
        The cut segments that are not axis edges.
    axis : MedialAxis
        The axis the partition comes from.
    points : (v, 2) float64
        Vertices of the planar graph: the boundary samples, then the axis nodes.
    cycles : tuple of (k,) int64
        Each region's vertex ids, counter-clockwise.
    corners : tuple of (k,) bool
        Which of a cycle's vertices are corners of the region.
    edge_kind : tuple of (k,) int8
        Kind of each cycle edge (vertex ``i`` to ``i + 1``): 0 boundary, 1
        axis, 2 cut.
    stats : dict
    """

    regions: list[dict]
    cuts: np.ndarray
    axis: MedialAxis
    points: np.ndarray
    cycles: tuple[np.ndarray, ...]
    corners: tuple[np.ndarray, ...]
    edge_kind: tuple[np.ndarray, ...]
    stats: dict = field(default_factory=dict)


@dataclass(frozen=True, eq=False)
class QuadMedial:
    """An all-quad mesh on a medial-axis partition."""

    mesh: Mesh
    partition: Partition
    stats: dict = field(default_factory=dict)


# ---------------------------------------------------------------------------
# Cut lines
# ---------------------------------------------------------------------------


def _contacts(ax: MedialAxis) -> tuple[np.ndarray, np.ndarray]:
    """CSR lists of the samples each node's circle touches (its triangles' vertices),
    one per run of consecutive samples (co-circular neighbours touch the circle at
    one place: cutting to both would make a sliver region)."""
    t = np.flatnonzero(ax.triangle_node >= 0)
    pairs = np.unique(
        np.column_stack([np.repeat(ax.triangle_node[t], 3), ax.triangles[t].ravel()]), axis=0
    )
    key = pairs[:, 0] * np.int64(len(ax.samples)) + pairs[:, 1]
    pred = np.empty(len(ax.samples), dtype=np.int64)
    pred[ax.succ] = np.arange(len(ax.succ))
    before = pairs[:, 0] * np.int64(len(ax.samples)) + pred[pairs[:, 1]]
    pos = np.minimum(np.searchsorted(key, before), len(key) - 1)
    follows = key[pos] == before
    kept = np.bincount(pairs[~follows, 0], minlength=len(ax.nodes))
    closed = np.flatnonzero((kept == 0) & (np.bincount(pairs[:, 0], minlength=len(ax.nodes)) > 0))
    follows[np.searchsorted(pairs[:, 0], closed)] = False  # a closed run: keep one
    pairs = pairs[~follows]
    start = np.searchsorted(pairs[:, 0], np.arange(len(ax.nodes) + 1))
    return start, pairs[:, 1]


def _branch_graph_core(ax: MedialAxis) -> np.ndarray:
    """Per branch, whether it is in the 2-core of the graph of branches."""
    ends = np.array([[b[0], b[-1]] for b in ax.branches], dtype=np.int64).reshape(-1, 2)
    alive = np.ones(len(ends), dtype=bool)
    while True:
        deg = np.bincount(ends[alive].ravel(), minlength=len(ax.nodes))
        loose = alive & ((deg[ends[:, 0]] == 1) | (deg[ends[:, 1]] == 1))
        if not loose.any():
            return alive
        alive &= ~loose


@njit(cache=True)
def _stripped(n, edges, keep):
    """Edges left after peeling, leaf by leaf, the nodes not in ``keep``."""
    start, inc = _csr(n, edges)
    alive = np.ones(edges.shape[0], np.bool_)
    deg = np.diff(start)
    stack = np.empty(n, np.int64)
    top = 0
    for v in range(n):
        if deg[v] == 1 and not keep[v]:
            stack[top] = v
            top += 1
    while top > 0:
        top -= 1
        v = stack[top]
        if deg[v] != 1 or keep[v]:
            continue
        for j in range(start[v], start[v + 1]):
            f = inc[j]
            if alive[f]:
                alive[f] = False
                deg[v] = 0
                w = edges[f, 0] + edges[f, 1] - v
                deg[w] -= 1
                if deg[w] == 1 and not keep[w]:
                    stack[top] = w
                    top += 1
    return alive


def _cut_lines(ax: MedialAxis, method: str):
    """Axis edges kept and cuts (node, sample) of the partition."""
    n = len(ax.nodes)
    deg = np.bincount(ax.edges.ravel(), minlength=n)
    start, contact = _contacts(ax)
    core = _branch_graph_core(ax)
    first, incident = _csr(n, ax.edges)  # the axis edges of each node
    cuts: list[tuple[int, int]] = []
    keep_edge = np.ones(len(ax.edges), dtype=bool)
    for v in np.flatnonzero((deg >= 3) | (deg == 0)):
        if method == "critical" or deg[v] == 0:
            cuts += [(int(v), int(s)) for s in contact[start[v] : start[v + 1]]]
    sections: list[int] = []
    for b, chain in enumerate(ax.branches):
        closed = chain[0] == chain[-1]
        if closed and deg[chain[0]] == 2:  # a loop with no junction
            least = 4
        elif closed:
            least = 2
        elif deg[chain[0]] == 1 and deg[chain[-1]] == 1:  # the whole axis is a path
            least = 1
        elif core[b]:
            least = 1 if method == "terminal" else 0
        else:
            continue
        xy = ax.nodes[chain]
        s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])
        width = 2 * max(float(ax.radius[chain].mean()), np.finfo(float).tiny)
        k = max(least, int(round(s[-1] / width)) - 1)
        at = np.searchsorted(s, s[-1] * np.arange(1, k + 1) / (k + 1))
        sections += [int(chain[i]) for i in np.clip(at, 1, len(chain) - 2) if deg[chain[i]] == 2]
    for v in dict.fromkeys(int(s) for s in sections):
        # the two radii at a regular node: to the samples of a Delaunay edge it sits on
        e = incident[first[v] : first[v + 1]]
        e = e[ax.edge_pq[e, 0] >= 0]
        if e.size:
            cuts += [(v, int(ax.edge_pq[e[0], 0])), (v, int(ax.edge_pq[e[0], 1]))]
    if method == "terminal":
        for v in np.flatnonzero((deg == 1) & (ax.node_sample < 0)):
            e = int(incident[first[v]])
            touch = contact[start[v] : start[v + 1]]
            away = touch[~np.isin(touch, ax.edge_pq[e])]
            if away.size:
                cuts.append((int(v), int(away[0])))
    else:
        # only the axis between cut nodes: strip branches down to nodes with cuts
        has_cut = np.zeros(n, dtype=bool)
        has_cut[[c[0] for c in cuts]] = True
        keep_edge = _stripped(n, ax.edges, has_cut)
    return keep_edge, np.array(cuts, dtype=np.int64).reshape(-1, 2)


# ---------------------------------------------------------------------------
# Faces
# ---------------------------------------------------------------------------


def _faces(points: np.ndarray, edges: np.ndarray, kind: np.ndarray, succ: np.ndarray):
    """Faces of a planar straight-line graph that lie in the domain.

    ``succ`` gives the next sample along the boundary (the first
    ``len(succ)`` vertices are the samples): faces bordered by a boundary
    piece run backwards (holes, the exterior) are dropped. Returns per face
    its counter-clockwise vertex cycle, corner flags (vertex degree >= 3)
    and edge kinds.
    """
    tail = np.concatenate([edges[:, 0], edges[:, 1]])
    head = np.concatenate([edges[:, 1], edges[:, 0]])
    hkind = np.concatenate([kind, kind])
    m = len(edges)
    twin = np.concatenate([np.arange(m, 2 * m), np.arange(m)])
    d = points[head] - points[tail]
    angle = np.arctan2(d[:, 1], d[:, 0])
    order = np.lexsort((angle, tail))
    rank = np.empty(2 * m, dtype=np.int64)
    rank[order] = np.arange(2 * m)
    first = np.searchsorted(tail[order], np.arange(len(points) + 1))
    degree = np.diff(first)
    # next(h): at head(h), the outgoing half-edge just before twin(h) in CCW order
    t = twin
    v = head
    pos = rank[t] - first[v]
    prev_pos = (pos - 1) % degree[v]
    nxt = order[first[v] + prev_pos]
    horder, offsets = _cycles(nxt, nxt)
    p = len(succ)
    backwards = (hkind == _BOUNDARY) & (head < p) & (tail < p)
    backwards[backwards] = succ[head[backwards]] == tail[backwards]
    cycles, corners, kinds = [], [], []
    for f in range(len(offsets) - 1):
        hs = horder[offsets[f] : offsets[f + 1]]
        if backwards[hs].any():
            continue
        verts = tail[hs]
        if _ring_area(points[verts]) <= 0:
            continue
        cycles.append(verts)
        corners.append(degree[verts] >= 3)
        kinds.append(hkind[hs].astype(np.int8))
    return cycles, corners, kinds


def _ring_area(xy: np.ndarray) -> float:
    """The signed area of a ring, from coordinates relative to its first vertex (the
    absolute ones lost a spike of area 2e-5 at an offset of 1e6 to cancellation)."""
    x, y = xy[:, 0] - xy[0, 0], xy[:, 1] - xy[0, 1]
    return 0.5 * math.fsum(x * np.roll(y, -1) - np.roll(x, -1) * y)


def _area_centroid(xy: np.ndarray) -> tuple[float, np.ndarray]:
    """The signed area and area centroid of a ring, relative to its first vertex."""
    d = xy - xy[0]
    x, y = d[:, 0], d[:, 1]
    cross = x * np.roll(y, -1) - np.roll(x, -1) * y
    area = float(cross.sum()) / 2
    c = np.array([((x + np.roll(x, -1)) * cross).sum(), ((y + np.roll(y, -1)) * cross).sum()])
    return area, xy[0] + c / (6 * area)


def partition(
    domain: Domain | None = None,
    *,
    axis: MedialAxis | None = None,
    method: str = "critical",
    h: float | None = None,
    prune: float = DEFAULT_PRUNE,
    progress: Progress | None = None,
) -> Partition:
    """Split a domain into regions along cut lines of its medial axis (§9.7.1).

    Parameters
    ----------
    domain : Domain, optional
        The domain; its axis is computed with ``h`` and ``prune``.
    axis : MedialAxis, optional
        Instead of ``domain``: an axis from :func:`~meshcore.medial.axis.medial_axis`
        (``voronoi`` approximation).
    method : {"critical", "terminal"}
        The second or the first method of the text (module docstring).
    h, prune : float, optional
        As :func:`~meshcore.medial.axis.medial_axis`.
    progress : callable, optional

    Returns
    -------
    Partition
        Regions that tile the domain: simple counter-clockwise polygons with
        disjoint interiors whose areas add up to the domain's area, every
        vertex a boundary sample or an axis node.

    Raises
    ------
    InputError
        A bad method, or neither or both of domain and axis.
    AlgorithmError
        A region came out with fewer than 3 sides (an axis too coarse to
        partition: lower ``h``).

    References
    ----------
    Methods text §9.7.1, Figure 9.13.
    """
    if method not in ("critical", "terminal"):
        raise InputError(
            f"method must be 'critical' or 'terminal', got {method!r}",
            loc=("method",),
            code="bad_value",
        )
    if (domain is None) == (axis is None):
        raise InputError("give exactly one of domain and axis", loc=(), code="bad_input")
    if axis is None:
        axis = medial_axis(domain, h=h, prune=prune, progress=progress)
    ax = axis
    if len(ax.nodes) and (ax.triangle_node < 0).all():
        raise InputError(
            "partition needs an axis of the 'voronoi' approximation",
            loc=("axis",),
            code="bad_value",
        )
    keep_edge, cuts = _cut_lines(ax, method)
    p = len(ax.samples)
    points = np.concatenate([ax.samples, ax.nodes])
    vertex = np.where(ax.node_sample >= 0, ax.node_sample, p + np.arange(len(ax.nodes)))
    axis_edges = vertex[ax.edges[keep_edge]]
    cut_edges = np.column_stack([vertex[cuts[:, 0]], cuts[:, 1]])
    edges = np.concatenate([ax.segments, axis_edges, cut_edges])
    kind = np.concatenate(
        [
            np.full(len(ax.segments), _BOUNDARY),
            np.full(len(axis_edges), _AXIS),
            np.full(len(cut_edges), _CUT),
        ]
    )
    edges = np.sort(edges, axis=1)
    edges, first = np.unique(edges, axis=0, return_index=True)
    proper = edges[:, 0] != edges[:, 1]
    succ = ax.succ
    cycles, corners, kinds = _faces(points, edges[proper], kind[first][proper], succ)
    cycles, corners, kinds, chords = spike_chords(points, cycles, corners, kinds, turns(ax))
    cut_edges = np.concatenate([cut_edges, np.array(chords, np.int64).reshape(-1, 2)])
    regions = []
    total = 0.0
    for verts, corner in zip(cycles, corners, strict=True):
        ring = points[verts]
        area = _ring_area(ring)
        total += area
        sides = int(corner.sum())
        if sides < 3:
            raise AlgorithmError(
                f"a region of area {area:.6g} has {sides} sides: the axis is too coarse to "
                "partition the domain, give a smaller h"
            )
        coords = np.concatenate([ring, ring[:1]]).tolist()
        regions.append({"type": "Polygon", "coordinates": [coords], "sides": sides, "area": area})
    sides = np.array([r["sides"] for r in regions], dtype=np.int64)
    stats = {
        "regions": len(regions),
        "sides": {str(k): int((sides == k).sum()) for k in np.unique(sides)},
        "cuts": int(len(cut_edges)),
        "area": total,
        "domain_area": ax.domain.area,
        "axis": ax.stats,
    }
    return Partition(
        regions=regions,
        cuts=np.stack([points[cut_edges[:, 0]], points[cut_edges[:, 1]]], axis=1),
        axis=ax,
        points=points,
        cycles=tuple(cycles),
        corners=tuple(corners),
        edge_kind=tuple(kinds),
        stats=stats,
    )


# ---------------------------------------------------------------------------
# Quads: midpoint subdivision, then a transfinite fill (§9.7.2, §8.5.3)
# ---------------------------------------------------------------------------


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


def _opened(points: np.ndarray, quads: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """A quad more at every border vertex whose quads' corners there average more
    than :data:`OPEN_ANGLE` (a reflex input corner over 250 degrees that the
    midpoint subdivision gave two quads, each with a corner over 125 degrees): the
    interior edge ``v - b`` between its two widest corners is opened into a quad
    ``(v, b, z, b2)``, ``b`` split in two along the path ``v - b - z`` (``z`` the
    neighbour of ``b`` across from ``v``; ``b`` keeps the quads on one side, the new
    point ``b2`` takes the others). ``b`` and ``b2`` start a third of the way to the
    centroids of their quads, the smoothing that follows places them. Returns the
    points, the quads and how many edges were opened."""
    n = len(points)
    P, Q = points.copy(), quads.copy()
    start, cells = _csr(n, Q)
    e = np.stack([Q, np.roll(Q, -1, axis=1)], axis=-1).reshape(-1, 2)
    key = np.sort(e, axis=1) @ np.array([n, 1], np.int64)
    uk, cnt = np.unique(key, return_counts=True)
    border = np.zeros(n, dtype=bool)
    border[uk[cnt == 1] // n] = border[uk[cnt == 1] % n] = True
    added: list[np.ndarray] = []
    for v in np.flatnonzero(border):
        fan = [int(q) for q in cells[start[v] : start[v + 1]]]
        if len(fan) < 2:
            continue
        at = {q: int(np.flatnonzero(Q[q] == v)[0]) for q in fan}
        ang = {}
        for q in fan:
            c = P[Q[q]]
            a, b = c[at[q] - 1] - c[at[q]], c[(at[q] + 1) % 4] - c[at[q]]
            ang[q] = math.atan2(abs(a[0] * b[1] - a[1] * b[0]), float(a @ b))
        if math.degrees(sum(ang.values())) / len(fan) <= OPEN_ANGLE:
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


def _coons(bottom, right, top, left) -> np.ndarray:
    """Transfinite interpolation on an ``(n1 + 1) x (n2 + 1)`` grid.

    ``bottom`` and ``top`` run in ``u`` (n1 + 1 points), ``left`` and
    ``right`` in ``v`` (n2 + 1); the corners are shared::

        left[-1] = top[0]  ----  top[-1] = right[-1]
           |                        |
        left[0] = bottom[0] ---- bottom[-1] = right[0]
    """
    n1, n2 = len(bottom) - 1, len(left) - 1
    u = np.linspace(0.0, 1.0, n1 + 1)[:, None, None]
    v = np.linspace(0.0, 1.0, n2 + 1)[None, :, None]
    B, T = bottom[:, None, :], top[:, None, :]
    L, R = left[None, :, :], right[None, :, :]
    grid = (
        (1 - v) * B
        + v * T
        + (1 - u) * L
        + u * R
        - ((1 - u) * (1 - v) * bottom[0] + u * (1 - v) * bottom[-1])
        - ((1 - u) * v * top[0] + u * v * top[-1])
    )
    grid[:, 0], grid[:, -1], grid[0, :], grid[-1, :] = bottom, top, left, right
    return grid


def _corner_area(a, b, c) -> float:
    return 0.5 * float((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))


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
    centroid = _area_centroid(ring)[1]
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


def quad_medial(
    domain: Domain,
    *,
    method: str = "critical",
    size: float | None = None,
    levels: int | None = None,
    h: float | None = None,
    prune: float = DEFAULT_PRUNE,
    progress: Progress | None = None,
) -> QuadMedial:
    """An all-quad mesh of a domain from its medial-axis partition (§9.7.2).

    Parameters
    ----------
    domain : Domain
    method : {"critical", "terminal"}
        The partition (:func:`partition`).
    size : float, optional
        Target edge length of the transfinite fill: each class of sides that
        conformity ties together gets the largest ``ceil(length / size)`` of
        its members.
    levels : int, optional
        Instead of ``size``: ``levels`` more midpoint subdivisions (every
        coarse quad becomes ``4**levels`` quads). Neither: ``levels=2``.
    h, prune : optional
        As :func:`~meshcore.medial.axis.medial_axis`.
    progress : callable, optional

    Returns
    -------
    QuadMedial
        Only quads, counter-clockwise, of positive area, conforming
        (coincident boundary points of neighbouring patches are one point),
        boundary points on the input boundary (snapped onto its corners
        where the counts allow, which covers a polygonal domain exactly).
        ``stats["fallback"]`` says when a ``terminal`` partition folded and
        the ``critical`` one was meshed instead; ``stats["partition"]`` is
        ``"four-sided"`` or ``"butterfly"`` when one of those was used
        (module docstring); ``stats["not_convex"]``: quads with a corner that
        is not strictly convex (exact; none on the domains tested), counted
        (:func:`_optimized` runs only when there are none, and keeps every
        quad strictly convex); ``stats["optimized"]`` its operator counts and
        ``stats["corners_relaxed"]`` whether its angle relaxation was kept;
        ``stats["optimize_undone"]``: its operators took a quad from an input
        corner, and the fill was relaxed without them.

    Raises
    ------
    InputError
        Both ``size`` and ``levels``, values out of range, or more than
        :data:`MAX_QUADS` quads.
    AlgorithmError
        As :func:`partition`, or inverted quads left on the critical
        partition (none on the domains tested).

    References
    ----------
    Methods text §9.7.2, Figure 9.14; §8.5.3; Chapter 4 (algebraic methods).
    """
    if size is not None and levels is not None:
        raise InputError("give size or levels, not both", loc=("levels",), code="bad_input")
    if size is not None and not (math.isfinite(size) and size > 0):
        raise InputError(f"size must be positive, got {size!r}", loc=("size",), code="bad_value")
    if levels is None and size is None:
        levels = 2
    if levels is not None and not (0 <= int(levels) <= 10):
        raise InputError(
            f"levels must be between 0 and 10, got {levels!r}", loc=("levels",), code="bad_value"
        )
    axis = medial_axis(domain, h=h, prune=prune, progress=progress)
    special, mesh, stats = _special(axis, size, levels)
    part = None
    if special is not None and not stats["invalid"]:
        if size is not None and stats["quads"] * size * size > MOST_COUNT * domain.area:
            # the butterfly's central quad carries the boundary's count both ways (a gear
            # at size 0.1: 1.88x): the medial partition when it keeps the count
            try:  # (a 2:1 ellipse's medial partition has a 2-sided region: the butterfly)
                part = _reflex_merged(partition(axis=axis, method=method))
                mesh2, stats2 = _quads_on(part, size, levels)
            except AlgorithmError:
                part, stats2 = None, {"invalid": 1}
            bad = stats2["invalid"] or stats2["slits"]
            if bad or stats2["quads"] * size**2 > MOST_COUNT * domain.area:
                part = None
        if part is None:
            kind = "four-sided" if len(special.regions) == 1 else "butterfly"
            mesh, stats = _optimized(mesh, domain, stats)
            report = quality.report(mesh)
            return QuadMedial(
                mesh=mesh, partition=special, stats={**stats, "partition": kind, "quality": report}
            )
        mesh, stats = mesh2, stats2
    else:
        part = _reflex_merged(partition(axis=axis, method=method))
        mesh, stats = _quads_on(part, size, levels)
    if (stats["invalid"] or stats["slits"]) and method == "terminal":
        # regions of 5 or 6 sides around reflex corners can fold; the critical
        # partition's triangles and quads do not on the domains tested. A region
        # around a dead-end cut (a slit: its cycle passes a vertex twice) gave a
        # non-conforming fill, a sliver hole along the slit (a random star at size 0.5)
        fallback = _reflex_merged(partition(axis=part.axis, method="critical"))
        mesh, stats2 = _quads_on(fallback, size, levels)
        stats = {
            **stats2,
            "fallback": f"the terminal partition gave {stats['invalid']} "
            f"inverted quads and {stats['slits']} regions with a slit: meshed on the "
            "critical partition",
        }
        part = fallback
    if stats["slits"]:
        raise AlgorithmError(
            f"{stats['slits']} regions of this partition pass a vertex twice (a slit); try "
            "another method or a smaller h"
        )
    if stats["invalid"]:
        raise AlgorithmError(
            f"{stats['invalid']} quads came out inverted on this partition; try another "
            "method, a smaller h or a smaller size"
        )
    mesh, stats = _optimized(mesh, domain, stats)
    report = quality.report(mesh)
    return QuadMedial(mesh=mesh, partition=part, stats={**stats, "quality": report})


def _optimized(mesh: Mesh, domain: Domain, stats: dict) -> tuple[Mesh, dict]:
    """The fill improved as an all-quad mesh (§8.4.3): the quad operators and smoothing
    of :func:`meshcore.quads.optimization.optimize_quads` (boundary points fixed), then
    the corner angles relaxed (:func:`~meshcore.quads.optimization.relax_quads` with
    ``angle_power``) over the quads under 0.95 and their neighbours, the input vertices
    fixed and the other boundary points sliding along their segment. The relaxation is
    kept when every quad stays strictly convex (exact), the mean quality (8.4) rises,
    no more quads fall under 0.5 and the least drops by at most :data:`LEAST_GIVE`."""
    if stats["not_convex"] or mesh.cells_by_type["quad"].shape[0] > TOL.relax_most:
        return mesh, stats  # optimize_quads takes strictly convex quads only
    opt = optimize_quads(mesh)
    P, Q = opt.mesh.points, opt.mesh.cells_by_type["quad"]
    out = {**stats, "optimized": {k: int(v) for k, v in opt.operators.items()}}
    fans = input_fans(mesh.points, mesh.cells_by_type["quad"], domain.points)
    out["optimize_undone"] = bool((input_fans(P, Q, domain.points) < fans).any())
    if out["optimize_undone"]:
        # an operator took a quad from an input corner (a collapse undid an opened
        # reflex corner, _opened: two quads of 137 degrees were left at 273): the fill
        # is relaxed as it is (least Q >= 0.5 on 11 of 32 random stars, was 9)
        P, Q = mesh.points, mesh.cells_by_type["quad"]
    q = quality.quad_quality(P, Q)
    fixed = input_index(P, domain.points) >= 0
    bad = np.zeros(len(P), dtype=bool)
    bad[Q[q < TOL.relax_below].ravel()] = True
    active = bad[Q].any(axis=1)
    new = relax_quads(
        P, Q, fixed, slide=sliding_nodes(P, Q, fixed), active=active, angle_power=TOL.relax_power
    )
    q2 = quality.quad_quality(new, Q)
    kept = (
        not (_folded(new, Q) > 0).any()
        and q2.mean() > q.mean()
        and (q2 < 0.5).sum() <= (q < 0.5).sum()
        and q2.min() >= q.min() - LEAST_GIVE
    )
    if kept:
        P = new
    out["corners_relaxed"] = bool(kept)
    # then the worst corners alone (a higher power), over the quads under 0.5 and their
    # neighbours: kept when it raises the least corner quality away from input vertices
    q = quality.quad_quality(P, Q)
    bad = np.zeros(len(P), dtype=bool)
    bad[Q[q < 0.5].ravel()] = True
    active = bad[Q].any(axis=1)
    kept = False
    if active.any():
        new = relax_quads(
            P, Q, fixed, slide=sliding_nodes(P, Q, fixed), active=active, angle_power=LEAST_POWER
        )
        kept = (
            not (_folded(new, Q) > 0).any()
            and _least_free(new, Q, fixed) > _least_free(P, Q, fixed)
            and quality.quad_quality(new, Q).mean() >= q.mean() - LEAST_GIVE
        )
        if kept:
            P = new
    out["least_relaxed"] = bool(kept)
    out["quads"] = int(len(Q))
    out["points"] = int(len(P))
    return Mesh(P, (CellBlock("quad", Q),)), out


def _least_free(P: np.ndarray, Q: np.ndarray, fixed: np.ndarray) -> float:
    """The least corner quality ((8.3)) of the quads over their corners that are not
    ``fixed`` points (an input corner's angle is the input's)."""
    ang = quality.quad_angles(P, Q)
    qp = np.where(ang <= 90.0, ang / 90.0, np.maximum(2.0 - ang / 90.0, 0.0))
    return float(qp[~fixed[Q]].min(initial=1.0))


def _special(ax: MedialAxis, size: float | None, levels: int | None):
    """The four-sided or butterfly partition and its fill, or ``(None, None, None)``.
    The butterfly tries :data:`INNER_FRACTIONS` in turn and keeps the first valid
    fill within :data:`MOST_COUNT` x area / size**2 (else the valid one of fewest
    quads; else the last tried, its inverted quads counted in its stats)."""
    four = _four_sided(ax)
    if four is not None:
        return four, *_quads_on(four, size, levels, whole=True)
    best = None
    for f in INNER_FRACTIONS:  # a loop over at most two partitions
        part = _butterfly(ax, f)
        if part is None:
            return None, None, None
        mesh, stats = _quads_on(part, size, levels, whole=True)
        if (
            best is None
            or best[2]["invalid"]
            or (not stats["invalid"] and stats["quads"] < best[2]["quads"])
        ):
            best = (part, mesh, stats)
        over = size is not None and stats["quads"] * size * size > MOST_COUNT * ax.domain.area
        if levels is not None or not (over or stats["invalid"]):
            break
    return best


def _relaxed(points: np.ndarray, quads: np.ndarray, corner: np.ndarray, ax: MedialAxis):
    """The fill untangled and smoothed (:func:`meshcore.quads.optimization.relax_quads`):
    the coarse quads' corners on the boundary (``corner``) and the boundary samples
    that are input vertices stay, the other boundary points slide along their input
    segment. Kept when it leaves fewer folded quads, or as many and a better least
    quality, than the fill; returns the points and whether they were kept."""
    fixed = corner.copy()
    p = len(ax.samples)
    pred = np.empty(p, dtype=np.int64)
    pred[ax.succ] = np.arange(p)
    vertex = ax.samples[ax.segment_source[pred] != ax.segment_source]
    order = np.lexsort(points.T[::-1])
    srt = points[order]
    at = np.searchsorted(srt[:, 0], vertex[:, 0])
    for v, i in zip(vertex, at, strict=True):  # exact matches only
        while i < len(srt) and srt[i, 0] == v[0]:
            if srt[i, 1] == v[1]:
                fixed[order[i]] = True
            i += 1

    new = relax_quads(points, quads, fixed, slide=sliding_nodes(points, quads, fixed))
    before, after = _folded(points, quads).sum(), _folded(new, quads).sum()
    q0 = quality.cell_quality(points, quads, "quad").min()
    q1 = quality.cell_quality(new, quads, "quad").min()
    if after < before or (after == before and q1 > q0):
        return new, True
    return points, False


def _folded(P: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """(q,) int: the corners of each quad that are not strictly convex (exact
    :func:`~meshcore.geometry.predicates.orient2d`)."""
    c = P[quads]
    prv, nxt = np.roll(c, 1, axis=1), np.roll(c, -1, axis=1)
    return sum((orient2d(prv[:, k], c[:, k], nxt[:, k]) <= 0).astype(np.int64) for k in range(4))


def _one_ring(ax: MedialAxis) -> np.ndarray | None:
    """The samples of a domain bounded by one ring, in boundary order (None otherwise)."""
    ring = [0]
    while len(ring) <= len(ax.succ):
        nxt = int(ax.succ[ring[-1]])
        if nxt == 0:
            break
        ring.append(nxt)
    return np.array(ring, np.int64) if len(ring) == len(ax.succ) else None


def _four_sided(ax: MedialAxis) -> Partition | None:
    """The whole domain as one four-sided region when it is one convex ring with
    exactly four corners (turns above :data:`SMOOTH_TURN`): a rectangle gives the
    structured grid."""
    ring = _one_ring(ax)
    if ring is None:
        return None
    turn = turns(ax)[ring]
    if (turn < -1e-12).any() or int((turn > SMOOTH_TURN).sum()) != 4:
        return None
    return _made(ax, ax.samples, [ring], [turn > SMOOTH_TURN])


def _butterfly(ax: MedialAxis, fraction: float) -> Partition | None:
    """The "butterfly" (O-grid) partition of a smooth star-shaped domain of one ring:
    a central quad along the principal directions and four sectors joining it to
    the boundary (module docstring), the band between them ``1 - fraction`` of the
    least distance from the centroid to the boundary along those directions thick.
    None when the domain has a corner (a turn above :data:`SMOOTH_TURN`) or is not
    star-shaped from its centroid."""
    ring = _one_ring(ax)
    if ring is None or (np.abs(turns(ax)[ring]) > BUTTERFLY_TURN).any():
        return None
    xy = ax.samples[ring]
    c = _area_centroid(xy)[1]
    d = xy - c
    if ((d[:, 0] * np.roll(d[:, 1], -1) - np.roll(d[:, 0], -1) * d[:, 1]) <= 0).any():
        return None  # not star-shaped from c
    lam, vec = np.linalg.eigh(d.T @ d)
    if lam[1] - lam[0] <= 1e-9 * lam[1]:  # no principal direction (a regular polygon)
        vec = np.eye(2)[:, ::-1]
    e1 = vec[:, 1]
    if e1[np.argmax(np.abs(e1))] < 0:  # its largest component positive (eigh's sign is free)
        e1 = -e1
    e2 = np.array([-e1[1], e1[0]])
    ang = np.arctan2(d[:, 1], d[:, 0])

    def reach(u):  # distance from c to the boundary along u (nearest sample by angle)
        k = _first_least(np.abs(np.angle(np.exp(1j * (ang - math.atan2(u[1], u[0]))))), 1e-9)
        return float(np.hypot(*d[k]))

    a = min(reach(e1), reach(-e1))
    b = min(reach(e2), reach(-e2))
    t = (1 - fraction) * min(a, b)
    a, b = a - t, b - t
    inner = c + np.array([-a * e1 - b * e2, a * e1 - b * e2, a * e1 + b * e2, -a * e1 + b * e2])
    # each corner is cut to its nearest sample: cuts about normal to the boundary
    tie = 1e-9 * float(np.hypot(*np.ptp(d, axis=0)))
    foot = [_first_least(np.hypot(*(xy - q).T), tie) for q in inner]
    if len(set(foot)) < 4 or not all(
        (foot[(i + 1) % 4] - foot[i]) % len(ring) < (foot[(i + 2) % 4] - foot[i]) % len(ring)
        for i in range(4)
    ):
        return None
    p = len(ax.samples)
    points = np.concatenate([ax.samples, inner])
    cycles = [p + np.arange(4)]
    corners = [np.ones(4, bool)]
    for i in range(4):
        j = (i + 1) % 4
        run = np.roll(ring, -foot[i])[: (foot[j] - foot[i]) % len(ring) + 1]
        cyc = np.concatenate([[p + i], run, [p + j]])
        flag = np.zeros(len(cyc), bool)
        flag[[0, 1, -2, -1]] = True
        cycles.append(cyc)
        corners.append(flag)
    return _made(ax, points, cycles, corners)


def _first_least(v: np.ndarray, tol: float) -> int:
    """The first index whose value is within ``tol`` of the least: a regular polygon's
    samples tie (two at the same distance), and rounding chose between them."""
    return int(np.flatnonzero(v <= v.min() + tol)[0])


def _regions(points: np.ndarray, cycles, corners) -> list[dict]:
    """The GeoJSON region of each vertex cycle over ``points``, with its number
    of sides (corners flagged) and its area."""
    regions = []
    for cyc, flag in zip(cycles, corners, strict=True):
        ring = points[cyc]
        coords = np.concatenate([ring, ring[:1]]).tolist()
        regions.append(
            {
                "type": "Polygon",
                "coordinates": [coords],
                "sides": int(flag.sum()),
                "area": _ring_area(ring),
            }
        )
    return regions


def _reflex_merged(part: Partition) -> Partition:
    """The partition with regions merged at crowded reflex input corners
    (:func:`meshcore.medial.regions.reflex_merged`)."""
    pts = part.points
    cycles, corners, kinds, removed = reflex_merged(
        part.axis, pts, part.cycles, part.corners, part.edge_kind
    )
    if not removed:
        return part
    regions = _regions(pts, cycles, corners)
    gone = np.array([np.concatenate([pts[a], pts[b]]) for a, b in removed])
    c = part.cuts.reshape(-1, 4)
    drop = (
        (c[:, None] == gone[None]).all(-1) | (c[:, None] == gone[None][..., [2, 3, 0, 1]]).all(-1)
    ).any(1)
    stats = {**part.stats, "regions": len(regions), "merged_at_reflex": len(removed)}
    return Partition(
        regions=regions,
        cuts=part.cuts[~drop],
        axis=part.axis,
        points=pts,
        cycles=tuple(cycles),
        corners=tuple(corners),
        edge_kind=tuple(kinds),
        stats=stats,
    )


def _made(ax: MedialAxis, points, cycles, corners) -> Partition:
    """A Partition of given regions (vertex cycles over ``points``, the samples first)."""
    regions = _regions(points, cycles, corners)
    kinds = tuple(np.zeros(len(c), np.int8) for c in cycles)
    return Partition(
        regions=regions,
        cuts=np.zeros((0, 2, 2)),
        axis=ax,
        points=points,
        cycles=tuple(cycles),
        corners=tuple(corners),
        edge_kind=kinds,
        stats={"regions": len(regions), "area": sum(r["area"] for r in regions)},
    )


def _quads_on(part: Partition, size: float | None, levels: int | None, whole: bool | None = None):
    """Midpoint subdivision and transfinite fill of a partition's regions, then
    smoothing; the mesh and its counts (``invalid``: quads of area <= 0).
    ``whole``: every region has four sides and is one patch (no subdivision); None:
    so, with ``size``, when every region has four corners, the sharp input corners
    (:data:`SHARP_TURN`) counted (an annulus: its rings' regions one patch each, so
    that one quad across each ring is possible: the midpoint subdivision made at
    least two, 1.76x area / size**2 at size 0.15)."""
    ax = part.axis
    points = part.points
    p = len(ax.samples)
    succ = ax.succ
    pred = np.empty(p, dtype=np.int64)
    pred[succ] = np.arange(p)
    src = ax.segment_source
    is_corner = np.zeros(len(points), dtype=bool)
    is_corner[:p] = src[pred] != src  # input vertices between two input segments

    # segments: half-sides (in canonical direction) and spokes
    seg_xy: list[np.ndarray] = []
    seg_fixed: list[np.ndarray] = []
    half_id: dict[tuple[bytes, int], int] = {}
    patches = []  # (s0, s0 reversed?, s1, s2, s3 reversed?) and corner points

    def new_segment(xy, fixed) -> int:
        seg_xy.append(xy)
        seg_fixed.append(fixed)
        return len(seg_xy) - 1

    # a sharp convex input corner is a corner of the midpoint subdivision: one coarse
    # quad there (as a side point it got two of half its angle)
    sharp = np.zeros(len(points), dtype=bool)
    sharp[:p] = turns(ax) > SHARP_TURN
    with_sharp = not whole
    if whole is None:  # (with levels, the halving is the subdivision asked for)
        whole = size is not None and all(
            int((c | sharp[v]).sum()) == 4 for v, c in zip(part.cycles, part.corners, strict=True)
        )
    for verts, corner in zip(part.cycles, part.corners, strict=True):
        if with_sharp:
            corner = corner | sharp[verts]
        ci = np.flatnonzero(corner)
        verts = np.roll(verts, -ci[0])
        ci = ci - ci[0]
        k = len(ci)
        bounds = np.append(ci, len(verts))
        halves = []  # per side: (first-half id, reversed?), (second-half id, reversed?)
        mids = []
        if whole:  # a four-sided region is one patch (its sides are not halved)
            refs = []
            for j in range(k):
                side = np.append(
                    verts[bounds[j] : bounds[j + 1]], verts[bounds[j + 1] % len(verts)]
                )
                flipped = not (side[0] < side[-1] or (side[0] == side[-1] and side[1] < side[-2]))
                canon = side[::-1] if flipped else side
                key = canon.tobytes()
                if (key, 0) not in half_id:
                    fixed = is_corner[canon].copy()
                    fixed[[0, -1]] = True
                    half_id[(key, 0)] = new_segment(points[canon], fixed)
                refs.append((half_id[(key, 0)], flipped))
            b, r, t, lft = refs
            patches.append((b, r, (t[0], not t[1]), (lft[0], not lft[1])))
            continue
        ring = points[verts]
        nxt, prv = ring[(ci + 1) % len(verts)] - ring[ci], ring[ci - 1] - ring[ci]
        cos_sin = ((nxt * prv).sum(axis=1), nxt[:, 0] * prv[:, 1] - nxt[:, 1] * prv[:, 0])
        alpha = np.degrees(np.mod(np.arctan2(cos_sin[1], cos_sin[0]), 2 * np.pi))
        tip = (alpha < KITE_ANGLE) & (k == 3) & (verts[ci] < p)  # a spike cut off
        for j in range(k):
            side = np.append(verts[bounds[j] : bounds[j + 1]], verts[bounds[(j + 1)] % len(verts)])
            canon = (
                side
                if side[0] < side[-1] or (side[0] == side[-1] and side[1] < side[-2])
                else side[::-1]
            )
            flipped = canon is not side
            key = canon.tobytes()
            xy = points[canon]
            s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])
            if (key, 0) not in half_id:
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
        g = _inner_point(ring, points[verts[ci]], np.array(mids), tip)
        spokes = [new_segment(np.vstack([mids[j], g]), np.ones(2, bool)) for j in range(k)]
        for j in range(k):
            h = halves[j - 1][1]
            patches.append(
                (halves[j][0], (spokes[j], False), (spokes[j - 1], False), (h[0], not h[1]))
            )
    # conformity classes: opposite patch sides, shared sides
    n_seg = len(seg_xy)
    pairs = np.array(
        [[s0[0], s2[0]] for s0, s1, s2, s3 in patches]
        + [[s1[0], s3[0]] for s0, s1, s2, s3 in patches],
        dtype=np.int64,
    )
    label, n_classes = _classes(n_seg, pairs)
    if levels is not None:
        count = np.full(n_classes, 2 ** int(levels), dtype=np.int64)
    else:
        length = np.array([np.hypot(*np.diff(xy, axis=0).T).sum() for xy in seg_xy])
        # the mean length of a class: its sides' points come out about `size` apart on
        # average (the largest would multiply the count along chains of classes)
        mean = np.bincount(label, length, n_classes) / np.bincount(label, None, n_classes)
        # enough points for every input vertex of a side (a polygon covered exactly)
        need = np.array([int(f[1:-1].sum()) + 1 for f in seg_fixed], dtype=np.int64)
        for stretch in STRETCH:  # the first whose count is within MOST_COUNT, else the last
            with np.errstate(over="ignore"):  # tiny sizes: inf, clipped (no int overflow)
                count = np.clip(np.round(mean / (stretch * size)), 1, MAX_QUADS + 1)
            count = count.astype(np.int64)
            np.maximum.at(count, label, need)
            n_of = count[label]
            total = sum(int(n_of[s0[0]] * n_of[s1[0]]) for s0, s1, _, _ in patches)
            if total * size * size <= MOST_COUNT * ax.domain.area:
                break
    n_of = count[label]
    total = sum(int(n_of[s0[0]] * n_of[s1[0]]) for s0, s1, _, _ in patches)
    if total > MAX_QUADS:
        raise InputError(
            f"this would make {total:,} quads; at most {MAX_QUADS:,}: ask for a larger size "
            "or fewer levels",
            loc=("size" if size is not None else "levels",),
            code="too_many_quads",
        )
    seg_pts = [
        _polyline_points(xy, int(n_of[i]), fx)
        for i, (xy, fx) in enumerate(zip(seg_xy, seg_fixed, strict=True))
    ]

    def along(ref):
        sid, rev = ref
        return seg_pts[sid][::-1] if rev else seg_pts[sid]

    grids = []
    corner_ids = []
    for s0, s1, s2, s3 in patches:
        grids.append(_coons(along(s0), along(s1), along(s2), along(s3)))
    allpts = np.concatenate([g.reshape(-1, 2) for g in grids])
    # coincident points (the shared sides' copies) are one, numbered in order of first
    # occurrence: a lexicographic numbering followed the coordinates' rounding (a
    # translated input renumbered, and the smoothing's sweeps then moved differently)
    uniq, first, inverse = np.unique(allpts, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first)
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    uniq, inverse = uniq[order], rank[inverse.ravel()]
    quads = []
    offset = 0
    for g in grids:
        n1, n2 = g.shape[0] - 1, g.shape[1] - 1
        ids = inverse[offset : offset + g.shape[0] * g.shape[1]].reshape(g.shape[0], g.shape[1])
        offset += g.shape[0] * g.shape[1]
        corner_ids += [ids[0, 0], ids[-1, 0], ids[0, -1], ids[-1, -1]]
        quads.append(
            np.stack([ids[:-1, :-1], ids[1:, :-1], ids[1:, 1:], ids[:-1, 1:]], axis=-1).reshape(
                n1 * n2, 4
            )
        )
    quads = np.concatenate(quads)
    uniq, quads, opened = _opened(uniq, quads)
    before = _corner_areas(uniq, quads).min(axis=1)
    boundary = topology.boundary(Mesh(uniq, (CellBlock("quad", quads),))).cells[0].data
    fixed = np.zeros(len(uniq), dtype=bool)
    fixed[boundary.ravel()] = True
    uniq = _smoothed(uniq, quads, fixed, SMOOTHING_SWEEPS)
    corner = np.zeros(len(uniq), dtype=bool)
    corner[np.asarray(corner_ids, np.int64)] = True
    uniq, relaxed = _relaxed(uniq, quads, corner & fixed, ax)
    mesh = Mesh(uniq, (CellBlock("quad", quads),))
    area = quality.signed_area(uniq, quads, "quad")
    stats = {
        "quads": int(len(quads)),
        "points": int(len(uniq)),
        "coarse_quads": len(patches),
        "regions": len(part.regions),
        "side_classes": int(n_classes),
        "area": float(area.sum()),
        "not_convex_before_smoothing": int((before <= 0).sum()),
        "relaxed": relaxed,
        "opened": opened,
        "invalid": int((area <= 0).sum()),
        "slits": sum(len(topology.unique_ints(c)) < len(c) for c in part.cycles),
        "not_convex": int((_folded(uniq, quads) > 0).sum()),
        "domain_area": ax.domain.area,
    }
    return mesh, stats
