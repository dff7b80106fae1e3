r"""Quad meshes by triangle combination (§8.4): ``combine``.

Input: a conforming triangle mesh, planar or a surface in 3D (§8.4.5), or a
planar domain that is triangulated here first. Output: quads (plus the
triangles that could not be combined, unless ``all_quad``), optionally
improved by the operators of §8.4.3 (:mod:`meshcore.quads.optimization`).

Pipeline
--------
1. **Dual graph.** Every interior edge ``uv`` between the triangles
   ``(u, v, w1)`` and ``(v, u, w2)`` is a candidate quad ``(u, w2, v, w1)``
   (counter-clockwise; nodes 0 and 2 are the ends of the edge that the
   combination removes). A candidate is *allowed* when it is strictly
   convex (planar: the exact :func:`~meshcore.geometry.predicates.orient2d`
   at ``u`` and ``v``; on a surface: the corner turns of
   :mod:`meshcore.mesh.quality` along the quad's vector area), when neither of
   its corners at ``u`` and ``v`` is within ``flat_corner`` degrees of 0 or
   180 (measured in the metric: the first drawback of §8.4.4, "a triangle
   with an edge aligned with one of its neighbour", gives a quad with a flat
   corner; with ``all_quad`` on domain input, within ``all_quad_flat_corner`` = 45 degrees:
   the split keeps every coarse corner as a final corner, and a coarse quad
   spanning a boundary vertex of a curved boundary left 174-degree quads on
   a 64-gon disk; measured on the disk, ellipse and annulus against 5 and 30
   degrees, 45 gave corners in [45, 135] and the best mean there, see
   README; a given mesh keeps the 5-degree bound: the gap meshes of
   :mod:`meshcore.grid` hold constraint chains as interior edges, which the
   wider bound let pairs remove), and when its quality reaches ``min_quality``. Its weight is its
   quality: ``angle`` (8.3)/(8.4) or (8.6) with a metric, ``simplified``
   (8.7), or ``shape`` (8.8), all from :mod:`meshcore.mesh.quality`.
2. **Selection** of the pairs, one compiled sequential kernel (numba) per
   algorithm (``stack`` and ``frontal``: :mod:`meshcore.quads.paths`):

   * ``stack`` (§8.4.2): a depth-first path from a triangle with two
     boundary edges; from triangle ``K`` entered through edge ``e1`` the
     next edges in the direct sense are tried, and a neighbour joins the
     stack as ``K``'s child when it is not coloured yet and the pair is
     allowed. When a triangle leaves the stack with one active child they
     are combined; with none it stays for its father; with two it is
     combined with its two children and its father into three quads around
     its centroid (Figure 8.12, right) when those three quads are allowed,
     else with its better child. Each connected part gets its own path
     (Remark 8.5). On a tree this post-order rule is the optimal greedy
     matching (leaves first).
   * ``heap`` (§8.4.4): the allowed edges, best quality first; a pair is
     formed when both triangles are still free (a sorted pass: the
     qualities never change, so the heap of the text reduces to an order).
   * ``frontal`` (Remark 8.8): triangles in breadth-first order from the
     boundary inward (from triangle 0 on a closed surface); a free
     triangle is combined with its best allowed free neighbour, and the
     front moves on past both. No global sort.
   * ``matching`` (beyond the text): a greedy start, the heap's order
     with the "update as pairs are used" of the text kept as a second heap
     (a triangle down to its last allowed free neighbour pairs with it
     ahead of the quality order, the cheapest defence against the isolated
     triangles of §8.4.4), then augmenting paths of Edmonds' blossom
     algorithm, which pair leftovers two by two by flipping the pairs along
     an alternating path in the dual graph: first one bounded search
     (``search_cap`` triangles) from each leftover through pairs of quality
     at least ``good_quality``, cheapest in lost quality first; then one
     forest search from all the leftovers at once through every allowed
     pair, breadth-first, dissolving only the two trees of each path found
     (:func:`_forest_kernel`). When the forest stops no augmenting path is
     left, so the number of leftovers is the least possible in the allowed
     dual graph. Then alternating 4-cycles that raise the summed quality
     are swapped in. It is a maximum-*cardinality* matching with a
     quality-greedy start, not an exact maximum-weight matching (Edmonds'
     weighted algorithm costs far more at a million triangles); the
     cardinality is what decides the triangles left, quality comes second.

3. **Domain input.** The domain is triangulated by
   :func:`meshcore.triangulation.refinement.triangulate` in a sheared frame ``x' = A x``
   with ``A = [[1, 1/2], [0, sqrt(3)/2]]``, and the mesh mapped back. The
   triangulator's equilateral lattice of side ``h`` then becomes a square
   grid of side ``h`` cut along one diagonal, whose pairs are squares of
   quality 1 ("lay the triangles so that pairs make near-squares"); only
   the layer along the boundary is irregular. ``pattern="equilateral"``
   skips the shear (pairs are then 60/120 degree rhombi, quality 2/3).
   With ``all_quad`` the domain is meshed at twice the size when
   ``twice_size`` (§8.4.2, last paragraph), so that the final quads have
   the requested size. The parity of the triangle count of a part is the
   parity of its boundary edge count, and an odd part cannot be paired
   completely (Remark 8.3): for domain input, one boundary edge of each odd
   part (the longest) is split at its midpoint, which makes the count even
   and keeps every input segment a chain of edges
   (:mod:`meshcore.quads.lattice`). With ``all_quad`` and ``twice_size``,
   rows of quads along the boundary come first (one row, with a quad at each
   convex corner and a fan at each reflex one, where the boundary has corners
   and a segment off the axes) and the lattice fills the inside of their
   offset rings (:mod:`meshcore.quads.boundary_layer`: where and why).
4. **all_quad** (Figure 8.13): on domain input with ``matching``, the
   pairing is first re-worked for fewer irregular vertices after the split
   (:mod:`meshcore.quads.valence`: leftover triangles moved along
   alternating paths or paired with an adjacent leftover under the 5-degree
   bound where the corner will be free to move). Then every edge gets its midpoint, every cell its
   vertex centroid; a quad becomes four quads and a leftover triangle three,
   so the mesh stays conforming. The four pieces of a quad are the quad cut
   by its two bimedians (which meet at the vertex centroid), so areas add
   up exactly up to rounding and convex quads give convex pieces.
5. **optimize** (§8.4.3): see :mod:`meshcore.quads.optimization`.

Choices the text leaves open
----------------------------
* Inverted (planar), degenerate, non-triangle, non-manifold or
  inconsistently oriented input is refused with an
  :class:`~meshcore.errors.InputError` naming the cells; overlaps between
  non-adjacent triangles are not searched for.
* Qualities are compared after rounding to ``quality_resolution``, so that
  ties (a structured mesh has many) break by index and not by the last
  bits of a rounding: the same mesh in an equivalent frame (stretched, with
  the metric that undoes the stretch) gives the same pairs.
* A metric per vertex (8.6) takes each candidate's least value over the
  metrics of its four corners (16 corner values, Remark 8.6); ``simplified``
  uses those at the ends of the removed edge (8.7); ``shape`` (8.8) is
  isotropic in the text and takes a constant metric only. Points added by
  the three-quad pattern and by ``all_quad`` get the mean metric of the
  points they are made from. The quality report uses a constant metric; a
  metric per vertex enters the weights only.

Cost (``benchmarks/quads.py``, one Gmsh mesh of a square with a hole)
----------------------------------------------------------------------
97k triangles: ``heap`` 0.17 s, ``frontal`` 0.18 s, ``stack`` 0.32 s,
``matching`` 0.38 s with no triangle left (Gmsh's Blossom 18.2 s); with
``optimize`` 4.0-4.5 s, mean quality (8.4) 0.862, least 0.55 (Blossom 0.822,
0.476). ``matching`` with ``optimize`` against Blossom (with its own
optimization), CPU: 1.9x at 1k triangles (15 against 16 ms before the optimizer's
passes for mixed meshes, ``TOL.mixed_passes``), 0.70x at 10k (150 against 198 ms),
0.11x at 100k (README). 964k triangles: ``heap`` 3.0 s, ``matching`` 7.3 s (17.8 s
before the forest search). The tail of the matching dominated there: the last
~900 leftovers sit deep inside the domain (median 92 triangle sizes from
the boundary, measured) and one search per leftover grew trees of
10^4-10^5 triangles, most of them failing (pass after pass, with growing
caps). Our reading, not verified: in regular patches the dual graph is
locally the bipartite honeycomb, so two leftovers of the same parity meet
only through an odd cycle (an irregular vertex) that may be far away. The
forest grows every tree at once and keeps the trees it does not use: after
the 1024-triangle pass (1.7 s; 2339 of the heap's 7087 leftovers are
still free) it pairs all of them but one in 2.6 s, against 12.3 s for the
two passes with larger caps that it replaces. Measured and dropped: the forest ordered by
path cost (a priority queue, 8.4 s alone), the forest restricted to good
pairs first (11.7 s: the trees cannot meet and cover the mesh), the forest
alone without the bounded pass (6.1 s in all, but mean 0.845 against 0.852
after ``optimize`` at 10k triangles). From the
domain with ``all_quad`` and ``twice_size``: mean 0.985 at 51k quads in
1.2 s, 0.993 at 503k quads in 18.5 s.

References
----------
Methods text §8.4.1 (the two combination patterns, Figure 8.12), §8.4.2
(the stack path, Remark 8.5, twice size), §8.4.3 (optimization), §8.4.4
((8.3)-(8.8), the heap, the two drawbacks, Figure 8.13, Remarks 8.6-8.8),
§8.4.5 (surfaces), Remark 8.3 (parity). J. Edmonds, "Paths, trees, and
flowers" (1965); J.-F. Remacle et al., "Blossom-Quad: a non-uniform
quadrilateral mesh generator using a minimum-cost perfect-matching
algorithm" (2012).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial

import numpy as np
from numba import njit

from meshcore.domain.planar import Domain, parse_domain, parse_size_field
from meshcore.errors import AlgorithmError, InputError, positive_parameter
from meshcore.geometry.ordering import radix_argsort
from meshcore.geometry.predicates import orient2d
from meshcore.mesh import CellBlock, Mesh, quality
from meshcore.mesh.topology import edge_keys
from meshcore.quads.boundary_layer import (
    CORNER_LEAST_QUALITY,
    ROW_CHOICES,
    beats_lattice,
    best_rows,
    boundary_layer,
    least_off_sharp,
    meets_targets,
    off_sharp,
    targets_rank,
)
from meshcore.quads.lattice import triangulated
from meshcore.quads.optimization import (
    corners_relaxed,
    domain_moves,
    lifted_least,
    optimize_quads,
)
from meshcore.quads.paths import (
    _pop,
    _push,
    _weight,
    frontal_kernel,
    heap_kernel,
    stack_kernel,
    swap_kernel,
)
from meshcore.quads.splitting import ladders, merged_ladders, split_all
from meshcore.quads.valence import fewer_defects
from meshcore.triangulation import check_thinness as check_forced_triangles

__all__ = [
    "ALGORITHMS",
    "MEASURES",
    "QuadResult",
    "MAX_FORCED_TRIANGLES",
    "check_input",
    "check_metric_2d",
    "check_thinness",
    "combine",
]

ALGORITHMS = ("stack", "heap", "frontal", "matching")
MEASURES = ("angle", "simplified", "shape")
PATTERNS = ("squares", "equilateral")
#: A domain whose thin parts force more triangles than this whatever the size is refused
#: before it is triangulated (:func:`check_thinness`).
MAX_FORCED_TRIANGLES = 1_000_000
#: A ``size`` giving more than this many quads (area / size², past float64's exact
#: integers) is refused: no mesh can have them.
MOST_QUADS = 2.0**53

Progress = Callable[[float, str], None]


@dataclass(frozen=True)
class _Tolerances:
    """Every threshold of the combination, in one place (angles in degrees)."""

    #: A candidate whose corner at an end of the removed edge is within this
    #: of 0 or 180 degrees (in the metric) is a flat quad: not combined.
    flat_corner: float = 5.0
    #: With ``all_quad``: the same bound, wider. The split keeps each coarse
    #: corner as a corner of a final quad, so a coarse corner near 180 degrees at
    #: a boundary vertex of a curved boundary (174 degrees on a 64-gon disk) is a
    #: final flat quad that no smoothing can repair (boundary vertices stay);
    #: refused, its two triangles become three quads each. 45 measured against 5
    #: and 30 (benchmarks/quads.py, disk, ellipse, annulus; README).
    all_quad_flat_corner: float = 45.0
    #: The all-quad mesh of a domain gets its corner angles optimized last over
    #: the quads under this quality and their neighbours ...
    relax_below: float = 0.95
    #: ... minimizing the summed (1 / sin angle) ** relax_power: 1 raised the
    #: mean most but lowered the least (disk, 1,488 quads: 0.866 -> 0.888,
    #: least 0.528 -> 0.434), 3 gave 0.885 / 0.511, 6 gave 0.884 / 0.559 but
    #: folded a quad on an ellipse (then refused).
    relax_power: float = 4.0
    #: More quads than this in that band: not optimized (a 1,488-quad disk spends
    #: 0.7 s CPU there, against 0.5 s for the rest of the combination).
    relax_most: int = 50_000
    #: L-BFGS-B iterations of that relaxation at most: the square with a hole of
    #: benchmarks/quads.py at 1k / 10k triangles reached mean 0.9152 / 0.9818 in 200
    #: (relaxation 0.054 / 0.244 CPU s), 0.9150 / 0.9814 in 100 (0.029 / 0.113 s),
    #: 0.9144 / 0.9805 in 50 (0.018 / 0.055 s); issue 20's 40 stars at size 0.1 / 0.05
    #: mean 0.8405 / 0.9023 in 200, 0.8313 / 0.8972 in 100, 0.8214 / 0.8893 in 50.
    relax_iterations: int = 100
    #: An optimized all-quad mesh of a domain (the corner row's conditions) that misses
    #: :func:`~meshcore.quads.boundary_layer.meets_targets` is made again at these
    #: times ``size``, and the first that meets them at ``size`` is returned: the row
    #: and the lattice change much with the size on spiky polygons (issue 20's star 15
    #: at 0.1: 1.514x area / size² quads at 1.0, 1.489x at 1.02; star 8 1.70x at 1.0,
    #: 1.48x at 1.06; star 29 least 0.523 / 1.90x at 1.0, 0.502 / 1.45x at 1.1; star 26
    #: least 0.497 at 1.0-1.15, 0.522 at 1.2). A domain that no size meets pays
    #: 1 + len(size_tries) meshes.
    size_tries: tuple[float, ...] = (1.02, 1.04, 1.06, 1.1, 1.2)
    #: ... when the first mesh has at most this many quads (each try costs a whole
    #: mesh: the disk at size 0.01, 31.5k quads, 0.79 CPU s; at 0.005, 126k, 7.0 s).
    size_tries_most: int = 50_000
    #: A first mesh with more than this times area / size² quads is made again with its
    #: ladder quads merged and kept whole (:mod:`meshcore.quads.splitting`), kept where
    #: it meets the targets, or comes nearer to them
    #: (:func:`~meshcore.quads.boundary_layer.targets_rank`).
    size_tries_over: float = 1.5
    #: Then the nodes of the quads under this quality away from sharp input corners
    #: (the issue's least quality) are moved to raise it
    #: (:func:`~meshcore.quads.optimization.lifted_least`).
    least_target: float = 0.5
    #: Qualities (in [0, 1]) are rounded to this before they are compared: far
    #: above what a 1e6 translation does to them (the moved input is itself
    #: rounded at 1.2e-10, ~1e-9 of a quality at size 0.1; at 1e-9 two of 200
    #: random stars, seeds 242 and 268, made other pairs of two mirror-image
    #: quads once moved), far below a difference that matters in a mesh.
    quality_resolution: float = 1e-6
    #: Least gain of summed quality for a 4-cycle swap (qualities are <= 1).
    gain: float = 1e-9
    #: Whether the matching's greedy start lets a triangle down to its last
    #: allowed neighbour pair first (fewer leftovers to augment from).
    urgent_start: bool = True
    #: Augmenting paths go through pairs at least this good first.
    good_quality: float = 0.5
    #: Largest alternating tree (triangles) grown from one leftover triangle in
    #: the first pass (good pairs only, cheapest first); 0 skips that pass.
    search_cap: int = 1 << 10
    #: Cost of one alternating step in the augmenting search, against the
    #: quality it loses: a path may be 1 / path_step times longer to lose 1 less.
    path_step: float = 0.05
    #: Sweeps of 4-cycle swaps at most.
    swap_sweeps: int = 8
    #: ``optimize`` without ``all_quad``: smoothing passes per sweep of the optimizer, and
    #: after its last sweep 0.4 sqrt(cells) within these bounds (a larger mesh converges
    #: slower), for a higher mean in less time than its defaults (12 and 30, kept for
    #: ``all_quad``): measured in :mod:`meshcore.quads.optimization`, *Cost*.
    mixed_passes: tuple[int, int, int] = (1, 40, 80)
    #: The valence clean-up of all-quad domain meshes (:mod:`meshcore.quads.valence`):
    #: alternating flips per path and passes at most (depth 8 found the same
    #: pairs as 4 on the disk at size 0.1).
    valence_depth: int = 4
    valence_rounds: int = 4


TOL = _Tolerances()


@dataclass(frozen=True)
class QuadResult:
    """What :func:`combine` returns.

    Attributes
    ----------
    mesh : Mesh
        Quads first (block 0), then the triangles left (block 1, if any).
    quality_before, quality_after : dict
        :func:`meshcore.mesh.quality.report` of the mesh before and after
        optimization (the same dict when ``optimize`` is off).
    pairs : int
        Quads made of two triangles.
    triples : int
        Three-quad patterns (one triangle and its three neighbours).
    triangles_left : int
        Triangles not combined (before any ``all_quad`` split).
    operators : dict
        Per operator of §8.4.3, how many times it was applied (empty when
        ``optimize`` is off).
    stats : dict
        Counts and timings (seconds per phase), plus ``warp`` (degrees, min
        / mean / max) for quads on a surface.
    """

    mesh: Mesh
    quality_before: dict
    quality_after: dict
    pairs: int
    triples: int
    triangles_left: int
    operators: dict = field(default_factory=dict)
    stats: dict = field(default_factory=dict)


# ----------------------------------------------------------------------------- kernels
# Every kernel below is an inherently sequential loop (a heap, a stack path, a
# front, alternating-tree searches): each decision depends on the previous ones.
# Triangle t has neighbours nb[t, k] across its local edge k (from node k to
# node k + 1), -1 on the boundary; w[t, k] is the weight of combining t with
# nb[t, k], negative when the pair is not allowed.


@njit(cache=True)
def _find(base, x):
    """Representative of x's blossom (union-find with path halving)."""
    while base[x] != x:
        base[x] = base[base[x]]
        x = base[x]
    return x


@njit(cache=True)
def _lca(a, b, base, p, mate, mark):
    x = a
    while True:
        x = _find(base, x)
        mark[x] = True
        if mate[x] < 0:
            break
        x = p[mate[x]]
    y = b
    while True:
        y = _find(base, y)
        if mark[y]:
            break
        y = p[mate[y]]
    x = a
    while True:
        x = _find(base, x)
        mark[x] = False
        if mate[x] < 0:
            break
        x = p[mate[x]]
    return y


@njit(cache=True)
def _step_cost(nb, w, mate, v, k, step):
    """Cost of the alternating step from ``v`` across its edge ``k`` and on along ``to``'s pair.

    ``step`` plus the quality the step loses (the pair broken minus the pair
    made, when positive): the search prefers paths that lose little, even
    when they are much longer.
    """
    to = nb[v, k]
    t2 = mate[to]
    loss = 0.0
    if t2 >= 0:
        loss = _weight(nb, w, to, t2) - w[v, k]
    return step + max(loss, 0.0)


@njit(cache=True)
def _scan(nb, w, mate, v, dv, step, hk, hv, hn):
    """Queue the edges of the even triangle ``v`` (path cost ``dv``) by the cost of taking them."""
    for k in range(3):
        if nb[v, k] >= 0:
            hn = _push(hk, hv, hn, -(dv + _step_cost(nb, w, mate, v, k, step)), 3 * v + k)
    return hn


@njit(cache=True)
def _mark_path(v, b, child, base, p, mate, buf, nbuf):
    """Walk from ``v`` up to the blossom base ``b``, re-linking ``p``; record the triangles.

    Bases are merged only after both sides are walked (a walk may pass
    through a sub-blossom whose base is not yet ``b``).
    """
    while _find(base, v) != b:
        u = mate[v]
        p[v] = child
        child = u
        buf[nbuf] = v
        buf[nbuf + 1] = u
        nbuf += 2
        v = p[u]
    return nbuf


@njit(cache=True)
def _augment_kernel(nb, w, thr, mate, cap, step):
    """Edmonds' augmenting paths from every free triangle (blossoms contracted).

    The alternating tree grows cheapest first (Dijkstra's order instead of
    breadth-first: Edmonds' search finds an augmenting path whenever one
    exists in whatever order it scans), by :func:`_step_cost`. Blossoms are
    contracted by union-find on their bases (only the path from each side
    up to the base is walked), and the tree of one search is reset through
    the list of the triangles it touched, so a search costs about the size
    of its tree, not ``m``. Returns the number of augmentations.
    """
    m = nb.shape[0]
    base = np.arange(m)
    p = np.full(m, -1, np.int64)
    used = np.zeros(m, np.bool_)
    mark = np.zeros(m, np.bool_)
    buf = np.empty(2 * m + 2, np.int64)
    dist = np.zeros(m)
    hk = np.empty(3 * m + 3)
    hv = np.empty(3 * m + 3, np.int64)
    touched = np.empty(m + 3, np.int64)
    gained = 0
    for root in range(m):
        if mate[root] >= 0:
            continue
        ok = False
        for k in range(3):
            if nb[root, k] >= 0 and w[root, k] >= thr:
                ok = True
        if not ok:
            continue
        nt = 0
        used[root] = True
        dist[root] = 0.0
        touched[nt] = root
        nt += 1
        hn = _scan(nb, w, mate, root, 0.0, step, hk, hv, np.int64(0))
        end = -1
        while hn > 0 and end < 0 and nt < cap:
            h = hv[0]
            hn = _pop(hk, hv, hn)
            v = h // 3
            k = h % 3
            to = nb[v, k]
            if w[v, k] < thr or mate[v] == to or _find(base, v) == _find(base, to):
                continue
            if to == root or (mate[to] >= 0 and p[mate[to]] >= 0):
                # a blossom: contract it onto the base of the paths' meeting point
                cb = _lca(v, to, base, p, mate, mark)
                nbuf = _mark_path(v, cb, to, base, p, mate, buf, np.int64(0))
                nbuf = _mark_path(to, cb, v, base, p, mate, buf, nbuf)
                for i in range(nbuf):
                    r = _find(base, buf[i])
                    if r != cb:
                        base[r] = cb
                dv = dist[v]
                for i in range(1, nbuf, 2):  # the odd triangles of the cycle turn even
                    x = buf[i]
                    if not used[x]:
                        used[x] = True
                        dist[x] = dv
                        if hn + 3 <= hk.shape[0]:
                            hn = _scan(nb, w, mate, x, dv, step, hk, hv, hn)
            elif p[to] < 0:
                p[to] = v
                touched[nt] = to
                nt += 1
                if mate[to] < 0:
                    end = to
                    break
                to2 = mate[to]
                used[to2] = True
                dist[to2] = dist[v] + _step_cost(nb, w, mate, v, k, step)
                touched[nt] = to2
                nt += 1
                if hn + 3 <= hk.shape[0]:
                    hn = _scan(nb, w, mate, to2, dist[to2], step, hk, hv, hn)
        if end >= 0:
            v = end
            while v >= 0:
                pv = p[v]
                ppv = mate[pv]
                mate[v] = pv
                mate[pv] = v
                v = ppv
            gained += 1
        for i in range(nt):
            x = touched[i]
            base[x] = x
            p[x] = -1
            used[x] = False
    return gained


@njit(cache=True)
def _enqueue(q, qt, x):
    if qt == q.shape[0]:
        q2 = np.empty(2 * q.shape[0], np.int64)
        q2[:qt] = q
        q = q2
    q[qt] = x
    return q, qt + 1


@njit(cache=True)
def _forest_kernel(nb, w, thr, mate):
    """Edmonds' search from every free triangle at once (a forest), trees dissolved after use.

    Every free triangle roots a tree, and the trees grow together,
    breadth-first (one queue of even triangles; no costs: a priority queue
    by :func:`_step_cost` was measured 2.8 times slower at 964k triangles).
    An edge from an even triangle to an even triangle of the same tree
    contracts a blossom (as in :func:`_augment_kernel`); to an even
    triangle of another tree it closes an augmenting path ``root - ... - v -
    to - ... - root'``, which is flipped. Only the two trees of that path
    are dissolved (their triangles unlabelled, and the even triangles of
    other trees next to them queued again); every other tree stays as grown,
    so no search starts over and no failed search is paid for twice. When
    the queue is empty no augmenting path is left through pairs of quality
    at least ``thr`` (the trees are Edmonds' Hungarian forest): the matching
    is of maximum cardinality. Returns the number of augmentations.
    """
    m = nb.shape[0]
    base = np.arange(m)
    p = np.full(m, -1, np.int64)
    root = np.full(m, -1, np.int64)
    even = np.zeros(m, np.bool_)
    mark = np.zeros(m, np.bool_)
    buf = np.empty(2 * m + 2, np.int64)
    nxt = np.full(m, -1, np.int64)  # members of a tree: a list through nxt from head[root]
    head = np.full(m, -1, np.int64)
    q = np.empty(max(m, 16), np.int64)
    qh = 0
    qt = np.int64(0)
    for r in range(m):
        if mate[r] < 0:
            root[r] = r
            even[r] = True
            head[r] = r
            q, qt = _enqueue(q, qt, r)
    gained = 0
    while qh < qt:
        v = q[qh]
        qh += 1
        if qh > (q.shape[0] >> 1) and qh > 4096:  # drop the consumed half
            q[: qt - qh] = q[qh:qt]
            qt -= qh
            qh = 0
        for k in range(3):
            if not even[v]:
                break
            to = nb[v, k]
            if to < 0 or w[v, k] < thr or mate[v] == to:
                continue
            rv = root[v]
            if root[to] < 0:
                p[to] = v
                to2 = mate[to]
                for x in (to, to2):
                    root[x] = rv
                    nxt[x] = head[rv]
                    head[rv] = x
                even[to2] = True
                q, qt = _enqueue(q, qt, to2)
                continue
            if not even[to] or _find(base, v) == _find(base, to):
                continue
            if root[to] == rv:
                cb = _lca(v, to, base, p, mate, mark)
                nbuf = _mark_path(v, cb, to, base, p, mate, buf, np.int64(0))
                nbuf = _mark_path(to, cb, v, base, p, mate, buf, nbuf)
                for i in range(nbuf):
                    r = _find(base, buf[i])
                    if r != cb:
                        base[r] = cb
                for i in range(1, nbuf, 2):
                    x = buf[i]
                    if not even[x]:
                        even[x] = True
                        q, qt = _enqueue(q, qt, x)
                continue
            rt = root[to]
            o = mate[to]
            mate[to] = -1
            while o >= 0:
                y = p[o]
                n2 = mate[y]
                mate[o] = y
                mate[y] = o
                o = n2
            p[to] = v
            x = to
            while x >= 0:
                px = p[x]
                ppx = mate[px]
                mate[x] = px
                mate[px] = x
                x = ppx
            gained += 1
            for r in (rv, rt):
                x = head[r]
                while x >= 0:
                    root[x] = -1
                    even[x] = False
                    p[x] = -1
                    base[x] = x
                    x = nxt[x]
            for r in (rv, rt):
                x = head[r]
                head[r] = -1
                while x >= 0:
                    for j in range(3):
                        y = nb[x, j]
                        if y >= 0 and even[y]:
                            q, qt = _enqueue(q, qt, y)
                    n2 = nxt[x]
                    nxt[x] = -1
                    x = n2
            break
    return gained


# ----------------------------------------------------------------------------- input


def _check_mesh(mesh) -> tuple[np.ndarray, np.ndarray]:
    """Points ``(n, d)`` and triangles ``(m, 3)`` of a checked triangle mesh."""
    if not isinstance(mesh, Mesh):
        raise InputError("mesh must be a Mesh", loc=("mesh",), code="bad_shape")
    try:
        mesh.check()
    except InputError as exc:
        raise exc.prefixed("mesh") from None
    for b, block in enumerate(mesh.cells):
        if block.type != "triangle" and len(block):
            raise InputError(
                f"cell block {b} holds {block.type} cells; quad combination takes triangles only",
                loc=("mesh", "cells", b, "type"),
                code="unsupported_cell_type",
            )
    blocks = [b.data for b in mesh.cells if b.type == "triangle"]
    tri = np.concatenate(blocks) if len(blocks) > 1 else blocks[0]
    return mesh.points, np.ascontiguousarray(tri, dtype=np.int64)


def _cell_loc(mesh: Mesh, c: int) -> tuple:
    """``("mesh", "cells", b, "data", i)`` of the ``c``-th triangle over all blocks."""
    for b, block in enumerate(mesh.cells):
        if c < len(block):
            return ("mesh", "cells", b, "data", int(c))
        c -= len(block)
    return ("mesh", "cells")


def _refuse_cells(mesh: Mesh, bad: np.ndarray, what: str, code: str) -> None:
    idx = np.flatnonzero(bad)
    if not len(idx):
        return
    listed = ", ".join(str(int(i)) for i in idx[:10])
    more = f" (and {len(idx) - 10} more)" if len(idx) > 10 else ""
    msg = f"{len(idx)} triangle(s) {what}: {listed}{more}"
    errors = [{"loc": list(_cell_loc(mesh, int(i))), "msg": msg, "type": code} for i in idx[:10]]
    raise InputError(msg, code=code, errors=errors)


def _neighbours(mesh: Mesh, P: np.ndarray, tri: np.ndarray):
    """Neighbour table ``(m, 3)`` (-1 on the boundary), refusing bad topology and cells."""
    m = len(tri)
    if P.shape[1] == 2:
        sign = orient2d(P[tri[:, 0]], P[tri[:, 1]], P[tri[:, 2]])
        _refuse_cells(mesh, sign < 0, "are inverted (clockwise)", "inverted_cell")
        _refuse_cells(mesh, sign == 0, "are flat (zero area)", "degenerate_cell")
    else:
        area = quality.signed_area(P, tri)
        _refuse_cells(mesh, ~(area > 0), "are flat (zero area)", "degenerate_cell")
    a = tri.ravel()
    b = np.roll(tri, -1, axis=1).ravel()
    n = len(P)
    key = edge_keys(a, b, n)
    order = radix_argsort(key)
    ks = key[order]
    start = np.r_[True, ks[1:] != ks[:-1]]
    gid = np.cumsum(start) - 1
    count = np.bincount(gid)
    many = count[gid] > 2
    if many.any():
        bad = np.zeros(m, bool)
        bad[order[many] // 3] = True
        _refuse_cells(
            mesh, bad, "share an edge with two or more others (non-manifold)", "nonmanifold_edge"
        )
    nb = np.full(3 * m, -1, np.int64)
    two = np.flatnonzero(count[gid] == 2)
    first = two[start[two]]
    h1, h2 = order[first], order[first + 1]
    same = a[h1] == a[h2]
    if same.any():
        bad = np.zeros(m, bool)
        bad[h1[same] // 3] = True
        bad[h2[same] // 3] = True
        what = (
            "overlap a neighbour (same orientation along a shared edge)"
            if P.shape[1] == 2
            else "are oriented against a neighbour"
        )
        _refuse_cells(mesh, bad, what, "inconsistent_orientation")
    nb[h1] = h2 // 3
    nb[h2] = h1 // 3
    return nb.reshape(m, 3)


def _quantized(q: np.ndarray) -> np.ndarray:
    r = TOL.quality_resolution
    return np.round(q / r) * r


def _measure(points, quads, name: str, metric) -> np.ndarray:
    if name == "angle":
        return quality.quad_quality(points, quads, metric)
    if name == "simplified":
        return quality.quad_quality_simplified(points, quads, metric)
    return quality.quad_shape(points, quads, metric)


def _candidates(P, tri, nb, measure: str, metric, min_quality: float, flat: float):
    """Quads ``(m, 3, 4)`` of every (triangle, edge) and their weights ``(m, 3)`` (< 0: refused)."""
    m = len(tri)
    t = np.repeat(np.arange(m), 3)
    k = np.tile(np.arange(3), m)
    s = nb.ravel()
    inner = np.flatnonzero((s >= 0) & (t < s))
    u = tri[t[inner], k[inner]]
    v = tri[t[inner], (k[inner] + 1) % 3]
    w1 = tri[t[inner], (k[inner] + 2) % 3]
    s_in = s[inner]
    # the apex of s: its vertex that is neither u nor v
    ts = tri[s_in]
    w2 = ts.sum(axis=1) - u - v
    quads = np.column_stack([u, w2, v, w1])
    ok, q = _allowed_measured(P, quads, measure, metric, flat)
    q = np.where(ok, _quantized(q), -1.0)
    q[q < min_quality] = -1.0
    w = np.full(3 * m, -1.0)
    w[3 * t[inner] + k[inner]] = q
    # the same weight seen from s
    ks = np.argmax(nb[s_in] == t[inner][:, None], axis=1)
    w[3 * s_in + ks] = q
    allq = np.zeros((3 * m, 4), np.int64)
    allq[3 * t[inner] + k[inner]] = quads
    allq[3 * s_in + ks] = quads
    return allq.reshape(m, 3, 4), w.reshape(m, 3)


def _allowed(P, quads, metric, flat: float) -> np.ndarray:
    """Strictly convex candidates without a corner within ``flat`` degrees of 0 or 180
    at the ends of the removed edge."""
    u, w2, v, w1 = (P[quads[:, i]] for i in range(4))
    if P.shape[1] == 2:
        convex = (orient2d(w1, u, w2) > 0) & (orient2d(w2, v, w1) > 0)
    else:
        convex = np.ones(len(quads), bool)
    # (8.7) at u and v is 2 theta / pi or 2 - 2 theta / pi: within f of 0 or 180 degrees
    # is a value under f / 90; 0 for a reflex corner (on a surface, the convexity test).
    corner = quality.quad_quality_simplified(P, quads, metric)
    return convex & (corner > flat / 90.0)


def _check_metric(metric, P) -> np.ndarray | None:
    if metric is None:
        return None
    quality.metric_factors(metric, P.shape[1], len(P))  # raises located InputErrors
    return np.asarray(metric, dtype=np.float64)


def check_input(mesh: Mesh, metric=None) -> None:
    """Raise the InputError :func:`combine` would raise for this mesh and metric.

    Parameters
    ----------
    mesh : Mesh
    metric : (d, d) or (n, d, d) float64, optional
    """
    P, tri = _check_mesh(mesh)
    _neighbours(mesh, P, tri)
    _check_metric(metric, P)


def check_thinness(domain) -> None:
    """Refuse a domain whose thin parts alone force more than :data:`MAX_FORCED_TRIANGLES`
    triangles, whatever ``size``.

    The triangles of a strip of width ``w`` meeting the angle bound have edges
    about ``w`` long, and the quads made of them keep that size: ``size`` no
    longer decides the count (a 1 x 1e-6 strip at size 0.05 gave 1.54M
    triangles and 3.08M quads in 52 CPU s). Refused up front, in milliseconds,
    with the estimate, rather than met by a time limit; ``triangulate`` meshes
    such domains.

    Raises
    ------
    InputError
        ``too_many_cells`` at ``domain``
        (:func:`meshcore.triangulation.check_thinness`).
    """
    check_forced_triangles(
        domain,
        MAX_FORCED_TRIANGLES,
        code="too_many_cells",
        advice=f"their quads keep that size, and quad_combine makes at most "
        f"{MAX_FORCED_TRIANGLES:,} of them: mesh it with triangulate",
    )


def check_metric_2d(metric) -> None:
    """Raise an InputError unless ``metric`` is a constant 2x2 SPD matrix (domain input)."""
    if np.ndim(metric) == 3:
        raise InputError(
            "with domain input the metric must be constant (the points are not known yet)",
            loc=("metric",),
            code="bad_metric",
        )
    quality.metric_factors(metric, 2, 0)


# ----------------------------------------------------------------------------- splitting


# ----------------------------------------------------------------------------- entry point


def _choose(value, name: str, allowed: tuple[str, ...]) -> str:
    if value not in allowed:
        raise InputError(
            f"{name} must be one of {', '.join(allowed)}, got {value!r}",
            loc=(name,),
            code="bad_value",
        )
    return value


def _report(mesh: Mesh, metric, boundary) -> dict:
    const = metric if metric is not None and np.ndim(metric) == 2 else None
    return quality.report(mesh, boundary_segments=boundary, metric=const)


def _mesh_of(P, quads, tris) -> Mesh:
    blocks = [CellBlock("quad", quads)]
    if len(tris):
        blocks.append(CellBlock("triangle", tris))
    return Mesh(P, tuple(blocks))


def _combined(
    mesh, metric, domain_input, algorithm, measure, min_quality, all_quad, report, lap, inner, thin
):
    """Steps 1, 2 and 4 of the module docstring: the selected pairs (and triples) of a
    triangle mesh as a mixed mesh, or split into quads with ``all_quad`` (after the
    valence clean-up of :mod:`meshcore.quads.valence` on domain input with ``matching``;
    ``inner``: the domain is the inside of a boundary layer; ``thin``: the domain's input
    vertex count and triangulation size, to merge ladder quads and keep them whole where
    they can, :mod:`meshcore.quads.splitting`).

    Returns (mesh, metric, boundary edges, stats, (pairs, triples, triangles left)).
    """
    P, tri = _check_mesh(mesh)
    metric = _check_metric(metric, P)
    report(0.4, "dual graph")
    nb = _neighbours(mesh, P, tri)
    t_b, k_b = np.nonzero(nb < 0)  # the input's boundary, or the domain's chains
    boundary = np.column_stack([tri[t_b, k_b], tri[t_b, (k_b + 1) % 3]])
    # the 45-degree bound is measured on domains (curved boundaries); a given mesh keeps 5
    flat = TOL.all_quad_flat_corner if all_quad and domain_input else TOL.flat_corner
    quads_of, w = _candidates(P, tri, nb, measure, metric, min_quality, flat)
    lap("candidates")
    report(0.5, f"selecting pairs ({algorithm})")
    m = len(tri)
    mate = np.full(m, -1, np.int64)
    triples = np.zeros((0, 4), np.int64)
    stats: dict = {"input_triangles": m, "input_points": len(P)}
    if algorithm in ("heap", "matching"):
        valid = np.flatnonzero((w.ravel() >= 0) & (np.arange(3 * m) // 3 < nb.ravel()))
        order = valid[np.argsort(-w.ravel()[valid], kind="stable")]
        heap_kernel(nb, w, order, mate, algorithm == "matching" and TOL.urgent_start)
        if algorithm == "matching":
            stats["heap_triangles_left"] = int(np.count_nonzero(mate < 0))
            gained = 0
            good = max(TOL.good_quality, min_quality)
            if TOL.search_cap > 0:
                gained += _augment_kernel(nb, w, good, mate, TOL.search_cap, TOL.path_step)
            gained += _forest_kernel(nb, w, min_quality, mate)
            stats["augmentations"] = int(gained)
            stats["swaps"] = int(swap_kernel(nb, w, mate, TOL.gain, TOL.swap_sweeps))
            if all_quad and domain_input:
                stats["valence"] = _valence_cleanup(
                    P, tri, nb, w, mate, measure, metric, min_quality, inner
                )
    elif algorithm == "frontal":
        seeds = np.flatnonzero((nb < 0).any(axis=1))
        frontal_kernel(nb, w, seeds, mate)
    else:
        nbound = (nb < 0).sum(axis=1)
        starts = np.argsort(-nbound, kind="stable")
        start_edge = np.argmax(nb[starts] < 0, axis=1)
        w3 = _three_quads_allowed(P, tri, nb, measure, metric, min_quality, flat)
        buf = np.zeros((m // 4 + 1, 4), np.int64)
        ntr = stack_kernel(nb, w, w3, starts, start_edge, mate, buf)
        triples = buf[:ntr]
    lap("selection")
    # -- the mixed mesh ------------------------------------------------------
    t = np.flatnonzero((mate >= 0) & (np.arange(m) < mate))
    k = np.argmax(nb[t] == mate[t][:, None], axis=1)
    quads = quads_of[t, k]
    used = mate >= 0
    npts = len(P)
    if len(triples):
        Kt = triples[:, 0]
        used[triples.ravel()] = True
        g = np.arange(npts, npts + len(Kt))
        P = np.concatenate([P, P[tri[Kt]].mean(axis=1)])
        if metric is not None and metric.ndim == 3:
            metric = np.concatenate([metric, metric[tri[Kt]].mean(axis=1)])
        tq = []
        for kk in range(3):
            u, v = tri[Kt, kk], tri[Kt, (kk + 1) % 3]
            d = tri[nb[Kt, kk]].sum(axis=1) - u - v
            tq.append(np.column_stack([u, d, v, g]))
        quads = np.concatenate([quads, *tq])
    left = tri[~used]
    stats.update(pairs=len(t), triples=len(triples), triangles_left=len(left))
    out_mesh = _mesh_of(P, quads, left)
    if all_quad:
        report(0.6, "splitting into quads")
        whole = None
        if thin is not None:  # (input vertices, the triangulation's size)
            P, quads, left, boundary, metric = merged_ladders(
                P, quads, left, boundary, *thin, metric
            )
            whole = ladders(quads, boundary, len(P))
        P2, q2, m2, boundary = split_all(P, quads, left, metric, boundary, whole)
        if metric is not None and metric.ndim == 3:
            metric = m2
        out_mesh = Mesh(P2, (CellBlock("quad", q2),))
    lap("build")
    return out_mesh, metric, boundary, stats, (len(t), len(triples), len(left))


def combine(
    mesh: Mesh | None = None,
    *,
    domain=None,
    size: float | None = None,
    size_field: dict | None = None,
    min_angle: float | None = None,
    keep_boundary: bool = False,
    pattern: str = "squares",
    algorithm: str = "matching",
    measure: str = "angle",
    metric=None,
    min_quality: float = 0.0,
    all_quad: bool = False,
    twice_size: bool = False,
    optimize: bool = False,
    inner: bool = False,
    corner_least: float | None = None,
    progress: Progress | None = None,
) -> QuadResult:
    """Combine the triangles of a mesh (or of a domain meshed here) into quads.

    Parameters
    ----------
    mesh : Mesh, optional
        Triangles only, counter-clockwise in the plane, consistently oriented
        on a surface (points ``(n, 3)``), conforming and manifold.
    domain : Domain or dict, optional
        Instead of ``mesh``: a planar domain, triangulated by
        :func:`meshcore.triangulation.refinement.triangulate` with ``size``,
        ``size_field``, ``min_angle`` and ``keep_boundary`` (module
        docstring, step 3).
    pattern : {"squares", "equilateral"}
        Domain input: triangles laid in pairs of near-squares (sheared
        lattice) or the triangulator's equilateral lattice.
    algorithm : {"stack", "heap", "frontal", "matching"}
    measure : {"angle", "simplified", "shape"}
        (8.4)/(8.6), (8.7) or (8.8): the weight of a candidate quad, and the
        measure the optimization improves.
    metric : (d, d) or (n, d, d) float64, optional
        A constant SPD metric or one per point (domain input: constant only).
    min_quality : float
        Candidates of lower quality are not combined.
    all_quad : bool
        Split quads into four and leftover triangles into three (Figure 8.13).
    twice_size : bool
        Domain input with ``all_quad``: mesh at ``2 * size`` first; on smooth
        domains (``size`` given, no size field nor metric, the boundary not
        kept) after a row of quads along the boundary
        (:func:`meshcore.quads.boundary_layer.boundary_layer`); with ``optimize``
        (``angle``, no ``corner_least``, ``squares``) up to three rows along smooth
        boundaries, or rows across from the outer ring to a single hole, chosen by
        the optimized mesh's mean quality
        (:func:`~meshcore.quads.boundary_layer.best_rows`, ``stats`` ``layer_rows``:
        ``(rows, hole_rows)``, ``(0, 0)`` across).
    optimize : bool
        Apply the operators of §8.4.3 and smoothing (:mod:`meshcore.quads.optimization`).
    inner : bool
        The domain is the inside of a boundary layer
        (:func:`meshcore.quads.boundary_layer.boundary_layer` sets it): its
        boundary vertices end inside the final mesh and may move, so the
        valence clean-up may pair leftover triangles with a flat corner there
        too (:mod:`meshcore.quads.valence`).
    corner_least : float in [0, 1], optional
        The least quality (8.4) of the corner row's quads before the
        optimization (:mod:`meshcore.quads.boundary_layer`; None: its
        ``CORNER_LEAST_QUALITY``). Where that refuses the row, ``optimize`` with
        ``angle`` tries it once more at 0 and keeps it when the optimized mesh
        meets :func:`~meshcore.quads.boundary_layer.meets_targets`, or else when
        the lattice's mesh misses them and the row beats it
        (:func:`~meshcore.quads.boundary_layer.beats_lattice`; ``stats``
        ``lattice_least``: the lattice's least quality away from sharp corners).
        Where the mesh still misses those targets (``size`` given, no size field
        nor metric, the boundary not kept, not ``inner``, ``squares``) with more than 1.5
        times area / size² quads, it is made again with the ladder quads of the domain's
        thin parts merged and kept whole (:mod:`meshcore.quads.splitting`): returned
        where it meets the targets, and standing for the first mesh where it comes
        nearer to them (:func:`~meshcore.quads.boundary_layer.targets_rank`: more of
        the three targets met, then the higher least quality away from the sharp input
        corners, then mean quality). Where the
        mesh still misses the targets, the domain is meshed
        again at 1.02, 1.04, 1.06, 1.1 and 1.2 times ``size`` and the first mesh that
        meets the targets at ``size`` is returned (``stats`` ``size_factor``);
        none does: the first mesh (so too when it has more than 50,000 quads).
    progress : callable(fraction, message), optional

    Returns
    -------
    QuadResult

    Raises
    ------
    InputError
        Bad parameters (``loc`` names them), a bad mesh (``loc`` under
        ``mesh``: non-triangle blocks, indices out of range, inverted, flat,
        non-manifold or inconsistently oriented triangles) or a bad domain
        (``too_many_cells`` for a domain too thin: :func:`check_thinness`).

    References
    ----------
    §8.4 (module docstring).
    """
    size = positive_parameter(size, "size")  # before the size tries multiply it
    retry = (
        domain is not None
        and size is not None
        and size_field is None
        and metric is None
        and all_quad
        and twice_size
        and optimize
        and measure == "angle"
        and pattern == "squares"
        and not keep_boundary
        and not inner
        and corner_least is None
    )
    if retry and not isinstance(domain, Domain):
        domain = parse_domain(domain)
    if progress is not None:
        progress = _forward(progress)
    one = partial(  # one size: the first mesh, then each size try
        _combine,
        mesh,
        domain=domain,
        size_field=size_field,
        min_angle=min_angle,
        keep_boundary=keep_boundary,
        pattern=pattern,
        algorithm=algorithm,
        measure=measure,
        metric=metric,
        min_quality=min_quality,
        all_quad=all_quad,
        twice_size=twice_size,
        optimize=optimize,
        inner=inner,
        corner_least=corner_least,
    )
    if not retry:
        return one(size=size, progress=progress)
    res = one(size=size, progress=_share(progress, 0.0, 0.9))
    if res.stats.get("layer_rows"):

        def rows_try(r: int, h: int) -> QuadResult | None:
            share = 0.05 / (len(ROW_CHOICES) - 1)  # never the first choice: the first mesh's
            low = 0.9 + share * (ROW_CHOICES.index((r, h)) - 1)
            return one(
                size=size, rows=(r, h), progress=_share(progress, low, share, f" (rows {r}, {h})")
            )

        res, met = best_rows(res, rows_try, domain, size)
    else:
        met = meets_targets(res.mesh, domain, size)
    if met or len(res.mesh.cells_by_type["quad"]) > TOL.size_tries_most:
        return res
    if len(res.mesh.cells_by_type["quad"]) * size * size > TOL.size_tries_over * domain.area:
        try:
            thin = one(size=size, ladders=True, progress=_share(progress, 0.0, 0.9))
        except AlgorithmError:  # as a size try: a try that fails leaves the first mesh
            thin = None
        if thin is not None and meets_targets(thin.mesh, domain, size):
            return thin
        if thin is not None and targets_rank(thin.mesh, domain, size) > targets_rank(
            res.mesh, domain, size
        ):
            res = thin
    tries = len(TOL.size_tries)
    for k, f in enumerate(TOL.size_tries):  # at most len(TOL.size_tries) meshes
        try:
            again = one(
                size=size * f,
                progress=_share(
                    progress, 0.95 + 0.05 * k / tries, 0.05 / tries, f" (again at {f:g} x size)"
                ),
            )
        except AlgorithmError:  # a try that fails leaves the first mesh standing
            continue
        if meets_targets(again.mesh, domain, size):
            again.stats["size_factor"] = f
            return again
    return res


def _forward(progress: Progress) -> Progress:
    """``progress`` that never goes back: each fraction at least the highest before (a
    mesh made again, for a retried row or a size try, starts its phases anew)."""
    high = 0.0

    def report(f: float, msg: str) -> None:
        nonlocal high
        high = max(high, f)
        progress(high, msg)

    return report


def _share(progress: Progress | None, low: float, width: float, note: str = "") -> Progress | None:
    """``progress`` for one of the meshes :func:`combine` may make, reporting into [low,
    low + width] with ``note`` after each message: the first mesh (or the ladder-merged
    try) into [0, 0.9], the other row choices of :func:`best_rows` each into its share of
    [0.9, 0.95], the size tries into theirs of [0.95, 1]."""
    if progress is None:
        return None
    return lambda f, msg: progress(low + width * f, msg + note)


def _combine(
    mesh: Mesh | None = None,
    *,
    domain=None,
    size: float | None = None,
    size_field: dict | None = None,
    min_angle: float | None = None,
    keep_boundary: bool = False,
    pattern: str = "squares",
    algorithm: str = "matching",
    measure: str = "angle",
    metric=None,
    min_quality: float = 0.0,
    all_quad: bool = False,
    twice_size: bool = False,
    optimize: bool = False,
    inner: bool = False,
    corner_least: float | None = None,
    progress: Progress | None = None,
    ladders: bool = False,
    rows: tuple[int, int] | None = None,
) -> QuadResult | None:
    """:func:`combine` for one ``size``; ``ladders``: merge the ladder quads of the
    domain's thin parts and keep them whole (:mod:`meshcore.quads.splitting`); ``rows``:
    exactly these rows along the outer rings and the holes, else None (no mesh made:
    :func:`~meshcore.quads.boundary_layer.best_rows`); None: ``ROW_CHOICES[0]`` at most
    (:func:`~meshcore.quads.boundary_layer.boundary_layer`)."""
    report = progress if progress is not None else (lambda f, msg: None)
    timings: dict[str, float] = {}
    clock = time.perf_counter()

    def lap(name: str) -> None:
        nonlocal clock
        now = time.perf_counter()
        timings[name] = round(now - clock, 6)
        clock = now

    algorithm = _choose(algorithm, "algorithm", ALGORITHMS)
    measure = _choose(measure, "quality", MEASURES)
    pattern = _choose(pattern, "pattern", PATTERNS)
    if (mesh is None) == (domain is None):
        raise InputError("give either mesh or domain", loc=("mesh",), code="conflicting_parameters")
    min_quality = _fraction(min_quality, "min_quality")
    corner_least = None if corner_least is None else _fraction(corner_least, "corner_least")
    if twice_size and (domain is None or not all_quad):
        raise InputError(
            "twice_size meshes a domain at twice the size for all_quad: it needs domain input "
            "and all_quad=true",
            loc=("twice_size",),
            code="conflicting_parameters",
        )
    if twice_size and size is not None and not math.isfinite(2.0 * size):
        raise InputError(
            f"size {size!r} is meshed at twice the size with twice_size, past the largest "
            "float: give a smaller size",
            loc=("size",),
            code="bad_parameter",
        )
    layered = retried = None
    layer_fits = size is not None and size_field is None and metric is None
    if domain is not None:
        if metric is not None:
            check_metric_2d(metric)
        report(0.0, "triangulating the domain")
        tsize = None if size is None else (2.0 * size if twice_size else size)
        field_ = size_field
        if twice_size and size_field is not None:
            field_points, field_values = parse_size_field(size_field)
            field_ = {"points": field_points, "values": 2.0 * field_values}

        def sub(f: float, msg: str) -> None:
            report(0.4 * f, msg)

        _dom = domain_in = domain if isinstance(domain, Domain) else parse_domain(domain)
        check_thinness(_dom)
        if size is not None and not _dom.area / size / size <= MOST_QUADS:
            quads = _dom.area / size / size
            about = f"about {quads:.3g}" if math.isfinite(quads) else f"more than {MOST_QUADS:.3g}"
            raise InputError(
                f"size {size!r} would make {about} quads on a "
                f"domain of area {_dom.area:.6g}: give a larger size",
                loc=("size",),
                code="too_many_cells",
            )
        if layer_fits and all_quad and twice_size and pattern == "squares" and not keep_boundary:
            r, h = ROW_CHOICES[0] if rows is None else rows
            layered = boundary_layer(
                _dom,
                size,
                lambda d: _combine(
                    domain=d,
                    size=size,
                    min_angle=min_angle,
                    keep_boundary=True,
                    algorithm=algorithm,
                    measure=measure,
                    min_quality=min_quality,
                    all_quad=True,
                    twice_size=True,
                    inner=True,
                ),
                corner_least=CORNER_LEAST_QUALITY if corner_least is None else corner_least,
                rows=r,
                hole_rows=h,
                exact=rows is not None,
            )
            if layered is None and rows is not None:
                return None  # these rows do not fit
            if layered is None and corner_least is None and optimize and measure == "angle":
                res = _combine(
                    domain=_dom,
                    size=size,
                    min_angle=min_angle,
                    algorithm=algorithm,
                    min_quality=min_quality,
                    all_quad=True,
                    twice_size=True,
                    optimize=True,
                    inner=inner,
                    corner_least=0.0,
                    progress=progress,
                    ladders=ladders,
                )
                # without a row it is the lattice's mesh, as below
                if "boundary_layer" not in res.stats or meets_targets(res.mesh, _dom, size):
                    return res
                retried = res
        if layered is None:
            mesh, _dom = triangulated(_dom, tsize, field_, min_angle, pattern, keep_boundary, sub)
        lap("triangulate")
    if layered is None:
        out_mesh, metric, boundary, stats, counts = _combined(
            mesh,
            metric,
            domain is not None,
            algorithm,
            measure,
            min_quality,
            all_quad,
            report,
            lap,
            inner,
            (len(_dom.points), tsize or 0.0) if ladders and not keep_boundary else None,
        )
    else:
        out_mesh, boundary, inside, laid = layered
        counts, stats = (0, 0, 0), {}  # rows across: no inner mesh
        if inside is not None:
            counts, stats = (inside.pairs, inside.triples, inside.triangles_left), inside.stats
        stats = dict(stats, boundary_layer=len(boundary), layer_rows=laid)
        lap("layer")
    report(0.65, "quality report")
    quality_before = _report(out_mesh, metric, boundary)
    ops: dict = {}
    quality_after = quality_before
    if optimize:
        report(0.7, "optimization")
        opt = optimize_quads(
            out_mesh,
            measure=measure,
            metric=metric,
            passes=None if all_quad else _mixed_passes(out_mesh),
            progress=lambda f, msg: report(0.7 + 0.25 * f, msg),
        )
        out_mesh = opt.mesh
        ops = opt.operators
        if boundary is not None:  # boundary vertices are never removed
            boundary = opt.point_map[boundary]
        if domain is not None and all_quad and metric is None and measure == "angle":
            moves = domain_moves(out_mesh, _dom)
            out_mesh, ops["relax"] = corners_relaxed(
                out_mesh,
                moves,
                TOL.relax_below,
                TOL.relax_power,
                TOL.relax_most,
                TOL.relax_iterations,
            )
            judged = off_sharp(out_mesh, _dom)
            out_mesh, ops["lift_off_sharp"] = lifted_least(
                out_mesh, moves, judged, TOL.least_target
            )
        if metric is not None and metric.ndim == 3:
            metric = metric[opt.point_map >= 0]
        lap("optimize")
        quality_after = _report(out_mesh, metric, boundary)
    if out_mesh.dim == 3:
        qd = out_mesh.cells_by_type.get("quad")
        if qd is not None and len(qd):
            wp = quality.quad_warp(out_mesh.points, qd)
            stats["warp"] = {
                "min": float(wp.min()),
                "mean": float(wp.mean()),
                "max": float(wp.max()),
            }
    stats["seconds"] = timings
    if retried is not None:  # the lattice's mesh, optimized above: judged is its off_sharp
        lattice_least = least_off_sharp(out_mesh, domain_in, judged)
        if not meets_targets(out_mesh, domain_in, size, judged) and beats_lattice(
            retried.mesh, out_mesh, lattice_least, domain_in
        ):
            retried.stats["lattice_least"] = lattice_least
            report(1.0, "done")
            return retried
    report(1.0, "done")
    return QuadResult(
        mesh=out_mesh,
        quality_before=quality_before,
        quality_after=quality_after,
        pairs=int(counts[0]),
        triples=int(counts[1]),
        triangles_left=int(counts[2]),
        operators=ops,
        stats=stats,
    )


def _fraction(value, name: str) -> float:
    """``value`` as a float in [0, 1], else an :class:`InputError` ``bad_value`` at
    ``(name,)`` (a non-number too: a library caller's string is not a TypeError, nor an
    integer beyond float64 an OverflowError)."""
    try:
        x = float(value)
    except (TypeError, ValueError, OverflowError):
        x = math.nan
    if not 0.0 <= x <= 1.0:
        raise InputError(f"{name} must be in [0, 1]", loc=(name,), code="bad_value")
    return x


def _mixed_passes(mesh: Mesh) -> tuple[int, int]:
    """The smoothing passes of ``optimize`` without ``all_quad`` (``TOL.mixed_passes``)."""
    per_sweep, least, most = TOL.mixed_passes
    cells = sum(len(b.data) for b in mesh.cells)
    return per_sweep, min(most, max(least, round(0.4 * math.sqrt(cells))))


def _valence_cleanup(P, tri, nb, w, mate, measure, metric, min_quality, inner) -> dict:
    """:func:`meshcore.quads.valence.fewer_defects` on a matching: two leftover
    triangles may pair under the 5-degree flat bound (``flat_corner``) where the
    ends of their common edge will be interior vertices of the final mesh (all of
    them when ``inner``), else under the all-quad bound."""
    _, w_merge = _candidates(P, tri, nb, measure, metric, min_quality, TOL.flat_corner)
    if not inner:
        t_b, k_b = np.nonzero(nb < 0)
        fixed = np.zeros(len(P), bool)
        fixed[tri[t_b, k_b]] = True
        fixed[tri[t_b, (k_b + 1) % 3]] = True
        w_merge = np.where(fixed[tri] | fixed[np.roll(tri, -1, axis=1)], w, w_merge)
    return fewer_defects(P, tri, nb, w, w_merge, mate, TOL.valence_depth, TOL.valence_rounds)


def _allowed_measured(P, quads, measure: str, metric, flat: float):
    """:func:`_allowed` and :func:`_measure` of the candidates: in the plane without a
    metric, both from :func:`~meshcore.mesh.quality.planar_quad_measures` (one compiled
    loop; the same values)."""
    if P.shape[1] != 2 or metric is not None:
        return _allowed(P, quads, metric, flat), _measure(P, quads, measure, metric)
    convex, corner, angle = quality.planar_quad_measures(P, quads)
    if measure == "angle":
        q = angle
    else:
        q = corner if measure == "simplified" else _measure(P, quads, measure, metric)
    return convex & (corner > flat / 90.0), q


def _three_quads_allowed(P, tri, nb, measure, metric, min_quality, flat) -> np.ndarray:
    """Whether a triangle and its three neighbours make three allowed quads (Figure 8.12)."""
    m = len(tri)
    full = (nb >= 0).all(axis=1)
    K = np.flatnonzero(full)
    ok = np.zeros(m, bool)
    if not len(K):
        return ok
    g = np.arange(len(P), len(P) + len(K))
    Pg = np.concatenate([P, P[tri[K]].mean(axis=1)])
    mg = metric
    if metric is not None and metric.ndim == 3:
        mg = np.concatenate([metric, metric[tri[K]].mean(axis=1)])
    good = np.ones(len(K), bool)
    for k in range(3):
        u, v = tri[K, k], tri[K, (k + 1) % 3]
        s = nb[K, k]
        d = tri[s].sum(axis=1) - u - v
        q4 = np.column_stack([u, d, v, g])
        allowed, q = _allowed_measured(Pg, q4, measure, mg, flat)
        good &= allowed & (q >= min_quality)
    ok[K] = good
    return ok
