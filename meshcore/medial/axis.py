"""The medial axis of a planar domain from its empty Delaunay triangulation (§9.4).

:func:`medial_axis` takes a validated :class:`~meshcore.domain.planar.Domain`
(holes allowed) or a point cloud sampling closed boundary curves (§9.4.2)
and returns a :class:`MedialAxis`: nodes with their radii (distance to the
boundary), edges, node kinds and branches.

Pipeline (§9.4.1):

1. **Sampling.** Every boundary segment is split into equal pieces no longer than ``h``; input
   vertices stay samples.
2. **Admissibility.** The samples are triangulated by :func:`meshcore.delaunay.kernel2d.delaunay`
   (our exact kernel). If some piece is not a Delaunay edge,
   :func:`meshcore.delaunay.admissible.admissible_segments` splits pieces until every one is
   (§9.1.4).
3. **Empty triangulation and types.** A compiled flood fill keeps the triangles on the domain side
   of the pieces (regions, never centroid tests) and counts each one's boundary edges: Type 0, 1, 2
   (and 3, a triangle that is the whole domain), Figure 9.9.
4. **Voronoi graph.** Circumcentres of adjacent triangles are joined across interior edges (Theorem
   9.1). Adjacent triangles whose four vertices are co-circular have the same circumcentre: they
   are one node, of degree 4 or more where co-circularity joins branches (Figure 9.10, left;
   §9.4.3). The test is on the two centres, computed relative to a shared vertex, being within
   :attr:`Tolerances.node_merge` of the diameter: it takes the exact ties (which the Delaunay
   kernel broke symbolically, one way or the other) and the near-ties whose Voronoi edge is shorter
   than any meaningful length, which has no direction worth keeping.
5. **Pruning** (Remarks 9.10-9.13, §9.4.3): a *terminal branch* runs from a leaf to the first node
   where three or more edges meet. Its *significance* is the angle that the boundary edge through
   which it leaves that junction subtends at the junction's centre: the angle between the two
   boundary points that the maximal circle there touches on either side of the branch. A corner of
   interior angle ``θ`` gives a branch of significance ``180° - θ`` (90° at a rectangle's corners);
   a branch made by the discretization (a Type 2 triangle on a sampled curve, Remark 9.11) spans a
   few samples, a few ``h / r``. Branches are removed, least significant first, while their
   significance is below ``prune`` degrees; when a junction is left with two edges, the branches
   through it merge and are measured again at the next junction. Only leaves are ever removed, so
   loops (holes) and connectivity are kept, and at least two branches survive at every junction.
6. **Terminal nodes** (§9.4.1, Type 1-Type 2 pair): "the medial axis ends at the centre of the
   circle of the triangle of Type 2; to complete it, one can link this point with the terminal
   node": a surviving leaf that is a Type 2 triangle at a *corner* (the boundary turns there by at
   least ``prune`` degrees, the significance of that corner's branch) is joined to it (radius 0),
   so corner branches reach their corners. At a smooth convex end the contacts of the circles close
   up towards the osculating circle (Remark 9.11): leaves whose circle touches the boundary within
   less than ``prune`` degrees (the minor arc between its farthest two contacts) are trimmed,
   repeatedly, so the axis ends near the centre of curvature (1.49 for 1.5 on the 2 x 1 ellipse). A
   component left as a single path is measured from its widest node, each half removed when
   insignificant there, so that a disk's axis is its centre.
7. **Radii.** Each node's radius is its distance to the boundary pieces (not the circumradius: a
   circle through three samples bulges past the boundary between samples), found by descending
   along the boundary from the node's contact samples (compiled).

Choices where the text leaves freedom
-------------------------------------
* **Default ``h``.** §9.4.1 suggests ``h <= h_min / 2`` (``h_min`` the smallest distance between
  non-consecutive boundary vertices), which makes the sampling admissible; that alone can be coarse
  (0.56 on a 2 x 1 rectangle), so the default is also at most the perimeter over
  :data:`DEFAULT_SAMPLES`, and at least the perimeter over :data:`MAX_DEFAULT_SAMPLES` (so that
  tiny input features cannot make a default job huge; admissibility then comes from step 2). A
  given ``h`` may ask for up to :data:`MAX_SAMPLES` samples.
* **Point clouds** (§9.4.2) are joined into closed curves by the NN-crust rule (each sample to its
  nearest neighbour and to its nearest neighbour on the other side, Dey and Kumar 1999, with the
  closed half-plane so that right-angled corners sampled evenly are joined), nested by exact ray
  parity into outer rings and holes, validated as a domain, and then treated as a polygon whose
  vertices are the samples. Without ``h`` the samples are used as given, so a cloud of a polygon's
  samples gives that polygon's axis. A cloud that does not make closed, simple curves is refused
  naming the point where the reconstruction fails.
* **Approximation.** ``voronoi`` (default) gives the circumcentres (the axis of Theorem 9.1).
  ``midpoints`` is Remark 9.14's coarse line: nodes at the midpoints of the interior edges the
  Voronoi edges cross, junctions at the centroids of their triangles, with the same topology as
  ``voronoi`` after pruning.
* **Pruning measure.** See step 5: ``prune`` is an angle in degrees, :data:`DEFAULT_PRUNE` = 25
  (keeps the corners of polygons up to 12 sides' worth of turning, removes the branches a sampled
  circle makes at 16 or more sides). ``prune=0`` keeps every branch.
* **Row order.** The Delaunay kernel's rows are spatially random (their order is not part of its
  guarantee); the triangles are renumbered in increasing order of their smallest sample index
  (stably) before step 3, so that, the samples being numbered along the boundary, every later pass
  reads memory nearly in order. ``triangles`` and the node numbering (nodes in order of their first
  triangle) follow that order.

References
----------
Methods text §9.4.1-§9.4.3 (Theorem 9.1, Figures 9.9-9.12, Remarks
9.9-9.14), §9.7.4 (dimensional reduction: the axis as a line mesh with its
radius). T. K. Dey and P. Kumar, "A simple provable algorithm for curve
reconstruction" (1999).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from numba import njit
from scipy.spatial import cKDTree

from meshcore.delaunay.admissible import admissible_segments
from meshcore.delaunay.kernel2d import delaunay
from meshcore.domain.planar import Domain, as_domain, parse_domain, ray_parity
from meshcore.errors import AlgorithmError, InputError
from meshcore.geometry.tolerances import MAX_COORDINATE, MIN_DIAMETER
from meshcore.limits import DEFAULT_PRUNE
from meshcore.mesh import CellBlock, Mesh, topology

__all__ = [
    "DEFAULT_PRUNE",
    "DEFAULT_SAMPLES",
    "MAX_DEFAULT_SAMPLES",
    "MAX_SAMPLES",
    "MedialAxis",
    "cloud_points",
    "medial_axis",
    "pruned_axes",
]

Progress = Callable[[float, str], None]

#: The default ``h`` is at most the perimeter over this ...
DEFAULT_SAMPLES = 4096
#: ... and at least the perimeter over this.
MAX_DEFAULT_SAMPLES = 1 << 18
#: A given ``h`` may ask for at most this many boundary samples (6M samples of a 2 x 1
#: rectangle, h = 1e-6, took 42 s of CPU, 3.2 GB and made a 454 MB result).
MAX_SAMPLES = 1 << 21


@dataclass(frozen=True)
class Tolerances:
    """Every tolerance of this module; none of them decides a sign.

    Attributes
    ----------
    node_merge : float
        Adjacent circumcentres closer than this, times the domain's
        diameter, are one node (co-circular vertices, up to rounding).
    """

    node_merge: float = 2.0**-33


TOLERANCES = Tolerances()

_CRITICAL, _TERMINAL, _REGULAR, _ISOLATED = "critical", "terminal", "regular", "isolated"


@dataclass(frozen=True, eq=False)
class MedialAxis:
    """An approximate medial axis and the triangulation it comes from.

    Attributes
    ----------
    nodes : (n, 2) float64
        Node positions.
    radius : (n,) float64
        Distance from each node to the boundary (0 at corner nodes).
    edges : (m, 2) int64
        Axis edges, as node indices.
    branches : tuple of (k,) int64
        Node chains between critical and terminal nodes; a closed loop with
        no such node is one chain whose last id repeats its first.
    h : float
        The boundary sampling step used.
    domain : Domain
        The domain (for a point cloud, the one reconstructed from it).
    samples : (p, 2) float64
        The boundary samples, ``domain.points``-independent numbering.
    succ : (p,) int64
        The next sample along the boundary: piece ``i -> succ[i]`` has the
        domain on its left.
    segment_source : (p,) int64
        The domain boundary segment each piece lies on.
    triangles : (t, 3) int64
        The empty Delaunay triangulation of the domain on the samples,
        counter-clockwise.
    triangle_type : (t,) int8
        Number of boundary edges of each triangle (Type 0, 1, 2, 3).
    node_triangle : (n,) int64
        For ``voronoi`` nodes, a triangle whose circumcentre the node is;
        -1 for the corner nodes added at Type 2 apexes and, in the
        ``midpoints`` approximation, for edge midpoints.
    triangle_node : (t,) int64
        For ``voronoi``, the node each triangle's circumcentre is (co-circular
        neighbours share one), -1 where pruned; all -1 for ``midpoints``.
    node_sample : (n,) int64
        The sample each corner node (a Type 2 apex) is, -1 for the others.
    edge_pq : (m, 2) int64
        For ``voronoi``, the interior Delaunay edge (two samples, one on each
        side of the axis) that each axis edge crosses; -1 for the edges to
        Type 2 apexes and for ``midpoints``.
    stats : dict
        Counts: samples, added points, triangles by type, nodes by kind,
        edges, branches, branches pruned.
    """

    nodes: np.ndarray
    radius: np.ndarray
    edges: np.ndarray
    branches: tuple[np.ndarray, ...]
    h: float
    domain: Domain
    samples: np.ndarray
    succ: np.ndarray
    segment_source: np.ndarray
    triangles: np.ndarray
    triangle_type: np.ndarray
    node_triangle: np.ndarray
    triangle_node: np.ndarray
    node_sample: np.ndarray
    edge_pq: np.ndarray
    stats: dict = field(default_factory=dict)

    @cached_property
    def kind(self) -> np.ndarray:
        """(n,) str: ``"critical"`` (three or more edges: a Type 0 node where
        branches meet), ``"terminal"`` (one edge: a branch end), ``"regular"``
        (two), ``"isolated"`` (none: the axis is one point)."""
        deg = np.bincount(self.edges.ravel(), minlength=len(self.nodes))
        return np.array([_ISOLATED, _TERMINAL, _REGULAR, _CRITICAL])[np.minimum(deg, 3)]

    @cached_property
    def segments(self) -> np.ndarray:
        """(p, 2) int64: the boundary pieces ``(i, succ[i])``, domain on the left."""
        return np.column_stack([np.arange(len(self.succ)), self.succ])

    def to_json(self) -> dict:
        """The medial-axis JSON of DESIGN.md: nodes, radius, edges, kind, branches."""
        return {
            "nodes": self.nodes.tolist(),
            "radius": self.radius.tolist(),
            "edges": self.edges.tolist(),
            "kind": self.kind.tolist(),
            "branches": [b.tolist() for b in self.branches],
        }

    def to_mesh(self) -> Mesh:
        """The axis as a line mesh with point data ``radius`` (§9.7.4, dimensional
        reduction); its cell data ``branch`` numbers each edge's branch."""
        branch_of = np.full(len(self.edges), -1, dtype=np.int64)
        key = topology.edge_keys(self.edges[:, 0], self.edges[:, 1], len(self.nodes))
        order = np.argsort(key)
        for i, chain in enumerate(self.branches):
            k = topology.edge_keys(chain[:-1], chain[1:], len(self.nodes))
            branch_of[order[np.searchsorted(key[order], k)]] = i
        return Mesh(
            self.nodes,
            (CellBlock("line", self.edges),),
            point_data={"radius": self.radius},
            cell_data={"branch": [branch_of]},
        )


# ---------------------------------------------------------------------------
# Sampling
# ---------------------------------------------------------------------------


def _travel_order(domain: Domain) -> np.ndarray:
    """Boundary segment ids ring after ring in the direction of travel."""
    order = []
    for k in range(domain.ring_count):
        rows = np.arange(domain.ring_offsets[k], domain.ring_offsets[k + 1])
        order.append(rows[::-1] if domain.ring_reversed[k] else rows)
    return np.concatenate(order)


def _default_h(domain: Domain) -> float:
    """min(h_min / 2, perimeter / DEFAULT_SAMPLES), at least perimeter / MAX_DEFAULT_SAMPLES."""
    P = domain.points[: domain.boundary_point_count]
    S = domain.segments
    perimeter = float(np.hypot(*(P[S[:, 1]] - P[S[:, 0]]).T).sum())
    k = min(len(P), 6)
    dist, idx = cKDTree(P).query(P, k=k)
    ring = domain.segment_ring
    pos = np.arange(len(P)) - domain.ring_offsets[ring]
    size = np.diff(domain.ring_offsets)[ring]
    other_pos = idx - domain.ring_offsets[ring][:, None]
    same = ring[idx] == ring[:, None]
    step = np.abs(other_pos - pos[:, None]) % size[:, None]
    near = same & ((step <= 1) | (step == size[:, None] - 1))
    far = np.where(near, np.inf, dist)
    h_min = float(far.min()) if np.isfinite(far).any() else perimeter
    h = min(h_min / 2, perimeter / DEFAULT_SAMPLES)
    return max(h, perimeter / MAX_DEFAULT_SAMPLES)


def _sampled(domain: Domain, h: float | None):
    """Samples every ``h`` along the boundary, in travel order.

    Returns ``(points, succ, source)``: sample coordinates, the next sample
    along the boundary (domain on the left of each piece ``i -> succ[i]``) and
    the domain segment of each piece.
    """
    P = domain.points
    seg = domain.segments[_travel_order(domain)]
    a, b = P[seg[:, 0]], P[seg[:, 1]]
    if h is None:
        count = np.ones(len(seg), dtype=np.int64)
    else:
        length = np.hypot(*(b - a).T)
        with np.errstate(over="ignore"):  # float, inf for a tiny h: int64 would overflow
            # a ratio within 1e-7 above an integer is that integer: a regular polygon's
            # sides are perimeter / DEFAULT_SAMPLES long times an integer, and rounding
            # (a translated or scaled input) decided between two sample counts
            wanted = np.maximum(1, np.ceil(length / h * (1 - 1e-7)))
        total = float(wanted.sum())
        if total > MAX_SAMPLES:
            raise InputError(
                f"h = {h:.6g} would sample the boundary (perimeter {length.sum():.6g}) with "
                f"{total:.3g} points; at most {MAX_SAMPLES:,}: give a larger h",
                loc=("h",),
                code="too_many_samples",
            )
        count = wanted.astype(np.int64)
    order = _travel_order(domain)
    ring_of_seg = domain.segment_ring[order]
    last_of_ring = np.r_[ring_of_seg[1:] != ring_of_seg[:-1], True]
    return _resample(a, b, count, last_of_ring, order)


@njit(cache=True)
def _resample(a, b, count, last_of_ring, seg_id):
    """Points ``a + (b - a) j / count`` for each segment (``a`` itself exactly),
    the next sample of each (the first of the ring after a ring's last one)
    and the segment each piece comes from."""
    total = 0
    for s in range(count.shape[0]):
        total += count[s]
    pts = np.empty((total, 2))
    succ = np.empty(total, np.int64)
    source = np.empty(total, np.int64)
    k = 0
    ring_start = 0
    for s in range(count.shape[0]):
        c = count[s]
        dx = b[s, 0] - a[s, 0]
        dy = b[s, 1] - a[s, 1]
        for j in range(c):
            t = j / c
            pts[k, 0] = a[s, 0] + t * dx
            pts[k, 1] = a[s, 1] + t * dy
            succ[k] = k + 1
            source[k] = seg_id[s]
            k += 1
        if last_of_ring[s]:
            succ[k - 1] = ring_start
            ring_start = k
    return pts, succ, source


def _too_thin(exc: InputError, domain: Domain, source, cloud_ids) -> InputError:
    """The error for a boundary whose samples collide (a spike or a gap thinner
    than float64 resolves): located at the domain vertex starting the
    segment of the first sample named."""
    loc = exc.errors[0]["loc"] if exc.errors else []
    sample = int(loc[1]) if len(loc) > 1 and isinstance(loc[1], int) else 0
    seg = int(source[min(sample, len(source) - 1)])
    v = int(domain.segments[seg, 0])
    where = ("points", int(cloud_ids[v])) if cloud_ids is not None else domain.vertex_loc(v)
    return InputError(
        f"the boundary near {domain.vertex_name(v)} at {domain.points[v].tolist()} is too thin "
        "to sample: two of its segments nearly overlap, closer than float64 resolves; "
        "widen or remove that spike",
        loc=where,
        code="degenerate_boundary",
    )


def _admissible(pts, succ, source, progress):
    """Delaunay triangulation in which every piece is an edge (§9.1.4), found
    by splitting pieces, and its empty triangulation (step 3)."""
    res = admissible_segments(pts, np.column_stack([np.arange(len(pts)), succ]), progress=progress)
    succ2 = np.empty(len(res.points), dtype=np.int64)
    succ2[res.segments[:, 0]] = res.segments[:, 1]
    source2 = np.empty(len(res.points), dtype=np.int64)
    source2[res.segments[:, 0]] = source[res.source]
    tri = _along_boundary(res.delaunay.triangles, res.delaunay.neighbors, len(res.points))
    fill = _empty_triangulation(tri[0], tri[1], succ2)
    return res.points, succ2, source2, tri, res.added, fill


# ---------------------------------------------------------------------------
# Compiled kernels (sequential: a flood fill, a union-find, a heap of
# branches, walks along chains)
# ---------------------------------------------------------------------------


@njit(cache=True)
def _along_boundary(tri, nb, n):
    """The Delaunay triangles and their neighbour table with the rows in
    increasing order of each triangle's smallest sample index (stably), the
    samples being numbered along the boundary: neighbouring triangles then
    sit in nearby rows and read nearby samples, where the kernel's row order
    is spatially random and every later pass would read memory at random
    (module docstring, "Row order")."""
    m = tri.shape[0]
    start = np.zeros(n + 1, np.int64)
    for t in range(m):
        start[min(tri[t, 0], tri[t, 1], tri[t, 2]) + 1] += 1
    for v in range(n):
        start[v + 1] += start[v]
    row = np.empty(m, np.int64)
    for t in range(m):
        k = min(tri[t, 0], tri[t, 1], tri[t, 2])
        row[t] = start[k]
        start[k] += 1
    out_tri = np.empty((m, 3), np.int64)
    out_nb = np.empty((m, 3), np.int64)
    for t in range(m):
        r = row[t]
        for i in range(3):
            out_tri[r, i] = tri[t, i]
            u = nb[t, i]
            out_nb[r, i] = row[u] if u >= 0 else -1
    return out_tri, out_nb


@njit(cache=True)
def _empty_triangulation(tri, nb, succ):
    """Inside flags, boundary-edge flags and types of the Delaunay triangles.

    ``bnd[t, i]``: the edge opposite vertex ``i`` is a boundary piece. The
    fill starts from the triangles on the left of pieces and never crosses a
    piece. ``status[0]`` is -1 if the fill reaches the convex hull (the
    pieces do not bound a region); ``status[1]`` counts the pieces that are
    Delaunay edges (each found once: in the triangle on its left, or on its
    right for a hull edge), so that all are when it equals their number.
    """
    nt = tri.shape[0]
    bnd = np.zeros((nt, 3), np.bool_)
    inside = np.zeros(nt, np.bool_)
    stack = np.empty(nt, np.int64)
    top = 0
    found = 0
    for t in range(nt):
        for i in range(3):
            a = tri[t, (i + 1) % 3]
            b = tri[t, (i + 2) % 3]
            if succ[a] == b:
                bnd[t, i] = True
                found += 1
                if not inside[t]:
                    inside[t] = True
                    stack[top] = t
                    top += 1
            elif succ[b] == a:
                bnd[t, i] = True
                if nb[t, i] < 0:
                    found += 1
    status = np.zeros(2, np.int64)
    status[1] = found
    while top > 0:
        top -= 1
        t = stack[top]
        for i in range(3):
            if bnd[t, i]:
                continue
            u = nb[t, i]
            if u < 0:
                status[0] = -1
                continue
            if not inside[u]:
                inside[u] = True
                stack[top] = u
                top += 1
    ttype = np.zeros(nt, np.int8)
    for t in range(nt):
        ttype[t] = bnd[t, 0] + bnd[t, 1] + bnd[t, 2]
    return inside, bnd, ttype, status


@njit(cache=True)
def _offset_centre(pts, o, b, c):
    """Circumcentre of (o, b, c) relative to o (no large coordinates added)."""
    bx = pts[b, 0] - pts[o, 0]
    by = pts[b, 1] - pts[o, 1]
    cx = pts[c, 0] - pts[o, 0]
    cy = pts[c, 1] - pts[o, 1]
    b2 = bx * bx + by * by
    c2 = cx * cx + cy * cy
    den = 2.0 * (bx * cy - by * cx)
    return (cy * b2 - by * c2) / den, (bx * c2 - cx * b2) / den


@njit(cache=True)
def _renumber(keep):
    """The new index of each kept row (kept rows in order, -1 for the others) and
    their count."""
    new = np.full(keep.shape[0], -1, np.int64)
    k = 0
    for i in range(keep.shape[0]):
        if keep[i]:
            new[i] = k
            k += 1
    return new, k


@njit(cache=True)
def _voronoi_classes(pts, tri, nb, inside, bnd, ttype, tol):
    """The Voronoi graph's nodes and edges over the inside triangles (step 4),
    in one pass over the triangles and one over the classes.

    The inside triangles are renumbered in order (``keep``: their ids in
    ``tri``; ``T`` and ``types`` their rows). Across each interior edge
    ``p, q`` between inside triangles ``t < u``, both circumcentres are
    computed relative to ``p`` (so that the distance between them does not
    depend on where the domain lies: 0 up to rounding when the four vertices
    are co-circular); within ``tol`` the two triangles are one class
    (union-find), otherwise the edge joins their classes in the graph.
    Classes are numbered in the order of their first triangle.

    Returns ``keep, T, types, label, k, pairs, pq, merged, rep, centre,
    radius, spread``: the class of each kept triangle and the number of
    classes; the graph edges as class pairs with their Delaunay edges; the
    number of merged pairs; per class its first triangle, that triangle's
    circumcentre and circumradius, and the contact spread (radians: the
    largest angle two vertices of one of its triangles subtend at that
    triangle's centre, the minor arc; the arcsine taken once per class, of
    the largest chord-to-diameter ratio, as it is monotonic).
    """
    nt = tri.shape[0]
    remap, m = _renumber(inside)
    keep = np.empty(m, np.int64)
    T = np.empty((m, 3), np.int64)
    types = np.empty(m, np.int8)
    own = np.empty((m, 2))  # each triangle's circumcentre
    own_r = np.empty(m)
    ratio = np.empty(m)  # its longest edge over its circumdiameter
    parent = np.arange(m)
    cap = 3 * m // 2 + 1
    ends = np.empty((cap, 2), np.int64)
    pq = np.empty((cap, 2), np.int64)
    g = 0
    merged = 0
    for t in range(nt):
        if not inside[t]:
            continue
        row = remap[t]
        keep[row] = t
        types[row] = ttype[t]
        for i in range(3):
            T[row, i] = tri[t, i]
        ax = pts[tri[t, 0], 0]
        ay = pts[tri[t, 0], 1]
        bx = pts[tri[t, 1], 0] - ax
        by = pts[tri[t, 1], 1] - ay
        cx = pts[tri[t, 2], 0] - ax
        cy = pts[tri[t, 2], 1] - ay
        b2 = bx * bx + by * by
        c2 = cx * cx + cy * cy
        den = 2.0 * (bx * cy - by * cx)
        ux = (cy * b2 - by * c2) / den
        uy = (bx * c2 - cx * b2) / den
        own[row, 0] = ax + ux
        own[row, 1] = ay + uy
        r = math.hypot(ux, uy)
        own_r[row] = r
        chord = math.sqrt(max(b2, c2, (bx - cx) ** 2 + (by - cy) ** 2))
        ratio[row] = chord / (2.0 * r)
        for i in range(3):
            if bnd[t, i]:
                continue
            u = nb[t, i]
            if u < t:
                continue
            p = tri[t, (i + 1) % 3]
            q = tri[t, (i + 2) % 3]
            c = tri[t, i]
            d = c
            for j in range(3):
                if nb[u, j] == t:
                    d = tri[u, j]
            x1, y1 = _offset_centre(pts, p, q, c)
            x2, y2 = _offset_centre(pts, p, d, q)
            if math.hypot(x1 - x2, y1 - y2) <= tol:
                a = _find(parent, row)
                b = _find(parent, remap[u])
                if a < b:
                    parent[b] = a
                elif b < a:
                    parent[a] = b
                merged += 1
            else:
                ends[g, 0] = row
                ends[g, 1] = remap[u]
                pq[g, 0] = p
                pq[g, 1] = q
                g += 1
    label = np.full(m, -1, np.int64)
    rep = np.empty(m, np.int64)
    best = np.zeros(m)
    k = 0
    for i in range(m):
        root = _find(parent, i)
        if label[root] < 0:
            label[root] = k
            rep[k] = i
            k += 1
        c = label[root]
        label[i] = c
        if ratio[i] > best[c]:
            best[c] = ratio[i]
    centre = np.empty((k, 2))
    radius = np.empty(k)
    spread = np.empty(k)
    for c in range(k):
        centre[c, 0] = own[rep[c], 0]
        centre[c, 1] = own[rep[c], 1]
        radius[c] = own_r[rep[c]]
        spread[c] = 2.0 * math.asin(min(1.0, best[c]))
    pairs = np.empty((g, 2), np.int64)
    for e in range(g):
        pairs[e, 0] = label[ends[e, 0]]
        pairs[e, 1] = label[ends[e, 1]]
    out_pq = pq[:g].copy()
    return keep, T, types, label, k, pairs, out_pq, merged, rep[:k].copy(), centre, radius, spread


@njit(cache=True)
def _find(parent, x):
    root = x
    while parent[root] != root:
        root = parent[root]
    while parent[x] != root:
        nxt = parent[x]
        parent[x] = root
        x = nxt
    return root


@njit(cache=True)
def _classes(n, pairs):
    """Union-find labels 0..k-1 of ``n`` items joined by ``pairs``."""
    parent = np.arange(n)
    for r in range(pairs.shape[0]):
        a = _find(parent, pairs[r, 0])
        b = _find(parent, pairs[r, 1])
        if a != b:
            if a < b:
                parent[b] = a
            else:
                parent[a] = b
    label = np.full(n, -1, np.int64)
    k = 0
    for i in range(n):
        root = _find(parent, i)
        if label[root] < 0:
            label[root] = k
            k += 1
        label[i] = label[root]
    return label, k


@njit(cache=True)
def _compact(node_alive, edge_alive, edges, pq):
    """The surviving nodes (ids, old -> new map) and edges (renumbered, with
    their Delaunay edges), and the new degrees."""
    n = node_alive.shape[0]
    new_id, k = _renumber(node_alive)
    alive_nodes = np.empty(k, np.int64)
    for v in range(n):
        if new_id[v] >= 0:
            alive_nodes[new_id[v]] = v
    m = 0
    for e in range(edge_alive.shape[0]):
        if edge_alive[e]:
            m += 1
    out = np.empty((m, 2), np.int64)
    out_pq = np.empty((m, 2), np.int64)
    deg = np.zeros(k, np.int64)
    j = 0
    for e in range(edge_alive.shape[0]):
        if edge_alive[e]:
            a = new_id[edges[e, 0]]
            b = new_id[edges[e, 1]]
            out[j, 0] = a
            out[j, 1] = b
            out_pq[j, 0] = pq[e, 0]
            out_pq[j, 1] = pq[e, 1]
            deg[a] += 1
            deg[b] += 1
            j += 1
    return alive_nodes, new_id, out, out_pq, deg


@njit(cache=True)
def _with_corners(centre, rep, alive_nodes, T, edges, pq, ends, apex, pts):
    """Voronoi nodes (circumcentres, then the corners ``apex`` joined to the
    leaves ``ends``): positions, triangles (-1 for corners), seed samples,
    edges and their Delaunay edges (-1 for the corner edges)."""
    k = alive_nodes.shape[0]
    c = apex.shape[0]
    m = edges.shape[0]
    nodes = np.empty((k + c, 2))
    node_tri = np.empty(k + c, np.int64)
    seeds = np.full((k + c, 3), -1, np.int64)
    for i in range(k):
        t = rep[alive_nodes[i]]
        nodes[i, 0] = centre[alive_nodes[i], 0]
        nodes[i, 1] = centre[alive_nodes[i], 1]
        node_tri[i] = t
        for j in range(3):
            seeds[i, j] = T[t, j]
    out = np.empty((m + c, 2), np.int64)
    out_pq = np.full((m + c, 2), -1, np.int64)
    out[:m] = edges
    out_pq[:m] = pq
    for i in range(c):
        nodes[k + i, 0] = pts[apex[i], 0]
        nodes[k + i, 1] = pts[apex[i], 1]
        node_tri[k + i] = -1
        out[m + i, 0] = ends[i]
        out[m + i, 1] = k + i
    return nodes, node_tri, seeds, out, out_pq


@njit(cache=True)
def _csr(n, cells):
    """Incidence of ``n`` vertices in the rows of ``cells`` ((m, k) vertex ids:
    edges, quads): ``start`` (n + 1,) and the row ids ``inc`` (k m,), vertex
    ``v``'s rows being ``inc[start[v]:start[v + 1]]``."""
    m, k = cells.shape
    start = np.zeros(n + 1, np.int64)
    for e in range(m):
        for j in range(k):
            start[cells[e, j] + 1] += 1
    for v in range(n):
        start[v + 1] += start[v]
    fill = start[:-1].copy()
    inc = np.empty(k * m, np.int64)
    for e in range(m):
        for j in range(k):
            v = cells[e, j]
            inc[fill[v]] = e
            fill[v] += 1
    return start, inc


@njit(cache=True)
def _other_edge(start, inc, alive, v, e):
    """The alive edge of degree-2 node ``v`` other than ``e``."""
    for j in range(start[v], start[v + 1]):
        f = inc[j]
        if f != e and alive[f]:
            return f
    return -1


@njit(cache=True)
def _walk(edges, start, inc, alive, deg, v, e):
    """From node ``v`` along edge ``e`` through degree-2 nodes: (end node, last edge)."""
    cur = edges[e, 0] + edges[e, 1] - v
    steps = 0
    while deg[cur] == 2 and steps <= edges.shape[0]:
        f = _other_edge(start, inc, alive, cur, e)
        nxt = edges[f, 0] + edges[f, 1] - cur
        e = f
        cur = nxt
        steps += 1
    return cur, e


@njit(cache=True)
def _heap_push(hk, hv, hn, size, key, val, ver):
    i = size
    hk[i] = key
    hv[i] = val
    hn[i] = ver
    while i > 0:
        p = (i - 1) // 2
        if hk[p] <= hk[i]:
            break
        hk[p], hk[i] = hk[i], hk[p]
        hv[p], hv[i] = hv[i], hv[p]
        hn[p], hn[i] = hn[i], hn[p]
        i = p
    return size + 1


@njit(cache=True)
def _heap_pop(hk, hv, hn, size):
    key, val, ver = hk[0], hv[0], hn[0]
    size -= 1
    hk[0], hv[0], hn[0] = hk[size], hv[size], hn[size]
    i = 0
    while True:
        left = 2 * i + 1
        if left >= size:
            break
        c = left
        if left + 1 < size and hk[left + 1] < hk[left]:
            c = left + 1
        if hk[i] <= hk[c]:
            break
        hk[c], hk[i] = hk[i], hk[c]
        hv[c], hv[i] = hv[i], hv[c]
        hn[c], hn[i] = hn[i], hn[c]
        i = c
    return key, val, ver, size


@njit(cache=True)
def _significance(center, radius, pts, edge_pq, e):
    """Angle (radians) that dual edge ``e``'s Delaunay edge subtends at its junction."""
    p = edge_pq[e, 0]
    q = edge_pq[e, 1]
    chord = math.hypot(pts[p, 0] - pts[q, 0], pts[p, 1] - pts[q, 1])
    s = chord / (2.0 * radius)
    if s >= 1.0:
        return math.pi
    return 2.0 * math.asin(s)


@njit(cache=True)
def _prune(n, edges, edge_pq, center, cradius, spread, pts, threshold):
    """Remove terminal branches of significance below ``threshold`` (radians),
    least significant first (module docstring, step 5). Returns the alive
    flags of nodes and edges and the number of branches removed."""
    m = edges.shape[0]
    start, inc = _csr(n, edges)
    alive = np.ones(m, np.bool_)
    node_alive = np.ones(n, np.bool_)
    deg = np.diff(start)
    end = np.full(n, -1, np.int64)  # junction of the branch of each leaf
    last = np.full(n, -1, np.int64)  # its last edge, into the junction
    version = np.zeros(n, np.int64)
    leaf_of_edge = np.full(m, -1, np.int64)
    cap = 4 * n + 16
    hk = np.empty(cap)
    hv = np.empty(cap, np.int64)
    hn = np.empty(cap, np.int64)
    size = np.int64(0)  # typed, not literal: one compiled _heap_push / _heap_pop
    removed = 0
    if threshold <= 0.0:
        return node_alive, alive, 0
    for v in range(n):
        if deg[v] != 1:
            continue
        e0 = inc[start[v]]
        j, e = _walk(edges, start, inc, alive, deg, v, e0)
        if deg[j] >= 3:
            end[v] = j
            last[v] = e
            leaf_of_edge[e] = v
            key = _significance(center[j], cradius[j], pts, edge_pq, e)
            size = _heap_push(hk, hv, hn, size, key, v, version[v])
    while size > 0:
        key, leaf, ver, size = _heap_pop(hk, hv, hn, size)
        if ver != version[leaf] or not node_alive[leaf] or key >= threshold:
            continue
        j = end[leaf]
        if deg[j] < 3:
            continue
        # remove the chain leaf .. (node before j)
        v = leaf
        e = np.int64(-1)
        for j2 in range(start[v], start[v + 1]):
            if alive[inc[j2]]:
                e = inc[j2]
        while v != j:
            node_alive[v] = False
            alive[e] = False
            nxt = edges[e, 0] + edges[e, 1] - v
            if nxt == j:
                break
            e = _other_edge(start, inc, alive, nxt, e)
            v = nxt
        deg[j] -= 1
        removed += 1
        if deg[j] != 2:
            continue
        # j dissolves: a leaf whose branch ended at j through one of its two
        # edges now runs on through the other one
        ea = np.int64(-1)  # typed, not literal: one compiled _walk
        eb = np.int64(-1)
        for j2 in range(start[j], start[j + 1]):
            f = inc[j2]
            if alive[f]:
                if ea < 0:
                    ea = f
                else:
                    eb = f
        for side in range(2):
            f_in = ea if side == 0 else eb
            f_out = eb if side == 0 else ea
            lf = leaf_of_edge[f_in]
            if lf < 0 or not node_alive[lf] or end[lf] != j or last[lf] != f_in:
                continue
            j3, e3 = _walk(edges, start, inc, alive, deg, j, f_out)
            version[lf] += 1
            end[lf] = j3
            last[lf] = e3
            if deg[j3] >= 3:
                leaf_of_edge[e3] = lf
                key = _significance(center[j3], cradius[j3], pts, edge_pq, e3)
                if size >= cap:
                    continue
                size = _heap_push(hk, hv, hn, size, key, lf, version[lf])
    # Tails: a leaf whose own circle touches the boundary within less than the
    # threshold (the end of a smooth convex part, where the contacts close up
    # towards the osculating circle, Remark 9.11) goes, repeatedly.
    stack = np.empty(n, np.int64)
    top = 0
    for v in range(n):
        if node_alive[v] and deg[v] == 1 and spread[v] < threshold:
            stack[top] = v
            top += 1
    while top > 0:
        top -= 1
        v = stack[top]
        if not node_alive[v] or deg[v] != 1 or spread[v] >= threshold:
            continue
        for j2 in range(start[v], start[v + 1]):
            f = inc[j2]
            if alive[f]:
                alive[f] = False
                node_alive[v] = False
                deg[v] = 0
                w = edges[f, 0] + edges[f, 1] - v
                deg[w] -= 1
                if deg[w] == 1 and spread[w] < threshold:
                    stack[top] = w
                    top += 1
    # A component left as a path (no junction) is measured from its widest
    # node M: each half whose edge out of M is insignificant goes (a disk's
    # axis is its centre; an ellipse keeps the segment between its centres
    # of curvature).
    path_nodes = np.empty(n, np.int64)
    path_edges = np.empty(n, np.int64)
    for v in range(n):
        if not node_alive[v] or deg[v] != 1:
            continue
        k = 0
        cur = v
        e = np.int64(-1)
        for j2 in range(start[v], start[v + 1]):
            if alive[inc[j2]]:
                e = inc[j2]
        while True:
            path_nodes[k] = cur
            path_edges[k] = e
            k += 1
            nxt = edges[e, 0] + edges[e, 1] - cur
            if deg[nxt] != 2:
                path_nodes[k] = nxt
                break
            e = _other_edge(start, inc, alive, nxt, e)
            cur = nxt
        last_node = path_nodes[k]
        if deg[last_node] != 1 or last_node < v:
            continue  # not a path, or already done from its other end
        top = 0
        for i in range(k + 1):
            if cradius[path_nodes[i]] > cradius[path_nodes[top]]:
                top = i
        mid = path_nodes[top]
        if top > 0:  # the half towards v leaves M through path_edges[top - 1]
            key = _significance(center[mid], cradius[mid], pts, edge_pq, path_edges[top - 1])
            if key < threshold:
                for i in range(top):
                    node_alive[path_nodes[i]] = False
                    alive[path_edges[i]] = False
                deg[mid] -= 1
                removed += 1
        if top < k:  # the other half leaves M through path_edges[top]
            key = _significance(center[mid], cradius[mid], pts, edge_pq, path_edges[top])
            if key < threshold:
                for i in range(top, k):
                    alive[path_edges[i]] = False
                    node_alive[path_nodes[i + 1]] = False
                deg[mid] -= 1
                removed += 1
    return node_alive, alive, removed


@njit(cache=True)
def _piece_distance(x, y, pts, a, b):
    ax = pts[a, 0]
    ay = pts[a, 1]
    dx = pts[b, 0] - ax
    dy = pts[b, 1] - ay
    px = x - ax
    py = y - ay
    den = dx * dx + dy * dy
    t = (px * dx + py * dy) / den if den > 0 else 0.0
    if t < 0.0:
        t = 0.0
    elif t > 1.0:
        t = 1.0
    return math.hypot(px - t * dx, py - t * dy)


@njit(cache=True)
def _boundary_distance(nodes, seeds, on_boundary, pts, succ, pred):
    """Distance of each node to the boundary pieces, by descent along the
    boundary from each of its seed samples (both directions); 0 for the
    nodes that are samples (``on_boundary >= 0``)."""
    n = nodes.shape[0]
    out = np.zeros(n)
    for i in range(n):
        if on_boundary[i] >= 0:
            continue
        x = nodes[i, 0]
        y = nodes[i, 1]
        best = np.inf
        for k in range(seeds.shape[1]):
            s = seeds[i, k]
            if s < 0:
                continue
            for direction in range(2):
                v = s
                prev = np.inf
                for _ in range(pts.shape[0]):
                    w = succ[v] if direction == 0 else pred[v]
                    d = _piece_distance(x, y, pts, v, w)
                    if d < best:
                        best = d
                    if d >= prev:
                        break
                    prev = d
                    v = w
        out[i] = best
    return out


@njit(cache=True)
def _branches(n, edges):
    """Chains of edges between nodes of degree other than 2, then pure loops.
    Returns (offsets, node ids)."""
    start, inc = _csr(n, edges)
    deg = np.diff(start)
    m = edges.shape[0]
    used = np.zeros(m, np.bool_)
    alive = np.ones(m, np.bool_)
    ids = np.empty(2 * m + n + 1, np.int64)
    offsets = np.empty(m + 2, np.int64)
    offsets[0] = 0
    nb = 0
    k = 0
    for sweep in range(2):
        for v in range(n):
            if sweep == 0 and deg[v] == 2:
                continue
            for j in range(start[v], start[v + 1]):
                e = inc[j]
                if used[e]:
                    continue
                ids[k] = v
                k += 1
                cur = v
                while True:
                    used[e] = True
                    cur = edges[e, 0] + edges[e, 1] - cur
                    ids[k] = cur
                    k += 1
                    if deg[cur] != 2 or cur == v:
                        break
                    e = _other_edge(start, inc, alive, cur, e)
                    if used[e]:
                        break
                nb += 1
                offsets[nb] = k
    return offsets[: nb + 1], ids[:k]


# ---------------------------------------------------------------------------
# Point clouds (§9.4.2)
# ---------------------------------------------------------------------------


@njit(cache=True)
def _cycles(succ_a, succ_b):
    """The cycles of a graph in which every vertex has two links: a 2-regular
    graph (its two neighbours), or a permutation given twice. Returns
    (vertices in cycle order, cycle offsets)."""
    n = succ_a.shape[0]
    seen = np.zeros(n, np.bool_)
    order = np.empty(n, np.int64)
    offsets = np.empty(n + 1, np.int64)
    offsets[0] = 0
    k = 0
    r = 0
    for s in range(n):
        if seen[s]:
            continue
        prev = -1
        cur = s
        while not seen[cur]:
            seen[cur] = True
            order[k] = cur
            k += 1
            nxt = succ_a[cur] if succ_a[cur] != prev else succ_b[cur]
            prev = cur
            cur = nxt
        r += 1
        offsets[r] = k
    return order, offsets[: r + 1]


def cloud_points(points) -> np.ndarray:
    """The samples of a point cloud (§9.4.2) as an (n, 2) float64 array, checked.

    Raises InputError located at ``points`` (shape: ``bad_shape``; fewer than 3:
    ``too_few_points``) or at the first bad point ``("points", i)`` (``non_finite``;
    ``out_of_range``: a coordinate above ``MAX_COORDINATE``, where squared distances
    overflow). The service runs it when a job is submitted.
    """
    try:
        P = np.asarray(points, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(
            "points must be a list of [x, y] positions", loc=("points",), code="bad_shape"
        ) from exc
    if P.ndim != 2 or P.shape[1] != 2:
        raise InputError(
            f"points must have shape (n, 2), got {P.shape}", loc=("points",), code="bad_shape"
        )
    n = len(P)
    if n < 3:
        raise InputError(
            f"a point cloud needs at least 3 points, got {n}",
            loc=("points",),
            code="too_few_points",
        )
    bad = np.flatnonzero(~np.isfinite(P).all(axis=1))
    if bad.size:
        raise InputError(
            f"point {bad[0]} is not finite: {P[bad[0]].tolist()}",
            loc=("points", int(bad[0])),
            code="non_finite",
        )
    big = np.flatnonzero(np.abs(P).max(axis=1) > MAX_COORDINATE)
    if big.size:
        raise InputError(
            f"point {big[0]} has a coordinate of magnitude above {MAX_COORDINATE:g}",
            loc=("points", int(big[0])),
            code="out_of_range",
        )
    return P


def _cloud_domain(points) -> tuple[Domain, np.ndarray]:
    """Closed curves through the samples (NN-crust), as a validated domain.

    Returns the domain and, per domain point, the index of its sample.
    """
    P = cloud_points(points)
    n = len(P)
    k = min(n, 16)
    dist, idx = cKDTree(P).query(P, k=k)
    dup = np.flatnonzero(dist[:, 1] == 0)
    if dup.size:
        i = int(dup[0])
        raise InputError(
            f"points {min(i, idx[i, 1])} and {max(i, idx[i, 1])} coincide at {P[i].tolist()}",
            loc=("points", int(max(i, idx[i, 1]))),
            code="duplicate_points",
        )
    nn = idx[:, 1]
    towards = P[nn] - P
    cand = idx[:, 2:]
    dots = np.einsum("ikj,ij->ik", P[cand] - P[:, None, :], towards)
    ok = dots <= 0
    has = ok.any(axis=1)
    half = np.where(has, cand[np.arange(n), np.argmax(ok, axis=1)], -1)
    lone = np.flatnonzero(~has)
    if lone.size:
        i = int(lone[0])
        raise InputError(
            f"point {i} at {P[i].tolist()} has no neighbour on the side away from its nearest "
            f"point {nn[i]}: the cloud does not sample a closed curve there (sample more densely)",
            loc=("points", i),
            code="not_a_curve",
        )
    pairs = np.concatenate(
        [np.column_stack([np.arange(n), nn]), np.column_stack([np.arange(n), half])]
    )
    pairs = np.unique(np.sort(pairs, axis=1), axis=0)
    degree = np.bincount(pairs.ravel(), minlength=n)
    wrong = np.flatnonzero(degree != 2)
    if wrong.size:
        i = int(wrong[0])
        raise InputError(
            f"point {i} at {P[i].tolist()} joins {degree[i]} neighbours instead of 2: the cloud "
            "does not sample closed simple curves densely enough there",
            loc=("points", i),
            code="not_a_curve",
        )
    ends = np.concatenate([pairs, pairs[:, ::-1]])
    ends = ends[np.argsort(ends[:, 0], kind="stable")]
    # contiguous columns: the layout partitioning's call compiles _cycles for
    order, offsets = _cycles(
        np.ascontiguousarray(ends[0::2, 1], dtype=np.int64),
        np.ascontiguousarray(ends[1::2, 1], dtype=np.int64),
    )
    short = np.flatnonzero(np.diff(offsets) < 3)
    if short.size:
        i = int(order[offsets[short[0]]])
        raise InputError(
            f"the curve through point {i} closes after fewer than 3 points",
            loc=("points", i),
            code="not_a_curve",
        )
    rings = [order[offsets[r] : offsets[r + 1]] for r in range(len(offsets) - 1)]
    # nesting: the rings containing one vertex of each ring, by exact ray parity
    seg_ring = np.repeat(np.arange(len(rings)), [len(r) for r in rings])
    p0 = P[order]
    nxt = np.concatenate([np.roll(r, -1) for r in rings])
    p1 = P[nxt]
    probe = P[[r[0] for r in rings]]
    hits = ray_parity(probe, np.arange(len(rings)), p0, p1, seg_ring, len(rings))
    depth = np.bincount(hits[:, 0], minlength=len(rings))
    parent = np.full(len(rings), -1)
    for q, ring in hits:
        if depth[ring] == depth[q] - 1:
            parent[q] = ring
    polygons: list[list[np.ndarray]] = []
    slot = {}
    for r in np.flatnonzero(depth % 2 == 0):
        slot[int(r)] = len(polygons)
        polygons.append([rings[r]])
    for r in np.flatnonzero(depth % 2 == 1):
        polygons[slot[int(parent[r])]].append(rings[r])
    ids = np.concatenate([ring for poly in polygons for ring in poly])
    coords = [[P[ring].tolist() for ring in poly] for poly in polygons]
    geometry = (
        {"type": "Polygon", "coordinates": coords[0]}
        if len(coords) == 1
        else {"type": "MultiPolygon", "coordinates": coords}
    )
    try:
        domain = parse_domain(geometry)
    except InputError as exc:
        raise InputError(
            f"the curves reconstructed from the point cloud are not a valid domain: {exc.message}",
            loc=("points",),
            code="not_a_curve",
        ) from None
    return domain, ids


# ---------------------------------------------------------------------------
# The entry point
# ---------------------------------------------------------------------------


def medial_axis(
    domain: Domain | None = None,
    *,
    points=None,
    h: float | None = None,
    prune: float = DEFAULT_PRUNE,
    approximation: str = "voronoi",
    progress: Progress | None = None,
) -> MedialAxis:
    """The medial axis of a polygon (holes allowed) or of a boundary point cloud.

    Parameters
    ----------
    domain : Domain or GeoJSON mapping, optional
        From :func:`meshcore.domain.planar.parse_domain`, or parsed here; its
        constraints are ignored.
    points : (n, 2) float64, optional
        Instead of ``domain``: samples of closed boundary curves (§9.4.2).
    h : float, optional
        Boundary sampling step (default: see the module docstring; for a
        point cloud, the samples as given).
    prune : float
        Degrees: terminal branches less significant than this are removed
        (module docstring, step 5); 0 keeps every branch.
    approximation : {"voronoi", "midpoints"}
        Circumcentres (Theorem 9.1) or midpoints of interior edges (Remark 9.14).
    progress : callable, optional
        ``progress(fraction, message)``; it may raise to cancel.

    Returns
    -------
    MedialAxis
        Every node lies inside the domain's closure, radii are distances to
        the boundary, every node of a surviving branch is connected to the
        rest (one component per component of the domain), and the axis has
        one independent loop per hole.

    Raises
    ------
    InputError
        Both or neither of ``domain`` and ``points``; a bad ``h``, ``prune``
        or ``approximation``; a point cloud that is not a dense sampling of
        closed simple curves (naming the point).
    AlgorithmError
        As :func:`meshcore.delaunay.admissible.admissible_segments`.

    References
    ----------
    Methods text §9.4.1-§9.4.3, Remarks 9.10-9.14.
    """
    args = {"points": points, "h": h, "approximation": approximation, "progress": progress}
    return next(pruned_axes(domain, prunes=(prune,), **args))


def pruned_axes(
    domain: Domain | None = None,
    *,
    points=None,
    h: float | None = None,
    prunes=(DEFAULT_PRUNE,),
    approximation: str = "voronoi",
    progress: Progress | None = None,
) -> Iterator[MedialAxis]:
    """:func:`medial_axis` pruned at each angle of ``prunes`` in turn, the samples,
    triangulation and Voronoi graph built once (only step 5 on depends on the angle):
    the same axes as one call per angle, each made when the next is asked for."""
    timings: dict[str, float] = {}
    clock = [time.perf_counter()]

    def report(fraction: float, message: str, phase: str | None = None) -> None:
        if phase is not None:
            now = time.perf_counter()
            timings[phase] = round(now - clock[0], 6)
            clock[0] = now
        if progress is not None:
            progress(fraction, message)

    if (domain is None) == (points is None):
        raise InputError("give exactly one of domain and points", loc=(), code="bad_input")
    if domain is not None:
        domain = as_domain(domain)
    if approximation not in ("voronoi", "midpoints"):
        raise InputError(
            f"approximation must be 'voronoi' or 'midpoints', got {approximation!r}",
            loc=("approximation",),
            code="bad_value",
        )
    for prune in prunes:  # (a loop over the few angles asked for)
        if not (isinstance(prune, int | float) and math.isfinite(prune) and 0 <= prune <= 180):
            raise InputError(
                f"prune must be an angle in degrees in [0, 180], got {prune!r}",
                loc=("prune",),
                code="bad_value",
            )
    if h is not None and not (isinstance(h, int | float) and math.isfinite(h) and h > 0):
        raise InputError(f"h must be a positive number, got {h!r}", loc=("h",), code="bad_value")
    if domain is None:
        domain, cloud_ids = _cloud_domain(points)
    elif h is None:
        h = _default_h(domain)
    if not domain.diameter >= MIN_DIAMETER:
        raise InputError(
            f"the {'points span' if points is not None else 'domain spans'} only "
            f"{domain.diameter:.3g}: circumcentres need a diameter of at least {MIN_DIAMETER:g} "
            "(squared distances underflow float64); scale the input up",
            loc=("points",) if points is not None else ("domain",),
            code="out_of_range",
        )
    report(0.05, "sampling the boundary")
    pts, succ, source = _sampled(domain, h)
    h_used = float(h) if h is not None else float(np.hypot(*(pts[succ] - pts).T).max())
    report(0.1, f"Delaunay triangulation of {len(pts)} boundary samples", "sampling")
    thin = None if points is None else cloud_ids
    try:
        dt = delaunay(pts)
    except InputError as exc:  # samples of two nearly overlapping segments coincide
        raise _too_thin(exc, domain, source, thin) from None
    report(0.5, "typing the triangles", "delaunay")
    added = 0
    tri = _along_boundary(dt.triangles, dt.neighbors, len(pts))
    fill = _empty_triangulation(tri[0], tri[1], succ)
    if fill[3][1] < len(pts):  # some piece is not a Delaunay edge
        try:
            pts, succ, source, tri, added, fill = _admissible(pts, succ, source, progress)
        except InputError as exc:
            raise _too_thin(exc, domain, source, thin) from None
    inside, bnd, ttype, status = fill
    if status[0] < 0:
        raise AlgorithmError("the boundary pieces do not bound the domain (fill leaked)")
    tol = TOLERANCES.node_merge * domain.diameter
    graph = _voronoi_classes(pts, tri[0], tri[1], inside, bnd, ttype, tol)
    keep, T, types, label, n_nodes, g_edges, g_pq, n_merged, rep, centre, cradius, spread = graph
    report(0.6, "Voronoi graph", "types")
    class_type2 = np.full(n_nodes, -1, dtype=np.int64)
    t2 = np.flatnonzero(types == 2)
    class_type2[label[t2]] = t2
    pred = topology.inverse_permutation(succ)
    counts = np.bincount(types, minlength=4)
    for prune in prunes:  # the pruning and what depends on it, per angle
        node_alive, edge_alive, pruned = _prune(
            n_nodes, g_edges, g_pq, centre, cradius, spread, pts, math.radians(prune)
        )
        report(0.75, "terminal nodes and radii", "graph_and_pruning")
        alive_nodes, new_id, edges, pq, deg = _compact(node_alive, edge_alive, g_edges, g_pq)
        # Type 2 leaves at a corner reach it (the sample shared by both boundary
        # edges, where the boundary turns by at least the pruning angle)
        ends = np.flatnonzero((deg == 1) & (class_type2[alive_nodes] >= 0))
        t_end = class_type2[alive_nodes[ends]]
        apex_col = np.argmin(bnd[keep[t_end]], axis=1)  # the vertex opposite the interior edge
        apex = T[t_end, apex_col]
        din = pts[apex] - pts[pred[apex]]
        dout = pts[succ[apex]] - pts[apex]
        turn = np.degrees(
            np.arctan2(np.abs(din[:, 0] * dout[:, 1] - din[:, 1] * dout[:, 0]), (din * dout).sum(1))
        )
        corner = turn >= prune
        ends, apex = ends[corner], apex[corner]
        if approximation == "voronoi":
            nodes, node_tri, seeds, edges, edge_pq = _with_corners(
                centre, rep, alive_nodes, T, edges, pq, ends, apex, pts
            )
            triangle_node = new_id[label]
        else:
            nodes, seeds, node_tri, edges = _midpoint_graph(
                pts, T, rep, alive_nodes, edges, pq, deg, ends, apex, label
            )
            triangle_node = np.full(len(T), -1, dtype=np.int64)
            edge_pq = np.full((len(edges), 2), -1, dtype=np.int64)
        node_sample = np.full(len(nodes), -1, dtype=np.int64)
        node_sample[len(nodes) - len(apex) :] = apex
        radius = _boundary_distance(nodes, seeds, node_sample, pts, succ, pred)
        report(0.9, "branches", "nodes_and_radii")
        offsets, ids = _branches(len(nodes), edges)
        branches = tuple(ids[offsets[i] : offsets[i + 1]] for i in range(len(offsets) - 1))
        deg = np.bincount(edges.ravel(), minlength=len(nodes))
        stats = {
            "h": h_used,
            "samples": int(len(pts)),
            "points_added": int(added),
            "triangles": int(len(T)),
            "triangle_types": {f"type{i}": int(counts[i]) for i in range(4)},
            "merged_pairs": int(n_merged),
            "nodes": int(len(nodes)),
            "edges": int(len(edges)),
            "critical": int((deg >= 3).sum()),
            "terminal": int((deg == 1).sum()),
            "branches": len(branches),
            "branches_pruned": int(pruned),
        }
        report(1.0, "done", "branches")
        stats["seconds"] = dict(timings)
        yield MedialAxis(
            nodes=nodes,
            radius=radius,
            edges=edges,
            branches=branches,
            h=h_used,
            domain=domain,
            samples=pts,
            succ=succ,
            segment_source=source,
            triangles=T,
            triangle_type=types,
            node_triangle=node_tri,
            triangle_node=triangle_node,
            node_sample=node_sample,
            edge_pq=edge_pq,
            stats=stats,
        )


def _midpoint_graph(pts, T, rep, alive_nodes, edges, g_pq, deg, ends, apex, label):
    """Remark 9.14: nodes at the midpoints of the crossed interior edges, the
    junctions (degree 3 or more) at their triangles' centroids, the Type 2
    ends joined to their apexes."""
    n_alive = len(alive_nodes)
    mid = 0.5 * (pts[g_pq[:, 0]] + pts[g_pq[:, 1]])
    m = len(edges)
    junction = np.flatnonzero(deg >= 3)
    junction_id = np.full(n_alive, -1, dtype=np.int64)
    junction_id[junction] = m + np.arange(len(junction))
    tri_of = rep[alive_nodes]
    centroid = pts[T[tri_of[junction]]].mean(axis=1)
    apex_id = m + len(junction) + np.arange(len(apex))
    # incidences (graph node, axis edge): consecutive midpoints through a
    # regular node, spokes from a junction's centroid
    inc_node = edges.ravel()
    inc_edge = np.repeat(np.arange(m), 2)
    order = np.argsort(inc_node, kind="stable")
    inc_node, inc_edge = inc_node[order], inc_edge[order]
    first = np.searchsorted(inc_node, np.arange(n_alive))
    regular = np.flatnonzero(deg == 2)
    links = [np.column_stack([inc_edge[first[regular]], inc_edge[first[regular] + 1]])]
    at_junction = np.isin(inc_node, junction)
    links.append(np.column_stack([junction_id[inc_node[at_junction]], inc_edge[at_junction]]))
    links.append(np.column_stack([inc_edge[first[ends]], apex_id]))
    nodes = np.concatenate([mid, centroid, pts[apex]])
    seeds = np.concatenate(
        [
            np.column_stack([g_pq, np.full(m, -1)]),
            T[tri_of[junction]],
            np.full((len(apex), 3), -1),
        ]
    )
    node_tri = np.concatenate([np.full(m, -1), tri_of[junction], np.full(len(apex), -1)])
    return nodes, seeds.astype(np.int64), node_tri, np.concatenate(links).astype(np.int64)
