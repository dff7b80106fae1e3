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
  A *crowded* junction (more than :data:`CROWDED` lines: cuts and branches
  to other junctions) keeps only the cuts at least :data:`CROWD_ANGLE` degrees
  from every such branch: a gear's centre is one node whose circle touches all the
  tooth gaps, and its 11 axis edges and 22 cuts made regions of 16 degrees at
  the node (an 11-tooth gear at size 0.1: least quality 0.18, corners from 16
  degrees, 1.32x area / size**2; without those cuts 0.36, from 33 degrees,
  1.08x; no other gear of 6-12 teeth nor any of the 32 issue stars at sizes
  0.1 and 0.15 changed).

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

Quads (§9.7.2, §8.5.3): the midpoint subdivision of every region, the counts of its
sides, the transfinite fill and its untangling are :func:`meshcore.medial.fill.quads_on`
(its module docstring); then the mesh is optimized as any all-quad mesh (:func:`_optimized`).

Spikes and crowded reflex corners (:mod:`meshcore.medial.regions`). An input
corner under 45 degrees inside a larger region is cut off by a chord between the
region corners around it (:func:`partition`), and its triangle's subdivision is a
small kite at the tip (side points :data:`meshcore.medial.fill.KITE_SIDE` x size from it, the inner
point just past them) and two strips along its sides; ``quad_medial`` keeps
``ceil(angle / 135) - 1`` of the cuts at a reflex input corner, and
``ceil(angle / 60) - 1`` at any other boundary point, merging the regions on both
sides of the others (the latter only where the count allows: else the partition is
meshed without them, :func:`quad_medial`). On 32 random stars of the issue's kind
(:func:`tests.meshcore.quads.stars.issue_star` 0-31: 5-60 vertices, radial jitter
10-80 %, every other one with a star-shaped hole) at size 0.1, away from the quads at
input corners under 45 degrees (forced: such a corner is held by one quad): corners
in [30, 150] degrees on 31, least quality 0.3 on 32 and 0.5 on 31 (30 before the mesh
kept was lifted further where short, :data:`LAST_LIFT_BELOW`; 27 before the lift
was :func:`meshcore.quads.vertex_moves.lift_corners` with quad_combine's sliding
relaxation; 24 before the other partitions were tried where the first one's least is
under :data:`GOOD_LEAST`;
19 before the least corners were lifted, :func:`meshcore.medial.fill.lift_least`; 26,
27 and 11 before the boundary points slid in the relaxations:
:func:`meshcore.medial.fill.boundary_slides`), least 0.31-0.61, quads under 0.5
there 11 (163 before the lift); the count 0.92-1.46x area / size**2 (1.74x before the
larger stretches, :data:`meshcore.medial.fill.STRETCH`); at size 0.15 least 0.5 on
25 (20, 14), count over 1.5x on 6 of the 32 (7 before the transitions,
the fills with ``fine`` of :func:`_medial_fill`; 8 before the small regions were merged,
:data:`MERGE_COUNT`; 13 before the axis was pruned more where the count passed,
:data:`PRUNE_MORE`; up to 2.86x). What binds the count there is, on the partition
meshed first, its regions: their coarse quads alone (one per side) are 1.54-2.45x area /
size**2 on those six (star 17: 95 regions, 2.45x), so that no count of the sides, with
or without transitions, brings it within; and on the partitions of fewer regions (the
axis pruned more, regions merged) the input vertices: every input vertex is a mesh
point (so that the area is exact), a boundary side of ``k`` of them needs ``k + 1``
divisions, and the coarse quads carry that count to their opposite sides, across the
regions of the partition (star 17, 70 vertices for area / size**2 = 140: 1.54x with
its regions merged if its input vertices did not bind, 2.84x as they do; the
transitions, which lift the bind only between a boundary side and its opposite side,
at most 3 to 1, leave it over). The meshes within the count (on five of the six) have
a least quality of 0.05-0.29 there: the one over it is kept (:data:`PRUNE_LEAST`).
Where the first mesh passes the count, every partition tried is also filled with its
four-sided regions of corners in [45, 135] degrees as one patch (``four`` of
:func:`meshcore.medial.fill.quads_on`: the midpoint subdivision made four coarse
quads of such a region, so four quads at least; one patch is cut across only where a
subdivided neighbour halves a side, carried on through a chain of them): on issue 20's
40 stars (:func:`tests.meshcore.quads.stars.issue_star` 0-39) at size 0.15 the count
passes 1.5x on 5 (7 before: star 12 1.66 -> 1.48x, least 0.527 kept; star 20 1.71 ->
1.47x, least 0.457 -> 0.424), least 0.5 on 33 (32: star 1 0.464 -> 0.576); on the 7
gears at 0.15 quads under 0.5 31 -> 23; 84 of the 94 star and gear meshes at 0.1 and
0.15 unchanged (the other 10 first passed the count; gear 12 at 0.1 now 1.46x for
1.27x, the first fill tried of least 0.5). Still over at 0.15: stars 17,
22, 25, 31, 33 (1.83-2.86x), bound by their input vertices as above (star 22's first
partition with four-patch fills: 1.68x from the input vertices' counts alone). Not
tried where the first mesh keeps the count but not the least: a spike of 0.5 degrees
(``test_quad_medial_same_cells_translated_or_scaled``) has least 0.10 at the origin
and 0.60 translated by 1e6 from the same cells (``_optimize``'s relaxation), and its
four-patch fill (0.61) was then kept at the origin only. Gears
of 6-12 teeth at size 0.1: least 0.5
on 7 of 7 (6 before :data:`LAST_LIFT_BELOW`, gear 9 at 0.487; 0 before the O-grid
at their hub, :func:`meshcore.medial.fill._flowered`,
and the merges at their tooth gaps, :data:`~meshcore.medial.regions.BOUNDARY_SHARE`;
4 before a border point of four quads gave one up, :func:`meshcore.medial.fill._closed`,
5 before it could bend a corner to :data:`~meshcore.medial.fill.CLOSE_BEND`),
0.502-0.62, count 1.21-1.49x; at 0.15 least 0.5 on 5 of 7, count 1.40-1.46x (over 1.5x
on 4, 1.68-2.47x, bound by their input vertices as above, before the transitions,
which fill only the partitions whose tied fill passes the count and that they bring
within, :func:`_medial_fill`: the 32 stars at 0.15 in 31.7 CPU s, 43.9 when every
partition was filled again, star 12 3.5 s, 6.0). What is left under 0.5: the strips of
spikes whose base chord is oblique and reflex corners (quads of 36-44 degrees next
to them), thin 4-sided regions between the close nodes of a crowded junction of the
``critical`` partition (parallelograms of 42-45 degrees: gear 9 at 0.15, star 18),
the few regions around its Type 0 nodes with a corner of 10-30 degrees at the node
(the text's midpoint subdivision of a triangle region), a spike's strips made coarse
by the count's stretch (star 31 at 0.15: least 0.27), and one star of 53 vertices
with 74 % jitter and no hole (star 22: least 0.43 at 0.1, corners 39-141 degrees, in
thin regions between its spikes; 0.31 and 28-150 before its 4-degree spike was cut
at its base, :func:`meshcore.medial.regions.spike_chords`). On issue 20's 40 stars
(``benchmarks/medial.py --quad-medial 0.1 0.15``): at 0.1 least 0.5 on 39, corners in
[30, 150] on 40, quads under 0.5 there 5 (38, 39, 15 before that cut and before a
reflex corner's fan was opened from the domain's angle, :func:`meshcore.medial.fill._opened`:
star 33 0.36 -> 0.55); at 0.15 least 0.5 on 35 (33), over 1.5x on 4 (5: star 33
1.83 -> 1.29x), quads under 0.5 24 (41). By class, the 0.15 misses: corners of 38-44
degrees at interior points of valence 4-7 where regions meet at an axis node with a
corner of 20-55 degrees (stars 17, 18, 22, gear 9: the lift stops there; on 17 and 18 three more
lifts changed nothing), large regions (25-42 area / size**2, the axis pruned at 45-90)
whose boundary side carries many input vertices (star 20, gear 10), a spike's strips
(star 31).
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

from meshcore.domain.planar import Domain, as_domain
from meshcore.errors import AlgorithmError, InputError
from meshcore.medial.axis import (
    DEFAULT_PRUNE,
    MedialAxis,
    _csr,
    _cycles,
    medial_axis,
    pruned_axes,
)
from meshcore.medial.fill import (
    MOST_COUNT,
    area_centroid,
    boundary_slides,
    folded,
    lift_least,
    quads_on,
)
from meshcore.medial.regions import (
    _AXIS,
    _BOUNDARY,
    _CUT,
    BOUNDARY_SHARE,
    KITE_ANGLE,
    _ring_area,
    input_fans,
    input_index,
    reflex_merged,
    small_merged,
    spike_chords,
    turns,
)
from meshcore.mesh import CellBlock, Mesh, quality
from meshcore.mesh.topology import inverse_permutation
from meshcore.quads.combination import TOL
from meshcore.quads.optimization import optimize_quads
from meshcore.quads.relaxation import relax_quads

__all__ = ["Partition", "QuadMedial", "partition", "quad_medial"]

Progress = Callable[[float, str], None]

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
#: The last relaxation (:func:`_optimized`) minimizes the summed (1 / sin angle) ** this
#: over the quads under quality 0.5 and their neighbours: the worst corners weigh most.
LEAST_POWER = 8.0
#: Where the count passes :data:`~meshcore.medial.fill.MOST_COUNT` x area / size**2 on
#: the axis pruned as asked, the axis is pruned at each larger of these angles (degrees)
#: in turn (and where the least quality is under :data:`GOOD_LEAST`), and the first mesh
#: within the count of least quality :data:`GOOD_LEAST` away from input spikes is kept,
#: else the one of the highest least quality there when that is at least
#: :data:`PRUNE_LEAST` or the first mesh's: fewer branches
#: make fewer regions, whose coarse quads bound the count from below (a 12-tooth gear at
#: size 0.1: 100 regions, 2.46x area / size**2 on the butterfly; 1.30x pruned at 45).
PRUNE_MORE = (45.0, 60.0, 90.0)
#: The least quality (away from input spikes) a more pruned mesh must keep (or the
#: first one's, when lower).
PRUNE_LEAST = 0.35
#: Where the first mesh keeps the count but its least quality (away from input spikes)
#: is under this, the other partitions of :func:`quad_medial` are meshed too and the
#: one within the count of the highest least quality is kept (the issue's bound, 8.4).
GOOD_LEAST = 0.5

#: A junction of the ``critical`` partition with more than this many lines (cuts, and
#: branches to other junctions) is crowded: its cuts within :data:`CROWD_ANGLE` degrees
#: of such a branch are left out (:func:`_spread`). A gear's centre is one node whose
#: circle touches every tooth gap: 11 axis edges and 22 cuts there made regions of 16
#: degrees at the node. (A junction whose branches all end at leaves keeps its cuts: a
#: random star's only junction lost them all, and the domain was one region.)
CROWDED = 6
#: See :data:`CROWDED` (degrees).
CROWD_ANGLE = 20.0

#: The final corner relaxation (:func:`_optimized`) may lower the least quality by this
#: for a higher mean: on the benchmark's spiky star at size 0.1, with a reflex corner
#: opened, it took the mean from 0.778 to 0.836 and the least from 0.486 to 0.481, and
#: was refused (mean 0.84 without the opening).
LEAST_GIVE = 0.01
#: Last, the corners of the quads under this quality (8.4) and of two rings of quads
#: around them are lifted (:func:`meshcore.medial.fill.lift_least`).
LIFT_BELOW = 0.6
#: The mesh kept whose least quality (8.4) away from input spikes is still under
#: :data:`GOOD_LEAST` is lifted once more, around the quads under this: on the
#: benchmark's stars and gears (``benchmarks/medial.py --quad-medial 0.1 0.15``) it took
#: gear 9 at size 0.1 from 0.487 to 0.502, star 26 from 0.494 to 0.500 and star 22 from
#: 0.247 to 0.314 (gears at 0.1 least 0.5 on 7 of 7, stars on 31 of 32), and raised the
#: least of 6 of the 9 short ones at 0.15 a little (0.003-0.009); quads under 0.5 there
#: 19 -> 11 at 0.1, 56 -> 56 at 0.15 (a judged quad may fall to the least). It costs
#: 0.3-0.5 CPU s where it runs; lifting every mesh so took the benchmark's CPU to 1.5x.
LAST_LIFT_BELOW = 0.75
#: Where every other partition passes :data:`~meshcore.medial.fill.MOST_COUNT` x area /
#: size**2, small regions are merged until their sides (one coarse quad each) are at
#: most this x area / size**2 (:func:`meshcore.medial.regions.small_merged`).
MERGE_COUNT = 1.0


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
    before = pairs[:, 0] * np.int64(len(ax.samples)) + inverse_permutation(ax.succ)[pairs[:, 1]]
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


def _spread(ax: MedialAxis, v: int, touch: np.ndarray, ahead: list) -> np.ndarray:
    """The contacts of a junction ``v`` whose cuts make at least :data:`CROWD_ANGLE` with
    every branch there that leads to another junction (``ahead``: their second nodes; a
    terminal branch is not a cut line of the ``critical`` partition), when it is
    crowded: more than :data:`CROWDED` such branches and cuts. All of them otherwise."""
    if len(ahead) < 3 or len(ahead) + len(touch) <= CROWDED:
        return touch
    a = np.arctan2(*(ax.nodes[ahead] - ax.nodes[v]).T[::-1])
    b = np.arctan2(*(ax.samples[touch] - ax.nodes[v]).T[::-1])
    gap = np.abs(np.angle(np.exp(1j * (b[:, None] - a[None]))))
    return touch[gap.min(axis=1) >= math.radians(CROWD_ANGLE)]


def _cut_lines(ax: MedialAxis, method: str):
    """Axis edges kept and cuts (node, sample) of the partition."""
    n = len(ax.nodes)
    deg = np.bincount(ax.edges.ravel(), minlength=n)
    start, contact = _contacts(ax)
    core = _branch_graph_core(ax)
    first, incident = _csr(n, ax.edges)  # the axis edges of each node
    cuts: list[tuple[int, int]] = []
    keep_edge = np.ones(len(ax.edges), dtype=bool)
    ahead: dict[int, list[int]] = {}  # per junction, the second node of each branch ...
    for c in ax.branches:  # ... from it to a junction (both ways on a loop)
        for k, e in ((1, 0), (-2, -1)):
            if deg[c[-1 - e]] >= 3:
                ahead.setdefault(int(c[e]), []).append(int(c[k]))
    for v in np.flatnonzero((deg >= 3) | (deg == 0)):
        if method == "critical" or deg[v] == 0:
            touch = contact[start[v] : start[v + 1]]
            if deg[v] >= 3:
                touch = _spread(ax, v, touch, ahead.get(int(v), []))
            cuts += [(int(v), int(s)) for s in touch]
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
    domain : Domain or GeoJSON mapping
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
        ``stats["prune"]``: the larger pruning angle whose axis was meshed, where the
        count passed 1.5x area / size**2 on the one asked (:data:`PRUNE_MORE`) or its
        least quality was under :data:`GOOD_LEAST`; ``partition.stats["merged_small"]``:
        the small regions merged (:data:`MERGE_COUNT`);
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
        :data:`meshcore.medial.fill.MAX_QUADS` quads.
    AlgorithmError
        As :func:`partition`, or inverted quads left on the critical
        partition (none on the domains tested).

    References
    ----------
    Methods text §9.7.2, Figure 9.14; §8.5.3; Chapter 4 (algebraic methods).
    """
    domain = as_domain(domain)
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
    more = [x for x in PRUNE_MORE if x > prune] if size is not None else []
    # the axis built once (samples, Delaunay, Voronoi graph), pruned at each angle in turn
    axes = pruned_axes(domain, h=h, prunes=(prune, *more), progress=progress)
    first = next(axes)
    special = _special(first, size, levels)  # the same samples on every pruned axis
    done: dict = {}  # partitions, fills and optimized meshes: each computed once
    res = _meshed(first, domain, method, size, levels, BOUNDARY_SHARE, special, done)
    res = _lifted(res, domain, LIFT_BELOW, done)
    if size is not None:
        # the axes pruned at each angle (``axis_at``), as they are needed
        ctx = _Tries(axes, {prune: first}, prune, more, domain, method, size, levels, special, done)
        res, least = _other_tried(res, ctx)
        if _over(res, domain, size):  # the same tries, the fills with transitions
            alt = ctx.meshed(first, BOUNDARY_SHARE, merge=False, fine=True)
            alt = _lifted(alt, domain, LIFT_BELOW, done)
            alt, alt_least = _other_tried(alt, ctx, fine=True)
            if not _over(alt, domain, size) and alt_least >= min(PRUNE_LEAST, least):
                res, least = alt, alt_least
    else:
        least = _least_away(res.mesh, domain)
    if least < GOOD_LEAST:  # the mesh kept, lifted further
        res = _lifted(res, domain, LAST_LIFT_BELOW, done)
    stats = {**res.stats, "quality": quality.report(res.mesh)}
    return QuadMedial(mesh=res.mesh, partition=res.partition, stats=stats)


@dataclass(frozen=True, eq=False)
class _Tries:
    """What :func:`_other_tried` meshes with, the same at both its calls: the
    iterator of pruned axes, ``axis_at`` (pruning angle -> axis, filled as needed),
    the angle asked and the ``more`` ones, and :func:`_meshed`'s arguments."""

    axes: object
    axis_at: dict
    prune: float
    more: list
    domain: Domain
    method: str
    size: float
    levels: int | None
    special: tuple
    done: dict

    def meshed(self, axis: MedialAxis, share, merge: bool, fine: bool, four=False) -> QuadMedial:
        """:func:`_meshed` on ``axis`` with these arguments."""
        d = self
        return _meshed(
            axis, d.domain, d.method, d.size, d.levels, share, d.special, d.done, merge, fine, four
        )


def _other_tried(res: QuadMedial, ctx: _Tries, fine=False):
    """``res`` (the first mesh of :func:`quad_medial`, lifted), or where it passes the
    count or its least quality away from input spikes is under :data:`GOOD_LEAST`, the
    first other mesh within the count of least quality :data:`GOOD_LEAST`, else the one
    within it of the highest least quality; over the count, that one only when its least
    is at least :data:`PRUNE_LEAST` (or the first mesh's). The others, where the first
    mesh passes the count: each partition's fill with its four-sided regions as one
    patch too (``four`` of :func:`meshcore.medial.fill.quads_on`; the first mesh's
    partition's first) after its fill by midpoint subdivision. ``prune``: the pruning angle
    asked (``res``'s); ``axis_at``: pruning angle -> axis, ``prune``'s given (others kept
    as made); ``axes``: the iterator of :func:`~meshcore.medial.axis.pruned_axes` giving
    the axes pruned at each of ``more`` in turn. Returns the mesh kept and its least
    quality away from input spikes (:func:`_least_away`); the others as in ``ctx``."""
    domain, size, prune, more, axis_at = ctx.domain, ctx.size, ctx.prune, ctx.more, ctx.axis_at
    over, kept = _over(res, domain, size), _least_away(res.mesh, domain)
    if not over and kept >= GOOD_LEAST:
        return res, kept
    least = min(PRUNE_LEAST, kept) - 1e-12 if over else kept  # the bar an other must pass
    # the more pruned axes with the regions merged at crowded boundary points, then
    # every axis without those merges (a region merged at a gear's tooth gap has a
    # longer boundary side, whose input vertices bind its count: BOUNDARY_SHARE), then
    # every axis with its small regions merged too (MERGE_COUNT)
    tries = [(BOUNDARY_SHARE, a, False) for a in more] + [(None, a, False) for a in (prune, *more)]
    tries += [(BOUNDARY_SHARE, a, True) for a in (prune, *more)]
    # where the first mesh passes the count, each with its four-sided regions as one patch
    # next (``quads_on``'s ``four``), the first mesh's partition so first (where it keeps
    # the count but not the least, not: the spike of 0.5 degrees of
    # ``test_quad_medial_same_cells_translated_or_scaled`` has least 0.10 at the origin
    # and 0.60 translated by 1e6 from the same cells, in ``_optimize``'s relaxation, and
    # its four-patch fill, 0.61, was kept at the origin only)
    kinds = (False, True) if over else (False,)
    first = [(BOUNDARY_SHARE, prune, False, True)] if over else []  # (its subdivided: res)
    tries = first + [(*t, four) for t in tries for four in kinds]
    tried = [res.mesh.cells_by_type["quad"]]
    for share, angle, merge, four in tries:  # a loop over at most 23 fills
        if angle not in axis_at:
            axis_at[angle] = next(ctx.axes)
        try:
            alt = ctx.meshed(axis_at[angle], share, merge, fine, four)
        except AlgorithmError:
            continue
        # a mesh tried before (a merge that changed nothing; the butterfly again; a
        # four-patch fill that is the subdivided one) or over the count is passed (the
        # lift moves points only: lifted when kept)
        quads = alt.mesh.cells_by_type["quad"]
        if any(quads is q for q in tried) or _over(alt, domain, size):
            continue
        tried.append(quads)
        alt = _lifted(alt, domain, LIFT_BELOW, ctx.done)
        got = _least_away(alt.mesh, domain)
        if got > least:
            extra = {"prune": angle} if angle != prune else {}
            res = QuadMedial(
                mesh=alt.mesh,
                partition=alt.partition,
                stats={**alt.stats, **extra, "boundary_merged": share is not None},
            )
            kept = least = got
            if got >= GOOD_LEAST:
                return res, kept
    return res, kept


def _over(res: QuadMedial, domain: Domain, size: float) -> bool:
    """Whether a mesh passes :data:`~meshcore.medial.fill.MOST_COUNT` x area / size**2."""
    return len(res.mesh.cells_by_type["quad"]) * size * size > MOST_COUNT * domain.area


def _least_away(mesh: Mesh, domain: Domain) -> float:
    """The least quality (8.4) of the quads with no corner at an input corner under
    :data:`~meshcore.medial.regions.KITE_ANGLE` (one quad holds such a corner)."""
    P, Q = mesh.points, mesh.cells_by_type["quad"]
    at = input_index(P, domain.points)
    angle = np.full(len(domain.points) + 1, 180.0)
    angle[: domain.boundary_point_count] = domain.corner_angles()
    ok = ~(angle[at] < KITE_ANGLE)[Q].any(axis=1)
    return float(quality.quad_quality(P, Q)[ok].min(initial=1.0))


def _meshed(
    axis: MedialAxis,
    domain,
    method,
    size,
    levels,
    share,
    special,
    done,
    merge=False,
    fine=False,
    four=False,
) -> QuadMedial:
    """:func:`quad_medial` on the axis (of ``domain``; arguments checked), the medial
    partition's regions merged at crowded boundary points as ``share`` says
    (:func:`_medial_fill`); ``special``: :func:`_special` of the domain's samples. Its
    least corners not yet lifted (:func:`_lifted`: only on the mesh kept). ``done``:
    the fills and optimized meshes so far, reused (the same quads object again)."""
    special, mesh, stats = special
    part = None
    if special is not None and not stats["invalid"]:
        if size is not None and stats["quads"] * size * size > MOST_COUNT * domain.area:
            # the butterfly's central quad carries the boundary's count both ways (a gear
            # at size 0.1: 1.88x): the medial partition when it keeps the count
            try:  # (a 2:1 ellipse's medial partition has a 2-sided region: the butterfly)
                part, mesh2, stats2 = _medial_fill(
                    axis, method, size, levels, share, done, merge, fine, four
                )
            except AlgorithmError:
                part, stats2 = None, {"invalid": 1}
            bad = stats2["invalid"] or stats2["slits"]
            if bad or stats2["quads"] * size * size > MOST_COUNT * domain.area:
                part = None
        if part is None:
            kind = "four-sided" if len(special.regions) == 1 else "butterfly"
            mesh, stats = _optimized(mesh, domain, stats, done)
            return QuadMedial(mesh=mesh, partition=special, stats={**stats, "partition": kind})
        mesh, stats = mesh2, stats2
    else:
        part, mesh, stats = _medial_fill(axis, method, size, levels, share, done, merge, fine, four)
    if (stats["invalid"] or stats["slits"]) and method == "terminal":
        # regions of 5 or 6 sides around reflex corners can fold; the critical
        # partition's triangles and quads do not on the domains tested. A region
        # around a dead-end cut (a slit: its cycle passes a vertex twice) gave a
        # non-conforming fill, a sliver hole along the slit (a random star at size 0.5)
        fallback, mesh, stats2 = _medial_fill(
            part.axis, "critical", size, levels, share, done, merge, fine, four
        )
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
    mesh, stats = _optimized(mesh, domain, stats, done)
    return QuadMedial(mesh=mesh, partition=part, stats=stats)


def _lifted(res: QuadMedial, domain: Domain, below: float, done: dict) -> QuadMedial:
    """The mesh of :func:`_meshed` with its least corners lifted last around the quads
    under ``below`` (:func:`meshcore.medial.fill.lift_least`, input vertices fixed) when
    :func:`_optimized` ran on it; ``stats["least_lifted"]`` counts the moves. The lift
    from ``done`` when made before for the same mesh object (a fill tried again)."""
    if "least_relaxed" not in res.stats:
        return res
    P, Q = res.mesh.points, res.mesh.cells_by_type["quad"]
    key = ("lifted", id(res.mesh), below)
    if key not in done:  # (the mesh held: its id is not reused)
        fixed = input_index(P, domain.points) >= 0
        done[key] = (res.mesh, *lift_least(P, Q, fixed, domain.points, below))
    _, P, lifted = done[key]
    mesh = Mesh(P, (CellBlock("quad", Q),))
    stats = {**res.stats, "least_lifted": res.stats.get("least_lifted", 0) + lifted}
    return QuadMedial(mesh=mesh, partition=res.partition, stats=stats)


def _optimized(mesh: Mesh, domain: Domain, stats: dict, done: dict) -> tuple[Mesh, dict]:
    """:func:`_optimize` of the mesh, or its result from ``done`` for the same mesh and
    stats objects (the butterfly, a partition tried again)."""
    key = ("optimized", id(mesh), id(stats))
    if key not in done:  # (the mesh and stats held: their ids are not reused)
        done[key] = (mesh, stats, _optimize(mesh, domain, stats))
    return done[key][2]


def _optimize(mesh: Mesh, domain: Domain, stats: dict) -> tuple[Mesh, dict]:
    """The fill improved as an all-quad mesh (§8.4.3): the quad operators and smoothing
    of :func:`meshcore.quads.optimization.optimize_quads` (boundary points fixed), then
    the corner angles relaxed (:func:`~meshcore.quads.relaxation.relax_quads` with
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
        P,
        Q,
        fixed,
        slide=boundary_slides(P, Q, fixed, domain.points),
        active=active,
        angle_power=TOL.relax_power,
    )
    q2 = quality.quad_quality(new, Q)
    kept = (
        not (folded(new, Q) > 0).any()
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
            P,
            Q,
            fixed,
            slide=boundary_slides(P, Q, fixed, domain.points),
            active=active,
            angle_power=LEAST_POWER,
        )
        kept = (
            not (folded(new, Q) > 0).any()
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
        return four, *quads_on(four, size, levels, whole=True)
    best = None
    for f in INNER_FRACTIONS:  # a loop over at most two partitions
        part = _butterfly(ax, f)
        if part is None:
            return None, None, None
        mesh, stats = quads_on(part, size, levels, whole=True)
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
    c = area_centroid(xy)[1]
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


def _medial_fill(
    axis: MedialAxis,
    method: str,
    size,
    levels,
    share,
    done: dict,
    merge=False,
    fine=False,
    four=False,
):
    """The medial partition (:func:`partition`, regions merged at crowded boundary points:
    :func:`_reflex_merged` with ``share``; with ``merge``, small regions merged until
    their sides are within the count: :func:`_small_merged`) and its fill
    (:func:`meshcore.medial.fill.quads_on`; with ``fine``, tried where every partition
    passes :data:`~meshcore.medial.fill.MOST_COUNT` x area / size**2 with the sides tied:
    its fill with transitions where this one passes and they bring it within, else the
    same tied fill; with ``four``, its four-sided regions as one patch, the same fill
    objects where none is): the partition, the mesh and its stats; the partitions and
    the fills from ``done`` when made before for this axis."""
    base = (id(axis), method)  # (the axis held: its id is not reused)
    if base not in done:
        done[base] = partition(axis=axis, method=method)
    shared = (*base, share)
    if shared not in done:
        done[shared] = _reflex_merged(done[base], share)
    part = done[shared]
    small = (*shared, "small")
    if merge and small not in done:
        done[small] = _small_merged(part, size)
    part = done[small] if merge else part
    key = (id(axis), part.points.tobytes(), *(c.tobytes() for c in part.cycles + part.corners))
    if key not in done:  # (the axis held: its id is not reused)
        done[key] = (part, *quads_on(part, size, levels))
    tied = done[key]
    if four:  # the same fill where no region is one patch (the same objects)
        key = (*key, "four")
        if key not in done:
            fill = quads_on(part, size, levels, four=True)
            done[key] = tied if fill is None else (part, *fill)
        tied = done[key]
    if not fine or tied[2]["quads"] * size * size <= MOST_COUNT * axis.domain.area:
        return tied
    if (*key, "fine") not in done:  # None: the transitions do not bring it within
        done[(*key, "fine")] = quads_on(part, size, levels, transitions=True, four=four)
    fill = done[(*key, "fine")]
    return tied if fill is None else (part, *fill)


def _reflex_merged(part: Partition, share: float | None) -> Partition:
    """The partition with regions merged at crowded reflex input corners and, with
    ``share``, at other crowded boundary points
    (:func:`meshcore.medial.regions.reflex_merged`)."""
    cycles, corners, kinds, removed = reflex_merged(
        part.axis, part.points, part.cycles, part.corners, part.edge_kind, share
    )
    if not removed:
        return part
    return _remade(part, cycles, corners, kinds, {"merged_at_reflex": len(removed)})


def _small_merged(part: Partition, size: float) -> Partition:
    """The partition with small regions merged in pairs until their sides are within
    :data:`MERGE_COUNT` x area / size**2
    (:func:`meshcore.medial.regions.small_merged`)."""
    cycles, corners, kinds, merges = small_merged(
        part.points,
        len(part.axis.samples),
        part.cycles,
        part.corners,
        part.edge_kind,
        size,
        part.axis.domain.area,
        MERGE_COUNT,
    )
    if not merges:
        return part
    return _remade(part, cycles, corners, kinds, {"merged_small": merges})


def _remade(part: Partition, cycles, corners, kinds, extra: dict) -> Partition:
    """``part`` with other regions (vertex cycles over its points, corner flags, edge
    kinds): its cuts those of the cycles' cut edges, ``extra`` added to its stats."""
    pts = part.points
    cut = np.concatenate(
        [
            np.column_stack([c, np.roll(c, -1)])[k == _CUT]
            for c, k in zip(cycles, kinds, strict=True)
        ]
    )
    cut = np.unique(np.sort(cut, axis=1), axis=0)
    regions = _regions(pts, cycles, corners)
    return Partition(
        regions=regions,
        cuts=np.stack([pts[cut[:, 0]], pts[cut[:, 1]]], axis=1),
        axis=part.axis,
        points=pts,
        cycles=tuple(cycles),
        corners=tuple(corners),
        edge_kind=tuple(kinds),
        stats={**part.stats, "regions": len(regions), **extra},
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
